"""One self-contained HTML page per experiment: every figure embedded, no script, no network.

Sections follow the story of the paper: raw captures → conditioning → the model (matrices,
transfer functions, poles/zeros, k and τ with intervals) → fit and residuals → order
evidence and the stages of ``--method auto`` → sensitivity to record length and sample
interval → validation on other inputs → the controller, when a design is given.  The page
uses print CSS so that "Print to PDF" gives a report a student can hand in.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from motorid.capture import Capture
from motorid.identify.pipeline import Identification
from motorid.model.notation import poly_text
from motorid.report import figures

__all__ = ["SECTIONS", "ReportInputs", "build_report"]

#: Section ids, in page order (the headless-browser test checks they all render).
SECTIONS: tuple[str, ...] = (
    "summary", "captures", "conditioning", "current", "model", "fit", "order", "stages",
    "sensitivity", "validation", "design",
)

_CSS = """
body{font-family:system-ui,-apple-system,'Segoe UI',sans-serif;max-width:60rem;margin:1.5rem auto;
padding:0 1rem;color:#222;line-height:1.45}
h1{font-size:1.6rem;margin-bottom:.2rem}h2{font-size:1.25rem;border-bottom:1px solid #ccc;margin-top:2rem}
table{border-collapse:collapse;margin:.6rem 0;font-size:.9rem}td,th{border:1px solid #bbb;padding:.2rem .5rem;
text-align:right}th{background:#f2f2f2}td.l,th.l{text-align:left}img{max-width:100%;height:auto}
.muted{color:#666;font-size:.85rem}.warn{color:#8a5300}code,pre{font-family:ui-monospace,monospace;font-size:.85rem}
pre{background:#f7f7f7;padding:.5rem;overflow-x:auto}section{page-break-inside:avoid}
@media print{body{max-width:none;margin:0}h2{page-break-after:avoid}img{max-width:95%}section{break-inside:avoid}}
"""


@dataclass(frozen=True, slots=True)
class ReportInputs:
    """Everything a report can show; only ``identification`` is required.

    Attributes
    ----------
    identification : Identification
        The result of :func:`motorid.identify.pipeline.identify_experiment`.
    captures : Mapping[str, Capture]
        The raw captures by role.
    validation : Mapping[str, Capture]
        Captures of other inputs (sine, triangle, square…) to validate the model on.
    sweep : Any
        A :class:`motorid.analysis.sweep.SweepResult` or ``None``.
    design : Mapping or None
        A design JSON (``motorid.design/1``) and, under ``"simulation"``, a closed-loop run
        ``{"time": [...], "series": {name: [...]}, "metrics": {...}}``; ``"modes_png"``: bytes.
    truth : Mapping or None
        The trainer's ``truth.json`` (shown beside the model for the demo).
    title : str
        Page title.
    """

    identification: Identification
    captures: Mapping[str, Capture] = field(default_factory=dict)
    validation: Mapping[str, Capture] = field(default_factory=dict)
    sweep: Any = None
    design: Mapping[str, Any] | None = None
    truth: Mapping[str, Any] | None = None
    title: str = "motorid report"


def _img(data: bytes, alt: str) -> str:
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{base64.b64encode(data).decode()}">'


def _table(head: list[str], rows: list[list[Any]]) -> str:
    def cell(x: Any, tag: str, first: bool) -> str:
        text = f"{x:.5g}" if isinstance(x, (float, np.floating)) else html.escape(str(x))
        return f'<{tag}{" class=l" if first else ""}>{text}</{tag}>'

    out = ["<table><tr>" + "".join(cell(h, "th", i == 0) for i, h in enumerate(head)) + "</tr>"]
    for r in rows:
        out.append("<tr>" + "".join(cell(x, "td", i == 0) for i, x in enumerate(r)) + "</tr>")
    return "".join(out) + "</table>"


def _matrix(name: str, m: np.ndarray) -> str:
    rows = "\n".join("  [" + ", ".join(f"{x: .5g}" for x in row) + "]" for row in np.atleast_2d(m))
    return f"<pre>{html.escape(name)} =\n{rows}</pre>"


def _section(sid: str, title: str, body: str) -> str:
    return f'<section id="{sid}"><h2>{html.escape(title)}</h2>{body}</section>'


def _safe(sid: str, title: str, make: Callable[[], str]) -> str:
    """A section that cannot be drawn says why instead of breaking the page."""
    try:
        return _section(sid, title, make())
    except Exception as exc:
        return _section(sid, title, f'<p class="warn">not available: {html.escape(str(exc))}</p>')


def build_report(inp: ReportInputs) -> str:
    """Build the HTML page.

    Parameters
    ----------
    inp : ReportInputs
        The identification and whatever else is available.

    Returns
    -------
    str
        A complete, self-contained HTML document.
    """
    ident = inp.identification
    model = ident.model
    cond = ident.conditioned
    fo = model.first_order()
    parts: list[str] = []

    def summary() -> str:
        u = model.uncertainty
        rows: list[list[Any]] = [
            ["method", model.method], ["order (states)", model.order], ["step", f"{cond.step_volts:.4g} V"],
            ["dc gain", f"{fo.dc_gain:.5g} V/V"], ["τ", f"{fo.time_constant_s:.5g} s"],
            ["k/(s+p)", f"{fo.k:.5g}/(s + {fo.p:.5g})"]]
        if u:
            for key, label in (("dc_gain", "dc gain 95%"), ("time_constant", "τ 95%")):
                lo, hi = u[key]["ci95"]
                rows.append([label, f"[{lo:.5g}, {hi:.5g}]"])
        if model.delay_s > 0:
            rows.append(["dead time", f"{1e3 * model.delay_s:.4g} ms "
                                      f"(τ + dead time {fo.time_constant_s + model.delay_s:.5g} s)"])
        for key, val in model.fit.items():
            shown = f"{val:.2f} %" if key.endswith("_fit_percent") else f"{100 * val:.2f} %"
            rows.append([f"fit {key}", shown])
        sanity = model.extras.get("sanity")
        if isinstance(sanity, dict):
            rows.append(["sanity checks", "all passed" if sanity.get("passed") else
                         f"{sum(not c['passed'] for c in sanity.get('checks', []))} FAILED (see the warnings)"])
        if inp.truth:
            tf = inp.truth.get("transfer_functions", {}).get("first_order", {})
            if tf:
                rows.append(["trainer truth (linearised)",
                             f"dc gain {tf['dc_gain']:.5g}, τ {tf['time_constant']:.5g} s"])
        body = _table(["", "value"], rows)
        body += f"<p>{html.escape(ident.reason)}</p>"
        for note in model.extras.get("conditioning", []) or []:
            body += f"<p class=muted>{html.escape(str(note))}</p>"
        if model.warnings:
            body += "<ul>" + "".join(f'<li class="warn">{html.escape(w)}</li>' for w in model.warnings) + "</ul>"
        files = ", ".join(f"{html.escape(r)}: {html.escape(s)}" for r, s in cond.sources.items())
        body += "<p class=muted>Files: " + files + "</p>"
        return body

    parts.append(_safe("summary", "Summary", summary))
    parts.append(_safe("captures", "Raw captures (as recorded)",
                       lambda: _img(figures.raw_captures(inp.captures), "raw captures") if inp.captures
                       else "<p>no raw captures given</p>"))
    parts.append(_safe("conditioning", "Conditioned signals: synchronised, unwrapped, reduced, differentiated",
                       lambda: _img(figures.conditioned_signals(cond), "conditioned signals")
                       + f"<p class=muted>step edge per capture; reduction ratio {cond.ratio} "
                         f"({cond.settings.reduction}); sample interval after reduction "
                         f"{cond.sample_interval_s:.4g} s</p>"))
    parts.append(_safe("current", "Armature current: recorded and FFT-denoised",
                       lambda: _img(figures.current_denoising(cond), "current") if "current" in cond.full_outputs
                       else "<p>no current capture given</p>"))

    def model_section() -> str:
        body = _matrix("A", model.A) + _matrix("B", model.B) + _matrix("C", model.C) + _matrix("D", model.D)
        body += f"<p class=muted>states: {', '.join(model.states)}; outputs: {', '.join(model.outputs)}</p>"
        for name in ("velocity", "position", "current"):
            tf = getattr(model, f"{name}_tf")
            if tf is None:
                continue
            num, den = np.ravel(tf.num[0][0]), np.ravel(tf.den[0][0])
            body += (f"<p><code>H_{name}(s) = ({html.escape(poly_text(num))}) / "
                     f"({html.escape(poly_text(den))})</code></p>")
        body += (f"<p>first order: <code>k/(s+p) = {fo.k:.5g}/(s + {fo.p:.5g})</code>, dc gain {fo.dc_gain:.5g}, "
                 f"τ = {fo.time_constant_s:.5g} s</p>")
        u = model.uncertainty
        if u:
            rows = [[k, u[k]["value"], u[k]["std"], f"[{u[k]['ci95'][0]:.5g}, {u[k]['ci95'][1]:.5g}]"]
                    for k in ("dc_gain", "time_constant")]
            for key in ("poles", "zeros"):
                for i, item in enumerate(u.get(key, [])):
                    rows.append([f"{key[:-1]} {i + 1}", f"{item['value'][0]:.5g}{item['value'][1]:+.3g}j",
                                 item["std"], f"[{item['ci95'][0]}, {item['ci95'][1]}]"])
            body += _table(["quantity", "value", "std", "95% interval"], rows)
            body += ("<p class=muted>What the intervals include: the noise of every channel (its AR model), "
                     "the nuisance parameters fitted with the model (pre-step levels, capture timing, the "
                     "encoder span, the dead time), the error of the step level read off the input channel"
                     + (", and the uncertainty of the structure itself (BIC-weighted spread of the candidate "
                        "structures)" if "structure_std" in u.get("dc_gain", {}) else "")
                     + f". Method: {html.escape(str(u.get('method', '')))}</p>")
        noise = model.extras.get("noise")
        if noise:
            body += "<p>noise model of the output-error fit (AR whitening of each channel's residuals):</p>"
            body += _table(["channel", "innovation σ (V)", "AR order", "pre-step σ (V)", "used for"],
                           [[role, nm["sigma"], nm["ar_order"], nm.get("pre_step_sigma", ""),
                             "its scale only: 8-bit codes not dithered by noise" if nm["use"] == "scale only"
                             else "the dynamics"] for role, nm in noise.items()])
        body += _img(figures.pole_zero(model), "pole-zero map")
        return body

    parts.append(_safe("model", "The identified model", model_section))
    parts.append(_safe("fit", "Measured vs model step response, with residuals",
                       lambda: _img(figures.step_fit(model, cond), "step fit")))

    def order_section() -> str:
        mk = ident.candidates.get("markov")
        if mk is None or "hankel_singular_values_scaled" not in mk.extras:
            return "<p>the Markov method was not run</p>"
        ex = mk.extras
        if ex.get("markov_basis") == "laguerre":
            sv = ex["hankel_singular_values_scaled"]
            floor = ex["hankel_noise_floor"]
            rows = [[i + 1, x, "above" if x > floor else "below"] for i, x in enumerate(sv)]
            coef = [[k, g, sd] for k, (g, sd) in enumerate(zip(ex["laguerre_coefficients"],
                                                               ex["laguerre_coefficients_std"], strict=False))]
            return (f"<p>Generalised Markov parameters on a Laguerre basis: pole a = {ex['laguerre_pole']:.4g} 1/s, "
                    f"N = {ex['laguerre_terms']} terms; DC gain from the coefficients √(2/a)·Σ(−1)ᵏg_k = "
                    f"{ex['laguerre_dc_gain']:.5g} ± {ex['laguerre_dc_gain_std']:.2g}.</p>"
                    + _table(["k", "σ_k / σ_1", f"vs noise floor {floor:.3g}"], rows)
                    + "<p>Laguerre coefficients:</p>" + _table(["k", "g_k", "std"], coef)
                    + f"<p class=muted>{html.escape(str(ex.get('markov_choice', '')))}</p>")
        return (_img(figures.hankel_values(ex["hankel_singular_values_scaled"], ex["hankel_singular_values_raw"],
                                           ex.get("hankel_noise_floor")), "Hankel singular values")
                + f"<p class=muted>{html.escape(str(ex.get('markov_choice', '')))}</p>")

    parts.append(_safe("order", "Order evidence: Hankel singular values", order_section))

    def stages_section() -> str:
        if not model.stages:
            return f"<p>single method: {html.escape(model.method)}</p>"
        rows = []
        for st in model.stages:
            rows.append([st.get("stage"), st.get("method", ""), st.get("order", ""),
                         st.get("dc_gain", ""), st.get("time_constant", ""),
                         "" if st.get("velocity_nrmse") is None else f"{100 * st['velocity_nrmse']:.2f} %",
                         st.get("evidence", st.get("failed", ""))])
        return _table(["stage", "method", "order", "dc gain", "τ (s)", "NRMSE", "note"], rows)

    parts.append(_safe("stages", "Stages of the identification", stages_section))

    def sweep_section() -> str:
        sw = inp.sweep
        if sw is None:
            return "<p>no sensitivity table computed</p>"
        rows = [[f"{1000 * dt:g} ms"]
                + [f"k = {sw.k[i, j]:.4f}, τ = {sw.tau_s[i, j]:.4f}" for j in range(len(sw.lengths_s))]
                for i, dt in enumerate(sw.intervals_s)]
        sp = sw.spread()
        return (_table(["ΔT"] + [f"{x:g} s" for x in sw.lengths_s], rows)
                + f"<p>method {html.escape(sw.method)}; spread k ±{100 * sp['k']:.1f} %, τ ±{100 * sp['tau']:.1f} %</p>"
                + _img(figures.sweep_maps(sw.lengths_s, sw.intervals_s, sw.k, sw.tau_s), "sensitivity maps"))

    parts.append(_safe("sensitivity", "Sensitivity to record length and sample interval", sweep_section))

    def validation_section() -> str:
        if not inp.validation:
            return "<p>no validation captures given (<code>--validate CAP...</code>)</p>"
        from motorid.errors import MotorIdError
        from motorid.analysis.validation import validate_capture

        body, rows = "", []
        for name, cap in inp.validation.items():
            try:
                r = validate_capture(model, cap)
            except MotorIdError as exc:
                rows.append([name, "—", "—", "—", f"not validated: {exc.message}"])
                continue
            rows.append([name, f"{100 * r.nrmse:.2f} %", f"{r.fit_percent:.1f} %", f"{r.offset_v:+.4g} V",
                         "; ".join(r.notes + r.warnings)])
            body += _img(figures.validation_overlay(r.time_s, r.input_v, r.measured_v, r.simulated_v,
                                                    f"{name}: NRMSE {100 * r.nrmse:.2f} %, fit {r.fit_percent:.1f} %"),
                         name)
        definition = ("<p>NRMSE = RMS(measured − model) / measured change of the response (a step: its "
                      "steady-state change; other inputs: its P99 − P1 span); fit = 100·(1 − ‖y − ŷ‖/‖y − ȳ‖), "
                      "MATLAB <code>compare</code>'s fit. The model's initial state and an output offset are "
                      "estimated by least squares over the whole record.</p>")
        return _table(["capture", "NRMSE", "fit", "offset", "notes"], rows) + definition + body

    parts.append(_safe("validation", "Validation on other inputs", validation_section))

    def design_section() -> str:
        d = inp.design
        if not d:
            return "<p>no controller design given (<code>--design d.json</code>)</p>"
        rows = [[k, str(d.get(k))] for k in ("K", "kr", "ki", "L", "closed_loop_poles", "observer_poles")
                if d.get(k) is not None]
        body = _table(["", "value"], rows)
        if d.get("routh"):
            body += "<p>Routh–Hurwitz: " + "; ".join(html.escape(str(x)) for x in d["routh"]) + "</p>"
        sim = d.get("simulation")
        if sim:
            series = {k: np.asarray(v) for k, v in sim["series"].items()}
            body += _img(figures.closed_loop(np.asarray(sim["time"]), series, "closed-loop step response"),
                         "closed loop")
            if sim.get("metrics"):
                body += _table(["metric", "value"], [[k, v] for k, v in sim["metrics"].items()])
        if d.get("note"):
            body += f"<p class=muted>{html.escape(str(d['note']))}</p>"
        if d.get("modes_png"):
            body += ("<p>Modes of the saturated position/velocity loop (paper Fig. 4, 11–13), "
                     "2nd- and 3rd-order model:</p>")
            body += _img(d["modes_png"], "mode map")
        return body

    parts.append(_safe("design", "Controller", design_section))
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    from motorid import __version__

    return (
        "<!DOCTYPE html><html lang=en><head><meta charset=utf-8>"
        f"<title>{html.escape(inp.title)}</title><style>{_CSS}</style></head><body>"
        f"<h1>{html.escape(inp.title)}</h1><p class=muted>motorid {__version__}, {stamp}</p>"
        + "".join(parts) + "</body></html>"
    )

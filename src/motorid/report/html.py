"""One self-contained HTML page per experiment: every figure embedded, no script, no network.

Sections follow the story of the paper: raw captures → conditioning → the model (matrices,
transfer functions, poles/zeros, k and τ with intervals) → fit and residuals → order
evidence and the stages of ``--method auto`` → sensitivity to record length and sample
interval → validation on other inputs → the controller, when a design is given.

Each section is one function here that turns the results into the plain values its Jinja2
template (``templates/sections/<id>.html``, autoescaped) shows; :func:`build_report` runs
them in page order.  The page has print CSS for A4, so that "Print to PDF" gives a report an
instructor can hand out.
"""

from __future__ import annotations

import contextlib

import datetime as _dt
import functools
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import jinja2
import numpy as np
from markupsafe import Markup

from motorid.capture import Capture
from motorid.errors import MotorIdError
from motorid.identification.noise_json import noise_of
from motorid.identification.pipeline import Identification
from motorid.identification.sanity import SanityReport, demanded_zero_note
from motorid.model.notation import poly_text
from motorid.model.units import channel_unit, physical_gain
from motorid.numfmt import DIGITS, complex_text, metric_name, roots_text, sig
from motorid.report import figures
from motorid.report.summary import interval_notes
from motorid.report.truth import reference_values, truth_checks

__all__ = [
    "METRIC_UNITS", "SECTIONS", "SECTION_BUILDERS", "RenderedSection", "ReportInputs", "build_report",
    "render_page", "render_section", "template_environment",
]

#: Section ids, in page order (the headless-browser test checks they all render).
SECTIONS: tuple[str, ...] = (
    "summary", "captures", "conditioning", "current", "model", "fit", "order", "stages",
    "sensitivity", "advice", "validation", "design",
)
#: Significant figures of the numbers on the page (full precision stays in the JSON).
SIGNIFICANT = DIGITS
#: A fit entry whose key ends so is already a percentage (MATLAB's fit); the others are fractions.
_PERCENT_SUFFIX = "_fit_percent"
#: Units of the closed-loop metrics (their words come from :func:`motorid.numfmt.metric_name`).
METRIC_UNITS: dict[str, str] = {
    "rise_time_s": "s", "settling_time_s": "s", "overshoot_pct": "%", "steady_state_error_v": "V",
    "tracking_rms_v": "V", "peak_control_v": "V",
}
#: The metrics written on the closed-loop plot (all of them are in the table under it).
_HEADLINE_METRICS = ("rise_time_s", "settling_time_s", "overshoot_pct", "peak_control_v")
#: Design entries shown in the gains table, with what they are.
_DESIGN_ROWS: tuple[tuple[str, str], ...] = (
    ("K", "state feedback K"), ("kr", "reference gain kr"), ("ki", "integral gain ki"),
    ("L", "observer gain L"), ("closed_loop_poles", "closed-loop poles (1/s)"),
    ("observer_poles", "observer poles (1/s)"),
)


@dataclass(frozen=True, slots=True)
class ReportInputs:
    """Everything a report can show; only ``identification`` is required.

    Attributes
    ----------
    identification : Identification
        The result of :func:`motorid.identification.pipeline.identify_experiment`.
    captures : Mapping[str, Capture]
        The raw captures by role.
    validation : Mapping[str, Capture]
        Captures of other inputs (sine, triangle, square…) to validate the model on.
    sweep : Any
        A :class:`motorid.analysis.sweep.SweepResult` or ``None``.
    design : Mapping or None
        A design JSON (``motorid.design/1``) and, under ``"simulation"``, a closed-loop run
        ``{"time": [...], "series": {name: [...]}, "metrics": {...}}`` with optional
        ``"rails_v"`` (actuator rails ±V) and ``"disturbances_s"`` (load instants); under
        ``"mode_maps"`` a tuple of :class:`motorid.simulation.modes.ModeMap` (or ``"modes_png"``:
        bytes of an image drawn elsewhere) and ``"design_gains"``: the design's own ``(Kp, Kv)``.
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


@dataclass(frozen=True, slots=True)
class RenderedSection:
    """A section of the page: its id, heading and rendered (autoescaped) body."""

    sid: str
    title: str
    body: Markup


# ------------------------------------------------------------------------------ templates


def _cell(x: Any) -> str:
    """A table cell or inline number: :data:`SIGNIFICANT` figures, complex as ``a + bj`` (:mod:`motorid.numfmt`)."""
    if isinstance(x, (bool, np.bool_)):
        return str(x)
    if isinstance(x, (complex, np.complexfloating)):
        return complex_text(complex(x), SIGNIFICANT)
    if isinstance(x, (float, np.floating)):
        return sig(float(x), SIGNIFICANT)
    return "" if x is None else str(x)


@functools.cache
def template_environment() -> jinja2.Environment:
    """The Jinja2 environment of the report's templates (autoescaped, strict about undefined names).

    Returns
    -------
    jinja2.Environment
        Loads ``motorid/report/templates``; filter ``cell`` formats a number for the page.
    """
    env = jinja2.Environment(
        loader=jinja2.PackageLoader("motorid.report", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )
    env.filters["cell"] = _cell
    return env



def render_section(sid: str, title: str, make: Callable[[], Mapping[str, Any]],
                   template: str | None = None) -> RenderedSection:
    """Render one section; a section that cannot be drawn says why instead of breaking the page.

    Parameters
    ----------
    sid : str
        The section's id (its anchor).
    title : str
        Its heading.
    make : callable
        Returns the names its template shows.
    template : str, optional
        The template (default ``sections/<sid>.html``).

    Returns
    -------
    RenderedSection
        The id, heading and body.
    """
    env = template_environment()
    try:
        body = env.get_template(template or f"sections/{sid}.html").render(**make())
    except Exception as exc:
        body = env.from_string('<p class="warn">not available: {{ why }}</p>').render(why=str(exc))
    return RenderedSection(sid, title, Markup(body))


def render_page(template: str, title: str, sections: list[RenderedSection], **context: Any) -> str:
    """Render a whole page (``report.html`` or ``levels.html``) around its sections.

    Parameters
    ----------
    template : str
        The page template, which extends ``base.html``.
    title : str
        Page title.
    sections : list of RenderedSection
        The sections in page order.
    **context
        Further names the page template uses.

    Returns
    -------
    str
        A complete HTML document.
    """
    from motorid import __version__

    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    return template_environment().get_template(template).render(
        title=title, version=__version__, stamp=stamp, sections=sections, **context)


# ------------------------------------------------------------------------------- sections


def _reference(inp: ReportInputs) -> tuple[dict[str, float], str] | None:
    return reference_values(inp.identification.model, inp.truth, inp.identification.candidates.get("classic"))


def _value_text(x: Any) -> str:
    """A design entry: numbers to :data:`SIGNIFICANT` figures, ``[re, im]`` pairs as complex numbers."""
    if isinstance(x, (list, tuple)):
        if x and all(isinstance(v, (list, tuple)) and len(v) == 2 for v in x):
            return roots_text([complex(float(v[0]), float(v[1])) for v in x], SIGNIFICANT)
        return "[" + ", ".join(_value_text(v) for v in x) + "]"
    return _cell(x)


def summary_section(inp: ReportInputs) -> dict[str, Any]:
    """The headline numbers, the estimates against the truth (or the classic estimate), the warnings.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/summary.html`` shows.
    """
    ident = inp.identification
    model, cond = ident.model, ident.conditioned
    fo = model.first_order()
    u = model.uncertainty
    gain_unit = model.dc_gain_unit
    rows: list[list[Any]] = [
        ["method", model.method], ["states (size of A)", model.order],
        ["step", f"{_cell(cond.step_volts)} {model.input_unit}"],
        ["dc gain", f"{_cell(fo.dc_gain)} {gain_unit}"], ["τ (by moments)", f"{_cell(fo.time_constant_s)} s"],
        ["63 % time (dead time included)", f"{_cell(model.t63_s())} s"],
        ["k/(s+p)", f"{_cell(fo.k)}/(s + {_cell(fo.p)})"]]
    if u is not None:
        for key, label, unit in (("dc_gain", "dc gain 95 %", gain_unit), ("time_constant", "τ 95 %", "s"),
                                 ("t63_s", "63 % time 95 %", "s"), ("residence_time_s", "τ + dead time 95 %", "s")):
            item = u.headline(key)
            if item is not None and (key != "residence_time_s" or model.delay_s > 0):
                lo, hi = item.interval_or_nan()
                rows.append([label, f"[{_cell(lo)}, {_cell(hi)}] {unit}"])
    for channel, scale in model.scales.items():
        phys = physical_gain(fo.dc_gain, model.units, model.scales, channel)
        if phys is not None:
            rows.append([f"dc gain per {scale.unit} ({channel} sensor {_cell(scale.volts_per_unit)} V/{scale.unit})",
                         f"{_cell(phys[0])} {phys[1]}"])
    if model.delay_s > 0:
        rows.append(["dead time", f"{_cell(1e3 * model.delay_s)} ms "
                                  f"(τ + dead time {_cell(fo.time_constant_s + model.delay_s)} s)"])
    for key, val in model.fit.items():
        rows.append([metric_name(key), f"{val:.2f} %" if key.endswith(_PERCENT_SUFFIX) else f"{100 * val:.2f} %"])
    if isinstance(model.extras.get("sanity"), Mapping):
        sanity = SanityReport.from_json(model.extras["sanity"])
        rows.append(["sanity checks", "all passed" if sanity.passed else
                     f"{len(sanity.failures)} FAILED (see the warnings)"])
    ref = _reference(inp)
    checks: tuple[Any, ...] = ()
    label = ""
    if ref is not None:
        values, label = ref
        times = ", ".join(f"{words} {_cell(values[key])} s" for key, words in
                          (("time_constant", "τ"), ("t63_s", "63 % time")) if key in values)
        rows.append([label, f"dc gain {_cell(values['dc_gain'])} {gain_unit}, {times}"])
        checks = truth_checks(model, values, label, truth=inp.truth, step_volts=cond.step_volts)
    interval_png = ""
    if checks:
        interval_png = figures.data_uri(figures.interval_checks(
            [figures.IntervalCheck(f"{c.quantity} ({c.unit})", c.value, c.ci95, c.reference, label) for c in checks]))
    return {
        "rows": rows, "checks": checks, "interval_png": interval_png, "reference_label": label,
        "reason": ident.reason, "notes": [str(n) for n in model.extras.get("conditioning", []) or []],
        "warnings": list(model.warnings), "files": list(cond.sources.items()),
    }


def captures_section(inp: ReportInputs) -> dict[str, Any]:
    """The raw captures as recorded.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/captures.html`` shows.
    """
    return {"png": figures.data_uri(figures.raw_captures(inp.captures)) if inp.captures else ""}


def conditioning_section(inp: ReportInputs) -> dict[str, Any]:
    """The synchronised, unwrapped, reduced and differentiated signals.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/conditioning.html`` shows.
    """
    cond = inp.identification.conditioned
    units = inp.identification.model.units
    return {"png": figures.data_uri(figures.conditioned_signals(cond, units=units)), "ratio": cond.ratio,
            "reduction": cond.settings.reduction, "interval": _cell(cond.sample_interval_s)}


def current_section(inp: ReportInputs) -> dict[str, Any]:
    """The armature current, recorded and FFT-denoised.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/current.html`` shows.
    """
    cond = inp.identification.conditioned
    return {"png": figures.data_uri(figures.current_denoising(cond)) if "current" in cond.full_outputs else ""}


def _matrix_text(m: np.ndarray) -> str:
    cells = [[sig(float(x), SIGNIFICANT) for x in row] for row in np.atleast_2d(m)]
    width = max((len(c) for row in cells for c in row), default=1)
    return "\n".join("  [" + ", ".join(c.rjust(width) for c in row) + "]" for row in cells)


def model_section(inp: ReportInputs) -> dict[str, Any]:
    """Matrices, transfer functions, first-order summary, intervals, noise model, pole-zero map.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/model.html`` shows.
    """
    model = inp.identification.model
    fo = model.first_order()
    tfs = []
    for name in ("velocity", "position", "current"):
        tf = getattr(model, f"{name}_tf")
        if tf is not None:
            tfs.append((name, poly_text(np.ravel(tf.num[0][0])), poly_text(np.ravel(tf.den[0][0]))))
    u = model.uncertainty
    rows: list[list[Any]] = []
    if u is not None:
        for key in ("dc_gain", "time_constant"):
            item = u.headline(key)
            if item is not None:
                lo, hi = item.interval_or_nan()
                rows.append([key.replace("_", " "), item.value, item.stderr, f"[{_cell(lo)}, {_cell(hi)}]",
                             model.dc_gain_unit if key == "dc_gain" else "s"])
        for name, items in (("pole", u.poles), ("zero", u.zeros)):
            for i, item in enumerate(items):
                lo, hi = item.interval_or_nan()
                rows.append([f"{name} {i + 1}", complex(item.value), item.stderr, f"[{_cell(lo)}, {_cell(hi)}]",
                             "1/s"])
    root_notes = [f"zero {i + 1}: {note}" for i, item in enumerate(u.zeros if u is not None else ())
                  if (note := demanded_zero_note(float(np.real(item.value)), item.interval_or_nan()[0]))]
    root_notes += [f"Intervals: {note}." for note in (interval_notes(u) if u is not None else ())]
    noise_rows = [[f"{role} ({channel_unit(model.units, role)})", nm.sigma, nm.ar_order, nm.pre_step_sigma,
                   "its scale only: 8-bit codes not dithered by noise" if nm.scale_only
                   else "the dynamics"] for role, nm in noise_of(model).items()]
    return {
        "matrices": [(name, _matrix_text(getattr(model, name))) for name in ("A", "B", "C", "D")],
        "states": ", ".join(model.states), "outputs": ", ".join(model.outputs), "tfs": tfs,
        "first_order": {"k": fo.k, "p": fo.p, "dc_gain": fo.dc_gain, "tau": fo.time_constant_s,
                        "gain_unit": model.dc_gain_unit},
        "uncertainty_rows": rows, "root_notes": root_notes,
        "structure": u is not None and u.dc_gain is not None and u.dc_gain.structure_std is not None,
        "method": u.method if u is not None else "", "noise_rows": noise_rows,
        "pole_zero_png": figures.data_uri(figures.pole_zero(model)),
    }


def fit_section(inp: ReportInputs) -> dict[str, Any]:
    """Measured against model step responses, with residuals.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/fit.html`` shows.
    """
    ident = inp.identification
    return {"png": figures.data_uri(figures.step_fit(ident.model, ident.conditioned))}


def order_section(inp: ReportInputs) -> dict[str, Any]:
    """The order evidence: Hankel singular values (or the Laguerre coefficients).

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/order.html`` shows; ``kind`` is ``none``, ``laguerre`` or ``hankel``.
    """
    mk = inp.identification.candidates.get("markov")
    if mk is None or "hankel_singular_values_scaled" not in mk.extras:
        return {"kind": "none"}
    ex = mk.extras
    choice = str(ex.get("markov_choice", ""))
    if ex.get("markov_basis") == "laguerre":
        floor = ex["hankel_noise_floor"]
        return {
            "kind": "laguerre", "pole": ex["laguerre_pole"], "terms": ex["laguerre_terms"],
            "dc_gain": ex["laguerre_dc_gain"], "dc_gain_std": ex["laguerre_dc_gain_std"], "floor": floor,
            "sv_rows": [[i + 1, x, "above" if x > floor else "below"]
                        for i, x in enumerate(ex["hankel_singular_values_scaled"])],
            "coefficient_rows": [[k, g, sd] for k, (g, sd) in enumerate(
                zip(ex["laguerre_coefficients"], ex["laguerre_coefficients_std"], strict=False))],
            "choice": choice,
        }
    png = figures.hankel_values(ex["hankel_singular_values_scaled"], ex["hankel_singular_values_raw"],
                                ex.get("hankel_noise_floor"))
    return {"kind": "hankel", "png": figures.data_uri(png), "choice": choice}


def stages_section(inp: ReportInputs) -> dict[str, Any]:
    """The stages of ``--method auto``, one row each.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/stages.html`` shows.
    """
    model = inp.identification.model
    rows = [[st.get("stage"), st.get("method", ""), st.get("order", ""), st.get("dc_gain", ""),
             st.get("time_constant", ""),
             "" if st.get("velocity_nrmse") is None else f"{100 * st['velocity_nrmse']:.2f} %",
             st.get("evidence", st.get("failed", ""))] for st in model.stages]
    return {"rows": rows, "method": model.method, "gain_unit": model.dc_gain_unit}


def sensitivity_section(inp: ReportInputs) -> dict[str, Any]:
    """The paper's table of k and τ over record length × sample interval.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/sensitivity.html`` shows (no ``rows``: not computed).
    """
    sw = inp.sweep
    if sw is None:
        return {"rows": []}
    rows = [[f"{1000 * dt:g} ms"] + [f"k = {_cell(sw.k[i, j])}, τ = {_cell(sw.tau_s[i, j])}"
                                     for j in range(len(sw.lengths_s))]
            for i, dt in enumerate(sw.intervals_s)]
    sp = sw.spread()
    return {"head": ["ΔT"] + [f"{x:g} s" for x in sw.lengths_s], "rows": rows, "method": sw.method,
            "spread_k": f"{100 * sp['k']:.1f}", "spread_tau": f"{100 * sp['tau']:.1f}",
            "png": figures.data_uri(figures.sweep_maps(sw.lengths_s, sw.intervals_s, sw.k, sw.tau_s))}


def _widths_text(w: Any) -> str:
    def one(x: float | None) -> str:
        return "—" if x is None else ("undetermined" if not np.isfinite(x) else f"±{sig(50 * x, 2)} %")

    return f"gain {one(w.dc_gain)}, τ {one(w.time_constant)}" + (
        f", dead time {one(w.dead_time)}" if w.dead_time is not None else "") + (
        f", electrical pole {one(w.electrical_pole)}" if w.electrical_pole is not None else "")


def advice_section(inp: ReportInputs) -> dict[str, Any]:
    """The experiment advisor: each scope setting's predicted interval widths (``motorid advise``).

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/advice.html`` shows.
    """
    from motorid.analysis.advice import advise

    how = ("Predicted from the Fisher information of the fitted output-error model on a record taken at each "
           "setting: the noise model measured on this capture, the 8-bit quantiser's step (volts/div / 25), the "
           "record length and the sampling; widths are the full 95 % interval over the estimate.")
    try:
        adv = advise(inp.identification, inp.captures)
    except MotorIdError as exc:
        return {"line": f"No advice for these captures: {exc.message}", "rows": [], "how": how}
    rows = [[f"{s.setting} ({s.channel})" if s.channel else s.setting, s.now, s.suggested,
             _widths_text(s.predicted), s.why + (f" (costs: {s.cost})" if s.cost else "")] for s in adv.suggestions]
    c = adv.combined.to_dict()
    combined = (", ".join(f"{k} {sig(v)} V/div" for k, v in c["volts_per_div"].items())
                + f"; {sig(c['time_per_div_s'])} s/div; {sig(c['trigger_position_pct'])} % before the trigger")
    return {"line": f"Now: {_widths_text(adv.now)}. {adv.summary_line()}.", "how": how,
            "head": ["setting", "now", "suggested", "predicted 95 % widths", "why"], "rows": rows,
            "combined": combined if adv.worth_changing else "",
            "combined_widths": _widths_text(adv.combined_predicted)}


def validation_section(inp: ReportInputs) -> dict[str, Any]:
    """The model driven by other recorded inputs, scored and overlaid.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/validation.html`` shows.
    """
    from motorid.analysis.validation import validate_capture

    rows: list[list[Any]] = []
    overlays: list[tuple[str, str]] = []
    model = inp.identification.model
    for name, cap in inp.validation.items():
        try:
            r = validate_capture(model, cap)
        except MotorIdError as exc:
            rows.append([name, "—", "—", "—", f"not validated: {exc.message}"])
            continue
        unit = channel_unit(model.units, r.channel)
        rows.append([name, f"{100 * r.nrmse:.2f} %", f"{r.fit_percent:.1f} %", f"{r.offset_v:+.4g} {unit}",
                     "; ".join(r.notes + r.warnings)])
        overlays.append((name, figures.data_uri(figures.validation_overlay(
            r.time_s, r.input_v, r.measured_v, r.simulated_v,
            f"{name}: NRMSE {100 * r.nrmse:.2f} %, fit {r.fit_percent:.1f} %", unit, model.input_unit))))
    return {"rows": rows, "overlays": overlays}


def _metric_rows(metrics: Mapping[str, Any], output_unit: str = "V") -> list[list[str]]:
    """Metrics in words with units (:data:`METRIC_UNITS`; the errors in the output's unit); NaN as a dash."""
    rows = []
    for key, val in metrics.items():
        words, unit = metric_name(key), METRIC_UNITS.get(key, "")
        if key in ("steady_state_error_v", "tracking_rms_v"):
            unit = output_unit
        undefined = isinstance(val, float) and not np.isfinite(val)
        rows.append([words, "—" if undefined else f"{_cell(val)} {unit}".strip()])
    return rows


def design_section(inp: ReportInputs) -> dict[str, Any]:
    """The controller: gains, Routh table, closed-loop response with rails and metrics, mode maps.

    Parameters
    ----------
    inp : ReportInputs
        The report's inputs.

    Returns
    -------
    dict
        The names ``sections/design.html`` shows.
    """
    d = inp.design
    if not d:
        return {"given": False}
    pid = d.get("pid") if isinstance(d.get("pid"), dict) else None
    if pid is not None:
        units = pid.get("units") or {}
        gain_rows = [["PID", f"{pid.get('kind', '')} on the {pid.get('loop')}, rule {pid.get('rule')} "
                             "(the derivative on the measurement)"]]
        gain_rows += [[name, f"{_cell(pid.get(name))} {units.get(name, '')}".strip()]
                      for name in ("kp", "ki", "kd", "tf_s") if pid.get(name) is not None]
        gain_rows.append(["closed-loop poles (1/s)", _value_text(d.get("closed_loop_poles") or [])])
    else:
        gain_rows = [["states", ", ".join(map(str, d.get("states") or []))]]
        gain_rows += [[words, _value_text(d.get(key))] for key, words in _DESIGN_ROWS if d.get(key) is not None]
    loop_png = robust_png = ""
    if isinstance(d.get("margins"), dict):
        from motorid.control.design_io import controller_from_json
        from motorid.control.margins import LoopMargins, loop_frequency_response
        from motorid.control.pid import PidDesign, pid_loop_frequency_response
        from motorid.errors import MotorIdError

        gain_rows.append(["margins", LoopMargins.from_json(d["margins"]).text()])
        if isinstance(d.get("robust"), dict):
            from motorid.control.robust import RobustCheck

            # a malformed robust object in a hand-edited design: its row (and band) is left out
            with contextlib.suppress(ValueError):
                check = RobustCheck.from_json(d["robust"])
                gain_rows.append(["on plausible motors", check.text()])
                if check.band[0]:
                    unit = channel_unit(inp.identification.model.units, str(d.get("output") or "position"))
                    robust_png = figures.data_uri(figures.robust_band(d["robust"]["band"], unit, check.text()))
        try:
            des = controller_from_json(d)
            model = inp.identification.model
            response = (pid_loop_frequency_response(model, des) if isinstance(des, PidDesign)
                        else loop_frequency_response(model, des))
        except MotorIdError:  # a design for another model's states: its margins row stays, no plot
            response = None
        if response is not None:
            loop_png = figures.data_uri(figures.loop_bode_nyquist(*response, d["margins"]))
    view: dict[str, Any] = {"given": True, "gain_rows": gain_rows, "routh": [str(x) for x in d.get("routh") or []],
                            "closed_loop_png": "", "caption": "", "metric_rows": [], "note": str(d.get("note") or ""),
                            "modes_png": "", "modes_marker": "", "loop_png": loop_png, "robust_png": robust_png,
                            **gain_units(inp.identification.model.units)}
    sim = d.get("simulation")
    if sim:
        metrics = sim.get("metrics") or {}
        out_unit = str(sim.get("output_unit") or "V")
        metric_rows = _metric_rows(metrics, out_unit)
        headline = _metric_rows({k: metrics[k] for k in _HEADLINE_METRICS if k in metrics}, out_unit)
        rails, disturbances = sim.get("rails_v"), tuple(sim.get("disturbances_s") or ())
        in_unit = inp.identification.model.input_unit
        png = figures.closed_loop(np.asarray(sim["time"]), {k: np.asarray(v) for k, v in sim["series"].items()},
                                  "closed-loop step response on the identified model", rails_v=rails,
                                  disturbances_s=disturbances, metrics=[f"{w}: {v}" for w, v in headline],
                                  output_unit=out_unit, input_unit=in_unit)
        view["closed_loop_png"] = figures.data_uri(png)
        view["metric_rows"] = metric_rows
        level = sim.get("reference_level") or {}
        rails_words = ("Dashed: the actuator rails ±" + _cell(rails) + f" {in_unit}, where the command saturates. "
                       if rails is not None else "No actuator rails in this run. ")
        view["caption"] = (_reference_words(level) + rails_words
                           + ("Dotted: the instants a load is applied." if disturbances else ""))
    gains = d.get("design_gains")
    if d.get("mode_maps"):
        view["modes_png"] = figures.data_uri(figures.mode_maps(d["mode_maps"], gains))
        view["modes_marker"] = (f"The star marks this design's own gains, Kp = {_cell(gains[0])} {view['kp_unit']}, "
                                f"Kv = {_cell(gains[1])} {view['kv_unit']}." if gains is not None else
                                "This design has other states or integral action, so it is not a point of these maps.")
    elif d.get("modes_png"):
        view["modes_png"] = figures.data_uri(d["modes_png"])
    return view


def _reference_words(level: Mapping[str, Any]) -> str:
    """The caption's first sentence: where the reference steps to, and why there when it is a default."""
    if not level:
        return ""
    head = f"The reference steps to {_cell(level.get('value'))} {level.get('unit', '')}"
    source = str(level.get("source") or "")
    return f"{head}{'' if source in ('', 'given') else f' ({source})'}. "


#: The sections in page order: (id, heading, the function that prepares its template's names).
SECTION_BUILDERS: tuple[tuple[str, str, Callable[[ReportInputs], Mapping[str, Any]]], ...] = (
    ("summary", "Summary", summary_section),
    ("captures", "Raw captures (as recorded)", captures_section),
    ("conditioning", "Conditioned signals: synchronised, unwrapped, reduced, differentiated", conditioning_section),
    ("current", "Armature current: recorded and FFT-denoised", current_section),
    ("model", "The identified model", model_section),
    ("fit", "Measured vs model step response, with residuals", fit_section),
    ("order", "Order evidence: Hankel singular values", order_section),
    ("stages", "Stages of the identification", stages_section),
    ("sensitivity", "Sensitivity to record length and sample interval", sensitivity_section),
    ("advice", "How to record the next capture", advice_section),
    ("validation", "Validation on other inputs", validation_section),
    ("design", "Controller", design_section),
)


def build_report(inp: ReportInputs) -> str:
    """Build the HTML page: every section of :data:`SECTIONS`, in order, from its template.

    Parameters
    ----------
    inp : ReportInputs
        The identification and whatever else is available.

    Returns
    -------
    str
        A complete, self-contained HTML document.
    """
    sections = [render_section(sid, title, functools.partial(make, inp)) for sid, title, make in SECTION_BUILDERS]
    ref = _reference(inp)
    return render_page("report.html", inp.title, sections, has_reference=ref is not None,
                       reference_label=ref[1] if ref else "", **gain_units(inp.identification.model.units))


def gain_units(units: Mapping[str, str]) -> dict[str, str]:
    """The units of the mode map's Kp and Kv, and a sentence on the channels' units, for the page.

    Parameters
    ----------
    units : Mapping[str, str]
        The model's channel units (empty for scope volts).

    Returns
    -------
    dict
        ``kp_unit``, ``kv_unit`` and ``units_sentence``.
    """
    pos = units.get("position")
    if not units:
        return {"kp_unit": "V/V", "kv_unit": "V/(V/s)",
                "units_sentence": "Voltages are as recorded on the scope (V)"}
    inp = channel_unit(units, "input")  # the command's: V, or pwm / % for a logged duty cycle
    per = f"{inp}/{pos}" if pos else f"{inp} per unit of position"
    listed = ", ".join(f"{ch} in {u}" for ch, u in units.items() if ch != "input")
    return {"kp_unit": per, "kv_unit": f"{inp}/({pos}/s)" if pos else f"{inp} per unit of position per second",
            "units_sentence": f"The channels are in the data's units ({listed}; the input in {inp})"}

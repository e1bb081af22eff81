"""The plain-text summary of an identified model: what ``motorid identify`` prints.

One source for the command line (which adds colour) and for
:meth:`motorid.IdentificationResult.summary` (plain text).  Each line is a tuple of
``(text, style)`` spans; ``style`` is a rich style name (``""``: none), so the command line
can colour a line without the text passing through rich's markup parser.

Numbers are written by :mod:`motorid.numfmt`: four significant figures, a
conjugate pair once as ``-2.800 ± 1.150j``, keys in words; the JSON keeps full precision.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from motorid.identification.noise_json import noise_of
from motorid.identification.sanity import SanityReport, demanded_zero_note
from motorid.model.notation import poly_text
from motorid.model.uncertainty import Uncertainty
from motorid.model.units import channel_unit, physical_gain
from motorid.numfmt import complex_text, metric_name, roots_text, sig

__all__ = ["Span", "SummaryLine", "interval_notes", "model_summary", "model_summary_lines"]

#: A piece of a line and its rich style (``""``: plain).
Span = tuple[str, str]
#: One printed line.
SummaryLine = tuple[Span, ...]

#: Style of the warnings the sanity gate adds (``SANITY CHECK FAILED — …``).
_FAILED_STYLE = "bold red"
#: Style of every other warning's ``warning:`` prefix.
_WARNING_STYLE = "yellow"


def _plain(text: str) -> SummaryLine:
    return ((text, ""),)


def _array_text(a: Any) -> str:
    return np.array2string(np.asarray(a, dtype=float), formatter={"float_kind": lambda v: sig(float(v))})


def _header(model: Any, title: str) -> list[SummaryLine]:
    lines: list[SummaryLine] = [
        ((title, "bold"), (f": method {model.method}, {model.order} states {list(model.states)}, "
                           f"{_velocity_poles(model)} poles of the velocity TF"
                           # a model built from a transfer function has no step of its own
                           + (f", step {sig(model.step_volts)} {model.input_unit}"
                              if model.step_volts is not None else ""), ""))]
    lines.append(_plain(f"A = {_array_text(model.A)}"))
    lines.append(_plain(f"B = {_array_text(model.B.ravel())}ᵀ"))
    for name in ("velocity", "position", "current"):
        try:
            coeffs = model.tf_coefficients(name)
        except Exception:
            coeffs = None
        if coeffs is None:
            continue
        num, den = np.ravel(coeffs[0]), np.ravel(coeffs[1])
        lines.append(_plain(f"H_{name}(s) = ({poly_text(num)}) / ({poly_text(den)})"))
    lines.append(_plain(f"poles: {roots_text(model.poles())}"))
    fo = model.first_order()
    lines.append(_plain(f"first order: k/(s+p) = {sig(fo.k)}/(s + {sig(fo.p)}); dc gain {sig(fo.dc_gain)} "
                        f"{model.dc_gain_unit}, τ = {sig(fo.time_constant_s)} s"))
    for channel, scale in model.scales.items():
        phys = physical_gain(fo.dc_gain, model.units, model.scales, channel)
        if phys is not None:
            lines.append(_plain(f"{channel} sensor {sig(scale.volts_per_unit)} V/{scale.unit}: dc gain "
                                f"{sig(phys[0])} {phys[1]}"))
    if model.delay_s > 0:
        lines.append(_plain(f"dead time: {sig(1e3 * model.delay_s)} ms (every H(s) above times "
                            f"e^(−s·{sig(model.delay_s)})); mean residence time τ + dead time = "
                            f"{sig(fo.time_constant_s + model.delay_s)} s"))
    return lines


def interval_notes(u: Uncertainty) -> list[str]:
    """Why the intervals are wider than the noise alone makes them, one sentence each (docs/timing.md).

    The printout and the report say the same.

    Parameters
    ----------
    u : Uncertainty
        A model's uncertainty.

    Returns
    -------
    list of str
        Empty when the intervals hold none of the quantiser's error along the record, a read-off
        onset's lag, and a counted speed's lag.
    """
    notes = []
    if u.quantiser:
        notes.append(f"they hold the quantiser's error along the record ({', '.join(u.quantiser)}): where the "
                     "noise does not dither its codes it rounds the signal the same way wherever the signal "
                     "moves slowly, an error that does not average out")
    if u.onset_lag_s:
        notes.append(f"the step instant is read off the response (no input channel), and a lag shorter than half a "
                     f"sample cannot be told from a later instant: τ's, the residence time's and the 63 % time's "
                     f"intervals reach {sig(1e3 * u.onset_lag_s)} ms higher (give the input column, or --t0, to "
                     "time the step)")
    if u.counting_lag_s:
        notes.append("the speed comes in whole counts, as one counted over each line does (encoder edges since the "
                     "last line), and was fitted as samples: if it counts, the motor is quicker by the counting's lag "
                     "(half a line, and half the hold of a value kept over several lines), so τ's, the residence "
                     f"time's and the 63 % time's intervals reach {sig(1e3 * u.counting_lag_s)} ms lower "
                     "(--counted-velocity if it counts: the fit then models the counting)")
    return notes


def _uncertainty(u: Uncertainty | None, gain_unit: str = "V/V") -> list[SummaryLine]:
    lines: list[SummaryLine] = []
    if u is None:
        return lines
    # with no input channel the step instant is the response's fitted onset: whatever lag the
    # sampling cannot resolve, and any dead time, went into that onset, not into the times
    onset = any(t.kind == "onset" for t in u.timing.values())
    # a speed counted over each interval lags the motor by half of it: a read-off on that record does too
    window = max((t.counting_lag_s for t in u.timing.values()), default=0.0)
    t63_label = ("63 % time (s; from the response's fitted onset: with no input channel a dead time or a lag under "
                 "a sample is in the onset, not here)" if onset else
                 "63 % time (s; the motor's, dead time included: a read-off on the counted speed is about "
                 f"{sig(1e3 * window)} ms later)" if window > 0 else
                 "63 % time (s; what a scope read-off measures, dead time included)")
    for key, label in (("dc_gain", f"dc gain ({gain_unit})"),
                       ("time_constant", "τ (s; by moments: Σ1/|p| − Σ1/|z|)"),
                       ("t63_s", t63_label),
                       ("residence_time_s", "mean residence time τ + dead time (s)")):
        item = u.headline(key)
        if item is None or (key == "residence_time_s" and u.delay is None):
            continue
        lo, hi = item.interval_or_nan()
        lines.append(_plain(f"{label}: {sig(item.value.real)} ± {sig(1.96 * item.stderr, 2)} "
                            f"(95 % interval [{sig(lo)}, {sig(hi)}])"))
    lines.extend(_plain(f"intervals: {note}") for note in interval_notes(u))
    if u.delay is not None:
        item = u.delay
        lines.append(_plain(f"delay: {sig(1e3 * item.value.real)} ms ± {sig(1.96e3 * item.stderr, 2)} ms (95 %; not in "
                            "the state-space model: add it as e^(-s·delay), e.g. control.pade)"))
    for role, timing in u.timing.items():
        if timing.shift is not None:
            shift = timing.shift
            lo, hi = shift.interval_or_nan()
            spread = (f"± {sig(1.96e3 * shift.stderr, 2)} ms (95 % interval [{sig(1e3 * lo)}, {sig(1e3 * hi)}] ms)"
                      if np.isfinite(shift.stderr) else
                      f"— {timing.note or 'no interval'}: [{sig(1e3 * lo)}, {sig(1e3 * hi)}] ms")
            lines.append(_plain(f"{role} step instant {sig(timing.edge_s)} s ({timing.step_instant}): fitted "
                                f"shift {sig(1e3 * shift.value.real)} ms {spread}"))
    for pair in u.pole_pairs:
        i, j = pair.poles
        wn, zeta = pair.natural_frequency, pair.damping
        lines.append(_plain(f"poles {i + 1} and {j + 1}: known as a pair only (each one's interval holds the "
                            f"other): natural frequency {sig(wn.value.real)} ± {sig(1.96 * wn.stderr, 2)} rad/s, "
                            + (f"damping {sig(zeta.value.real)} ± {sig(1.96 * zeta.stderr, 2)} (95 %)"
                               if np.isfinite(zeta.stderr) else
                               f"damping {sig(zeta.value.real)} at their double pole, the edge of the fit's real "
                               "poles: no interval (there the delta method's would be ±0 or straddle 1, below which "
                               "real poles cannot go)")))
    paired = u.paired_poles()
    for name, items in (("pole", u.poles), ("zero", u.zeros)):
        for i, item in enumerate(items):
            if name == "pole" and i in paired:
                continue
            note = demanded_zero_note(float(np.real(item.value)), item.interval_or_nan()[0]) if name == "zero" \
                else None
            lines.append(_plain(f"{name} {i + 1}: {complex_text(complex(item.value))} ± "
                                f"{sig(1.96 * item.stderr, 2)} (95 %)" + (f" — {note}" if note else "")))
    return lines


def _noise_and_stages(model: Any) -> list[SummaryLine]:
    lines: list[SummaryLine] = []
    noise = noise_of(model)
    if noise:
        parts = []
        for role, nm in noise.items():
            use = "; scale only: its 8-bit codes are not dithered by noise" if nm.scale_only else ""
            unit = channel_unit(model.units or {}, role)  # the data's own unit (rpm on a rig log)
            parts.append(f"{role} σ {sig(nm.sigma)} {unit} (AR order {nm.ar_order}{use})")
        lines.append(_plain("noise model of the output-error fit: " + ", ".join(parts)))
    for st in model.stages:
        desc = ", ".join(_stage_item(k, v, model.dc_gain_unit) for k, v in st.items()
                         if k in ("method", "order", "dc_gain", "time_constant", "markov_order", "oe_order", "agree"))
        extra = f" — {st['evidence']}" if "evidence" in st else ""
        if "failed" in st:  # a stage that did not run says why (it printed nothing after its name)
            desc = f"did not run: {st['failed']}"
        lines.append(_plain(f"stage {st['stage']}: {desc}{extra}"))
    return lines


def _velocity_poles(model: Any) -> int:
    """Poles of the velocity transfer function (the 'order' the paper and python-control mean)."""
    den = np.trim_zeros(np.ravel(model.tf_coefficients("velocity")[1]), "f")
    return int(den.size - 1)


def _stage_item(key: str, value: Any, gain_unit: str) -> str:
    # one word per idea: a stage's "order" is its model's number of states
    if key == "order":
        return f"states {value}"
    if key == "time_constant" and isinstance(value, float):
        return f"τ {sig(value)} s"
    if key == "dc_gain" and isinstance(value, float):
        return f"dc gain {sig(value)} {gain_unit}"  # every stage fits the same data: the model's unit
    return f"{metric_name(key)} {sig(value) if isinstance(value, float) else value}"


def _polish_shifts(extras: Mapping[str, Any]) -> dict[str, float]:
    """The Laguerre polish's trigger shift of each capture after the first (none before this was reported)."""
    return dict((extras.get("laguerre_polish") or {}).get("shifts_s") or {})


def _shifted(u: Uncertainty | None) -> frozenset[str]:
    """Channels whose fitted shift the uncertainty lines print."""
    return frozenset() if u is None else frozenset(role for role, t in u.timing.items() if t.shift is not None)


def _markov(extras: Mapping[str, Any], gain_unit: str, timed: frozenset[str] = frozenset()) -> list[SummaryLine]:
    """The Markov method's own lines; a shift printed with its interval (``timed``) is not repeated."""
    ex = extras
    if ex.get("markov_basis") == "laguerre":
        return [
            _plain(f"Laguerre basis: a = {sig(ex['laguerre_pole'])} 1/s, N = {ex['laguerre_terms']}; coefficients "
                   + ", ".join(sig(x) for x in ex["laguerre_coefficients"][:8])
                   + (" …" if ex["laguerre_terms"] > 8 else "")
                   + f"; DC gain from them {sig(ex['laguerre_dc_gain'])} ± "
                   f"{sig(1.96 * ex['laguerre_dc_gain_std'], 2)} {gain_unit} (95 %)"),
            _plain("Hankel singular values of the Laguerre coefficients (normalised): "
                   + ", ".join(sig(x) for x in ex["hankel_singular_values_scaled"])
                   + f"; noise floor {sig(ex['hankel_noise_floor'])}"),
            _plain(f"Markov settings: {ex.get('markov_choice', '')}"),
            *[_plain(f"{ch} trigger shift against the first capture's step (fitted, within one grid step): "
                     f"{sig(1e3 * v)} ms") for ch, v in _polish_shifts(ex).items() if ch not in timed],
        ]
    if "hankel_singular_values_scaled" in ex:
        return [
            _plain("Hankel singular values (normalised), time-scaled: "
                   + ", ".join(sig(x) for x in ex["hankel_singular_values_scaled"])
                   + "; raw (seconds): " + ", ".join(sig(x) for x in ex["hankel_singular_values_raw"])
                   + f"; noise floor {sig(ex['hankel_noise_floor'])}"),
            _plain(f"Markov settings: {ex.get('markov_choice', '')}"),
        ]
    return []


def _fit_and_checks(model: Any) -> list[SummaryLine]:
    lines: list[SummaryLine] = []
    for key, val in model.fit.items():
        if key.endswith("_fit_percent"):
            lines.append(_plain(f"{metric_name(key)}: {sig(val)} % (MATLAB compare: 100·(1 − ‖y − ŷ‖/‖y − mean y‖))"))
        else:
            lines.append(_plain(f"{metric_name(key)}: {sig(100 * val)} % (RMS error / measured steady-state change)"))
    for note in model.extras.get("conditioning", ()) or ():
        lines.append(_plain(f"automatic choice: {note}"))
    sanity = SanityReport.from_json(model.extras.get("sanity"))
    if sanity.checks:
        failed = sanity.failures
        if failed:
            lines.append(((f"sanity checks: {len(failed)} of {len(sanity.checks)} FAILED — read the warnings "
                           "before using this model", _FAILED_STYLE),))
        else:
            # the headline is checked against its interval only when the method gives one (not the paper's methods)
            headline = ("headline inside its interval" if any(c.name.startswith("headline ") for c in sanity.checks)
                        else "no interval to hold the headline to: this method gives none")
            lines.append(_plain(f"sanity checks: all {len(sanity.checks)} passed (stable, better than a "
                                f"first-order baseline, agrees with the read-off gain and 63 % time; {headline})"))
    for w in model.warnings:
        style = _FAILED_STYLE if w.startswith("SANITY CHECK FAILED") else _WARNING_STYLE
        lines.append((("warning:", style), (f" {w}", "")))
    return lines


def model_summary_lines(model: Any, title: str = "identified model") -> list[SummaryLine]:
    """The summary of a model as styled lines (what ``motorid identify`` prints, in colour).

    Parameters
    ----------
    model : MotorModel
        An identified model.
    title : str
        The first line's heading.

    Returns
    -------
    list of SummaryLine
        One entry per printed line, each a tuple of ``(text, rich style)`` spans.
    """
    return (_header(model, title) + _uncertainty(model.uncertainty, model.dc_gain_unit) + _noise_and_stages(model)
            + _markov(model.extras, model.dc_gain_unit, _shifted(model.uncertainty)) + _fit_and_checks(model))


def model_summary(model: Any, title: str = "identified model") -> list[str]:
    """The summary of a model as plain text lines (what ``motorid identify`` prints).

    Parameters
    ----------
    model : MotorModel
        An identified model.
    title : str
        The first line's heading.

    Returns
    -------
    list of str
        The lines, without styles or line ends; a line may be longer than a terminal (the
        command line wraps them to its width).
    """
    return ["".join(text for text, _ in line) for line in model_summary_lines(model, title)]

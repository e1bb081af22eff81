"""The headline estimates against a value known another way: the truth, or the classic estimate.

The demo (and any virtual-trainer run) knows the plant's truth; a real recording does not, but
the paper's classic read-off (final value and 63 % time) is always at hand.  Each headline
estimate is compared with that value in units of its standard error, and a miss — the value
outside the 95 % interval — comes with a sentence naming the cause the data point to.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from motorid.identification.noise_json import noise_of
from motorid.numfmt import sig

__all__ = ["TruthCheck", "reference_values", "truth_checks"]

#: Half-width of the 95 % interval in standard errors (normal approximation, as the intervals).
Z95 = 1.96
#: The headline quantities: (key in the uncertainty dict, words, unit); the gain's unit is the
#: model's own (``rpm/V`` for data in rpm) when it has one.
QUANTITIES: tuple[tuple[str, str, str], ...] = (("dc_gain", "dc gain", "V/V"), ("time_constant", "τ", "s"),
                                                ("t63_s", "63 % time", "s"))
#: Label of the trainer's truth (the linearised plant: friction and dead-zones left out).
TRUTH_LABEL = "the trainer's truth (linearised)"
#: Label of the classic estimate (final value and 63 % time read off the record).
CLASSIC_LABEL = "the classic estimate"


@dataclass(frozen=True, slots=True)
class TruthCheck:
    """One headline estimate against a reference value.

    Attributes
    ----------
    quantity : str
        In words (``"dc gain"``, ``"τ"``).
    unit : str
        ``"V/V"`` or ``"s"``.
    value, stderr : float
        The estimate and its standard error.
    ci95 : (float, float)
        Its 95 % interval.
    reference : float
        The value compared with it.
    reference_label : str
        What ``reference`` is (:data:`TRUTH_LABEL` or :data:`CLASSIC_LABEL`).
    z : float
        ``(reference − value) / stderr``.
    inside : bool
        ``reference`` lies inside ``ci95``.
    sentence : str
        What the page says: where the reference lies and, for a miss, why.
    """

    quantity: str
    unit: str
    value: float
    stderr: float
    ci95: tuple[float, float]
    reference: float
    reference_label: str
    z: float
    inside: bool
    sentence: str


def reference_values(model: Any, truth: Mapping[str, Any] | None,
                     classic: Any = None) -> tuple[dict[str, float], str] | None:
    """The values to compare the headline estimates with, and what they are.

    Parameters
    ----------
    model : MotorModel
        The identified model.
    truth : Mapping or None
        The virtual trainer's ``truth.json`` (its ``transfer_functions.first_order``).
    classic : MotorModel, optional
        The classic method's model, used when there is no truth and the model is not itself
        the classic one.

    Returns
    -------
    (dict, str) or None
        ``{"dc_gain": …, "time_constant": …}`` (the truth's τ by moments) and :data:`TRUTH_LABEL`, or
        ``{"dc_gain": …, "t63_s": …}`` (the classic read-off's 63 % time) and :data:`CLASSIC_LABEL`;
        None when neither is available.
    """
    first = (truth or {}).get("transfer_functions", {}).get("first_order", {})
    if "dc_gain" in first and "time_constant" in first:
        return {"dc_gain": float(first["dc_gain"]), "time_constant": float(first["time_constant"])}, TRUTH_LABEL
    if classic is not None and getattr(model, "method", None) != "classic":
        fo = classic.first_order()
        # the classic τ is a 63 % read-off: compared with the model's 63 % time, not its τ by moments
        return {"dc_gain": float(fo.dc_gain), "t63_s": float(fo.time_constant_s)}, CLASSIC_LABEL
    return None


def truth_checks(model: Any, reference: Mapping[str, float], reference_label: str, *,
                 truth: Mapping[str, Any] | None = None, step_volts: float | None = None) -> tuple[TruthCheck, ...]:
    """Compare each headline estimate with its reference; explain a miss.

    Parameters
    ----------
    model : MotorModel
        The identified model, with its ``uncertainty`` (no uncertainty: no checks).
    reference : Mapping[str, float]
        From :func:`reference_values`.
    reference_label : str
        From :func:`reference_values`.
    truth : Mapping, optional
        The trainer's ``truth.json`` (its ``equivalent_input_offset_v`` explains a gain miss).
    step_volts : float, optional
        The step level of the experiment (V).

    Returns
    -------
    tuple of TruthCheck
        One per quantity of :data:`QUANTITIES` with a finite, positive standard error.
    """
    u = model.uncertainty
    gain_unit = str(getattr(model, "dc_gain_unit", "V/V"))
    out = []
    for key, words, unit in QUANTITIES:
        unit = gain_unit if key == "dc_gain" else unit
        item = None if u is None else u.headline(key)
        if item is None or key not in reference:
            continue
        value, std = item.value.real, item.stderr
        lo, hi = item.interval_or_nan()
        ref = float(reference[key])
        if not (math.isfinite(std) and std > 0 and math.isfinite(ref)):
            continue
        z = (ref - value) / std
        inside = lo <= ref <= hi
        who = reference_label[0].upper() + reference_label[1:]
        where = (f"{who}, {sig(ref)} {unit}, lies inside the 95 % interval of the {words} "
                 f"[{sig(lo)}, {sig(hi)}] {unit}, {abs(z):.2g} standard errors from the estimate {sig(value)}.")
        if not inside:
            side = "above" if z > 0 else "below"
            where = (f"{who}, {sig(ref)} {unit}, lies {abs(z):.3g} standard errors {side} the {words} "
                     f"estimate {sig(value)} {unit}, outside its 95 % interval [{sig(lo)}, {sig(hi)}]: "
                     + _sentences(_miss_causes(key, model, value, std, ref, reference_label, truth, step_volts)))
        out.append(TruthCheck(words, unit, value, std, (lo, hi), ref, reference_label, z, inside, where))
    return tuple(out)


def _sentences(parts: list[str]) -> str:
    """The causes as one text: the first continues the sentence before it, the others start their own."""
    return " ".join([parts[0]] + [p[0].upper() + p[1:] for p in parts[1:]])


def _miss_causes(key: str, model: Any, value: float, std: float, ref: float, label: str,
                 truth: Mapping[str, Any] | None, step_volts: float | None) -> list[str]:
    """The sentences that explain a miss, most specific first (at least one)."""
    causes: list[str] = []
    offset = _input_offset(truth)
    if key == "dc_gain" and label == TRUTH_LABEL and offset > 0 and step_volts:
        sentence, z_corrected = _input_offset_cause(value, std, ref, offset, step_volts)
        causes.append(sentence)
        if abs(z_corrected) <= Z95:
            return causes  # the offset explains the whole miss
    scale_only = [role for role, nm in noise_of(model).items() if nm.scale_only]
    if scale_only:
        causes.append(f"the 8-bit codes of the {', '.join(scale_only)} channel are not dithered by its noise: their "
                      "error is a staircase, correlated from sample to sample, so the interval, which treats it as "
                      "random, is too narrow.")
    if label == TRUTH_LABEL:
        causes.append("the truth is the linearised plant, without its friction, dead-zones and amplifier "
                      "nonlinearity; the interval covers the noise of the record only, not this difference "
                      "of structure.")
    if label == CLASSIC_LABEL:
        causes.append("the classic estimate reads the final value and the 63 % time off single points of the "
                      "record and ignores the fast poles, so it differs from the fitted model by more than the "
                      "model's own standard error; the interval is that of the fitted model, not of the classic "
                      "read-off.")
    if key == "time_constant" and model.delay_s > 0:
        causes.append(f"The fitted τ excludes a dead time of {1e3 * model.delay_s:.3g} ms (τ + dead time = "
                      f"{sig(value + model.delay_s)} s).")
    return causes


def _input_offset(truth: Mapping[str, Any] | None) -> float:
    """The trainer's friction as an input-equivalent offset (V), 0 when unknown."""
    doc = truth or {}
    value = doc.get("transfer_functions", {}).get("equivalent_input_offset_v", doc.get("equivalent_input_offset_v"))
    try:
        offset = float(value or 0.0)
    except (TypeError, ValueError):
        return 0.0
    return offset if math.isfinite(offset) else 0.0


def _input_offset_cause(value: float, std: float, ref: float, offset_v: float, step_v: float) -> tuple[str, float]:
    """Coulomb friction seen as an input offset: the gain output/step is low by ``offset/step``.

    Returns the sentence and the distance of the corrected estimate from the truth in its
    standard errors.
    """
    factor = 1.0 - offset_v / step_v
    corrected, corrected_std = value / factor, std / factor
    z = (ref - corrected) / corrected_std
    return (f"the trainer's friction acts as an input offset of {sig(offset_v, 3)} V, so of the "
            f"{sig(step_v, 3)} V step the motor sees {sig(step_v - offset_v, 3)} V and the gain measured as "
            f"output/step is {100 * offset_v / step_v:.2g} % below the linearised truth; corrected for it the "
            f"estimate is {sig(corrected)}, {abs(z):.2g} standard errors from the truth.", z)


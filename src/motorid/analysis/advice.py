"""The experiment advisor: from a first capture, how to record the next one.

For each setting of the oscilloscope — volts/div of each channel, time/div (the record after the
step and the sample interval: a TDS1000/2000/TBS1000 record is always 2500 points), the trigger
position (samples before the step), the step level and Average mode — the 95 % interval widths
the same identification would report on a record taken at that setting are predicted from the
Fisher information of the fitted output-error model (:func:`~motorid.identification.output_error.planned_uncertainty`):
the fit's own residuals and Jacobian on the planned time grid, whitened by the noise model
measured on the capture, with the 8-bit quantiser's step ``volts/div / 25`` in the noise and in
the plateaus' levels.  No rule of thumb decides: a setting is suggested when its predicted widths
are narrower; a setting whose predicted trace leaves the screen is never suggested.

Assumptions (each one is a statement about the scope or the noise, not a tuning knob):

- The noise measured on the capture is the quantiser's (``q²/12``, white) plus the rest (front-end
  noise, ripple), whose per-sample level and colour (the AR whitening polynomial) stay when the
  sample interval changes: the front end's noise is white per sample.
- Average mode divides the variance of the rest by N; the quantiser's step stays, because the
  TDS1000/2000 keeps 8-bit records in Average mode (``DATa:WIDth 2`` pads a zero byte:
  TDS1000/TDS2000 Programmer Manual, DATa:WIDth).
- A step level changes the signal over the noise, but also the operating point: the dead-zone,
  friction and the amplifier's rails are outside a linear model, so a step level is suggested
  alone (with that caveat) and never in the combined suggestion.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from motorid._threads import single_blas_thread
from motorid.capture import Capture
from motorid.conditioning.pipeline import ConditionedExperiment
from motorid.errors import OptionError
from motorid.identification.output_error import OeResult, PlannedUncertainty, planned_uncertainty
from motorid.identification.pipeline import Identification
from motorid.identification.result import IdentificationError
from motorid.identification.stages import (
    MAX_RECORD_TIME_CONSTANTS,
    NoiseModel,
    noise_model,
    oe_stage,
    quantisation_bias_std,
    refine_noise,
)
from motorid.model import MotorModel
from motorid.numfmt import sig

__all__ = [
    "AVERAGES",
    "RECORD_POINTS",
    "Advice",
    "AdviceSettings",
    "RecordSettings",
    "Suggestion",
    "Widths",
    "advise",
    "current_settings",
    "time_per_div_ladder",
    "volts_per_div_ladder",
]

#: Points per record of the TDS1000/2000/TBS1000 (10 horizontal divisions).
RECORD_POINTS = 2500
#: Average mode's counts on the TDS1000/2000 (1: Sample mode).
AVERAGES: tuple[int, ...] = (1, 4, 16, 64, 128)
#: Half the screen in divisions that a trace may use: the 8-bit range is −5.12…+5.08 divisions.
SCREEN_HALF_DIVS = 5.0
#: The 8-bit quantiser's codes per vertical division.
CODES_PER_DIV = 25.0
#: Trigger positions tried (% of the record before the trigger point).
TRIGGER_POSITIONS_PCT: tuple[float, ...] = (5.0, 10.0, 15.0, 20.0, 30.0, 40.0, 50.0)
#: Records shorter than this many 63 % times after the step are not suggested: the planned
#: Fisher information trusts the model, and a record that does not show the steady state cannot
#: check it.
MIN_RECORD_T63 = 3.0
#: Records longer than this many 63 % times after the step are not tried (the fit uses
#: at most :data:`~motorid.identification.stages.MAX_RECORD_TIME_CONSTANTS` of them).
MAX_RECORD_T63 = 200.0
#: Step levels tried, as multiples of the current one (within the input range).
STEP_FACTORS: tuple[float, ...] = (0.5, 0.75, 1.25, 1.5, 2.0)
#: The trainer's (and a typical servo amplifier's) input range, ±V.
INPUT_RANGE_V = 10.0
#: A channel's random (not quantiser) noise variance is taken as at least this fraction of its
#: measured innovation variance: the split of an 8-bit trace's noise into quantiser and the rest
#: is uncertain when the quantiser dominates, and the prediction should not promise more than
#: about a three-fold narrowing from the vertical scale alone.
MIN_RANDOM_FRACTION = 0.1


def volts_per_div_ladder(probe: float = 1.0) -> tuple[float, ...]:
    """The vertical scales of a TDS1000/2000/TBS1000 channel: 2 mV to 5 V per division in 1-2-5 steps.

    Parameters
    ----------
    probe : float
        Probe attenuation (10: 20 mV to 50 V per division at the probe's tip).

    Returns
    -------
    tuple of float
        Volts per division, ascending.

    References
    ----------
    TDS1000/TDS2000 Series User Manual, Specifications: "Volts/Div Range 2 mV to 5 V/div at
    input BNC" in a 1-2-5 sequence.
    """
    base = [m * 10.0**e for e in range(-3, 1) for m in (1.0, 2.0, 5.0)]
    return tuple(round(probe * v, 12) for v in base if 2e-3 - 1e-12 <= v <= 5.0 + 1e-12)


def time_per_div_ladder() -> tuple[float, ...]:
    """The horizontal scales of a TDS1000/2000/TBS1000: 2.5 ns to 50 s per division, 1-2.5-5 sequence.

    Returns
    -------
    tuple of float
        Seconds per division, ascending.

    References
    ----------
    TDS1000/TDS2000 Series User Manual, Specifications: "Sec/Div Range 2.5 ns to 50 s/div, in a
    1, 2.5, 5 sequence" (TDS2012C and TBS1000 alike).
    """
    out = [m * 10.0**e for e in range(-9, 2) for m in (1.0, 2.5, 5.0)]
    return tuple(round(v, 15) for v in out if 2.5e-9 - 1e-21 <= v <= 50.0 + 1e-12)


@dataclass(frozen=True, slots=True)
class AdviceSettings:
    """How the advisor decides.

    Attributes
    ----------
    threshold : float
        A setting is worth changing when it narrows the DC gain's or the time constant's
        predicted 95 % interval by more than this fraction (0.2: 20 %) and widens neither by as
        much.
    """

    threshold: float = 0.2

    def __post_init__(self) -> None:
        if not (isinstance(self.threshold, (int, float)) and 0.0 < self.threshold < 1.0):
            raise OptionError(f"--threshold must be a fraction between 0 and 1, got {self.threshold!r}")


@dataclass(frozen=True, slots=True)
class RecordSettings:
    """One way of recording the experiment on the scope.

    Attributes
    ----------
    volts_per_div : Mapping[str, float]
        Vertical scale of each channel: ``input`` (CH1, the step) and each capture's role (its CH2).
    time_per_div_s : float
        Horizontal scale (the record is 10 divisions, 2500 points).
    trigger_position_pct : float
        Part of the record before the trigger point (the step), %.
    step_volts : float
        Step level.
    averages : int
        Acquisitions averaged (1: Sample mode).
    """

    volts_per_div: Mapping[str, float]
    time_per_div_s: float
    trigger_position_pct: float
    step_volts: float
    averages: int = 1

    @property
    def sample_interval_s(self) -> float:
        """Seconds per sample: 10 divisions over 2500 points."""
        return 10.0 * self.time_per_div_s / RECORD_POINTS

    @property
    def samples_before(self) -> int:
        """Samples before the step."""
        return round(self.trigger_position_pct / 100.0 * RECORD_POINTS)

    def to_dict(self) -> dict[str, Any]:
        """The settings as the advice JSON writes them.

        Returns
        -------
        dict
            ``volts_per_div`` (by channel), ``time_per_div_s``, ``trigger_position_pct``,
            ``sample_interval_s``, ``step_volts``, ``averages``.
        """
        return {"volts_per_div": {k: float(v) for k, v in self.volts_per_div.items()},
                "time_per_div_s": float(self.time_per_div_s),
                "trigger_position_pct": float(self.trigger_position_pct),
                "sample_interval_s": float(self.sample_interval_s), "step_volts": float(self.step_volts),
                "averages": int(self.averages)}


def _rel(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


@dataclass(frozen=True, slots=True)
class Widths:
    """Predicted 95 % interval widths, each the full width over the estimate.

    Attributes
    ----------
    dc_gain, time_constant : float
        Of the DC gain and the time constant (inf: not determined).
    dead_time : float or None
        Of the dead time (``None``: the model has none).
    electrical_pole : float or None
        Of the fastest pole after the dominant one (``None``: a one-pole model).
    """

    dc_gain: float
    time_constant: float
    dead_time: float | None = None
    electrical_pole: float | None = None

    @property
    def electrical_pole_resolvable(self) -> bool | None:
        """Whether the electrical pole's interval is narrower than the pole (``None``: no such pole)."""
        if self.electrical_pole is None:
            return None
        return bool(self.electrical_pole < 1.0)

    def to_dict(self) -> dict[str, Any]:
        """The ``predicted`` object of the advice JSON (``null`` for a width the record cannot give).

        Returns
        -------
        dict
            ``dc_gain_ci95_width_rel``, ``time_constant_ci95_width_rel``, and when they apply
            ``dead_time_ci95_width_rel``, ``electrical_pole_ci95_width_rel`` and
            ``electrical_pole_resolvable``.
        """
        out: dict[str, Any] = {"dc_gain_ci95_width_rel": _rel(self.dc_gain),
                               "time_constant_ci95_width_rel": _rel(self.time_constant)}
        if self.dead_time is not None:
            out["dead_time_ci95_width_rel"] = _rel(self.dead_time)
        if self.electrical_pole is not None:
            out["electrical_pole_ci95_width_rel"] = _rel(self.electrical_pole)
            out["electrical_pole_resolvable"] = self.electrical_pole_resolvable
        return out

    def gain_over(self, other: Widths) -> float:
        """The larger relative narrowing of the DC gain's or τ's interval against ``other`` (0.3: 30 %).

        Parameters
        ----------
        other : Widths
            The reference (the current settings').

        Returns
        -------
        float
            ``max(1 − dc/dc_other, 1 − τ/τ_other)``.
        """
        return max(1.0 - self.dc_gain / other.dc_gain, 1.0 - self.time_constant / other.time_constant)


@dataclass(frozen=True, slots=True)
class Suggestion:
    """One setting changed alone.

    Attributes
    ----------
    setting : str
        ``volts_per_div``, ``time_per_div_s``, ``trigger_position_pct``, ``sample_interval_s``,
        ``step_volts`` or ``averages``.
    channel : str or None
        For ``volts_per_div``: ``input`` or the capture's role.
    now, suggested : float
        The current and the suggested value.
    why : str
        One sentence.
    predicted : Widths
        The widths with this change alone.
    cost : str or None
        What the change costs besides a new record (more acquisitions, another operating point).
    """

    setting: str
    channel: str | None
    now: float
    suggested: float
    why: str
    predicted: Widths
    cost: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """One item of the advice JSON's ``suggestions``.

        Returns
        -------
        dict
            ``setting``, ``channel``, ``now``, ``suggested``, ``why``, ``predicted``, ``cost``.
        """
        return {"setting": self.setting, "channel": self.channel, "now": self.now, "suggested": self.suggested,
                "why": self.why, "predicted": self.predicted.to_dict(), "cost": self.cost}


@dataclass(frozen=True, slots=True)
class Advice:
    """How to record the next capture, with the intervals each change is predicted to give.

    Attributes
    ----------
    settings : RecordSettings
        The capture's own settings.
    now : Widths
        The widths predicted for them (the identification's, without the structure's spread).
    suggestions : tuple of Suggestion
        Settings worth changing, one at a time, the one that narrows τ's interval most first.
    combined : RecordSettings
        All the free settings (volts/div, time/div, trigger position) changed together; the
        capture's own when nothing is worth changing.
    combined_predicted : Widths
        The widths predicted for them.
    threshold : float
        The narrowing a change must bring to be worth it.
    notes : tuple of str
        What the advice assumed (channels without a vertical scale, several time bases…).
    """

    settings: RecordSettings
    now: Widths
    suggestions: tuple[Suggestion, ...]
    combined: RecordSettings
    combined_predicted: Widths
    threshold: float
    notes: tuple[str, ...] = field(default=())

    @property
    def worth_changing(self) -> bool:
        """Whether any free setting narrows the gain's or τ's interval by more than the threshold."""
        return any(s.cost is None for s in self.suggestions)

    @property
    def most_important(self) -> Suggestion | None:
        """The free setting that narrows τ's interval most (``None``: nothing worth changing)."""
        return next((s for s in self.suggestions if s.cost is None), None)

    def summary_line(self) -> str:
        """One line: what to change first and how much it narrows the intervals, or that nothing is worth it.

        Returns
        -------
        str
            The line ``identify`` prints under ``advice:``.
        """
        if not self.worth_changing:
            line = (f"nothing worth changing: no scope setting narrows the gain's or τ's 95 % interval by more "
                    f"than {100 * self.threshold:.0f} %")
            costly = next((x for x in self.suggestions if x.setting == "averages"), None)
            if costly is not None:
                line += (f" (Average mode over {sig(costly.suggested)} steps would: τ {_pct(self.now.time_constant)} → "
                         f"{_pct(costly.predicted.time_constant)})")
            return line
        s = next(x for x in self.suggestions if x.cost is None)
        name, unit = _LABELS[s.setting]
        name = name.format(channel=s.channel)
        return (f"record again with {name} {sig(s.suggested)}{unit} (now {sig(s.now)}{unit}): τ's interval "
                f"{_pct(self.now.time_constant)} → {_pct(s.predicted.time_constant)}, the gain's "
                f"{_pct(self.now.dc_gain)} → {_pct(s.predicted.dc_gain)}; all together: τ "
                f"{_pct(self.combined_predicted.time_constant)} (motorid advise)")

    def to_dict(self) -> dict[str, Any]:
        """The advice JSON (docs/formats.md "Advice JSON").

        Returns
        -------
        dict
            ``schema``, ``now``, ``settings``, ``suggestions``, ``combined`` {``settings``,
            ``predicted``}, ``worth_changing``, ``threshold``, ``notes``.
        """
        return {"schema": "motorid.advice/1", "now": self.now.to_dict(), "settings": self.settings.to_dict(),
                "suggestions": [s.to_dict() for s in self.suggestions],
                "combined": {"settings": self.combined.to_dict(), "predicted": self.combined_predicted.to_dict()},
                "worth_changing": self.worth_changing, "threshold": self.threshold, "notes": list(self.notes)}


#: How a setting reads in a sentence: its name and unit.
_LABELS: dict[str, tuple[str, str]] = {
    "volts_per_div": ("the {channel} channel at", " V/div"),
    "time_per_div_s": ("time/div", " s"),
    "trigger_position_pct": ("the trigger position at", " % of the record"),
    "sample_interval_s": ("a sample interval of", " s"),
    "step_volts": ("a step of", " V"),
    "averages": ("Average mode over", " acquisitions"),
}


def _pct(width: float) -> str:
    return "undetermined" if not math.isfinite(width) else f"±{sig(50 * width, 2)} %"


@dataclass(frozen=True, slots=True)
class _Channel:
    """What the advisor knows of one channel on the screen."""

    q: float  # the quantiser's step now (V)
    probe: float
    baseline_v: float  # the raw trace's level before the step
    margin_v: float  # noise and spikes around the model's trace
    random_var: float  # innovation variance that is not the quantiser's
    pre_random_var: float  # the same of the pre-step samples
    pre_var: float  # raw pre-step variance beyond the quantiser's (for the level's error)
    settled_var: float  # raw settled variance beyond the quantiser's
    residual_var: float  # the fit's residual variance beyond the quantiser's (the dither a finer scale shows)
    wrapping: float | None  # a wrapping position's largest |V| (the sawtooth's range), else None
    travelled_v: float  # the largest change the capture recorded after the step


class _Planner:
    """The fitted model, its noise and the capture's screen: widths for any :class:`RecordSettings`."""

    def __init__(self, cond: ConditionedExperiment, model: MotorModel, res: OeResult, noise: NoiseModel,
                 captures: Mapping[str, Capture], now: RecordSettings) -> None:
        self.cond, self.model, self.res, self.noise, self.now = cond, model, res, noise, now
        self.fitted = tuple(res.residuals)
        self.roles = tuple(r for r in cond.responses if r in captures)
        dof = max(res.n_samples - res.params.size, 1)
        self.s2 = 2.0 * res.cost / dof
        self.t63 = float(cond.response_time_s) if np.isfinite(cond.response_time_s) else float(res.time_constant_s)
        self.sampled = {role for role, _ in res.settings.instant_std}
        self.channels = {role: self._channel(role, captures[role]) for role in self.roles}
        self.input = self._input(captures)
        self._cache: dict[Any, Widths | None] = {}

    def _channel(self, role: str, cap: Capture) -> _Channel:
        r = self.cond.responses[role]
        q = self.now.volts_per_div[role] / CODES_PER_DIV
        raw = np.asarray(cap.output_v, dtype=float)
        before = np.asarray(cap.time_s) < float(r.edge.time_s)
        baseline = float(np.mean(raw[before])) if before.any() else float(raw[0])
        q2 = q * q / 12.0
        if role in self.fitted:
            sigma = self.noise.sigma[role]
            margin = float(np.max(np.abs(self.res.residuals[role])))
        else:
            sigma = self.noise.pre_sigma.get(role, q / math.sqrt(12.0))
            margin = 3.0 * float(np.std(raw[before])) if before.sum() > 2 else 3.0 * sigma
        pre_sigma = self.noise.pre_sigma.get(role, sigma)
        y, pre = r.output_v, r.time_s < 0
        after = np.flatnonzero(~pre)
        settled = y[after[int(0.75 * after.size):]]
        wrapping = float(np.max(np.abs(raw))) if r.wraps > 0 else None
        return _Channel(q=q, probe=float(cap.output_info.probe_atten or 1.0), baseline_v=baseline, margin_v=margin,
                        random_var=max(sigma**2 - q2, MIN_RANDOM_FRACTION * sigma**2),
                        pre_random_var=max(pre_sigma**2 - q2, 0.0),
                        pre_var=max(float(np.var(y[pre])) - q2, 0.0) if pre.sum() > 1 else 0.0,
                        settled_var=max(float(np.var(settled)) - q2, 0.0) if settled.size > 1 else 0.0,
                        residual_var=max(float(np.var(self.res.residuals[role])) - q2, 0.0)
                        if role in self.fitted else 0.0,
                        wrapping=wrapping, travelled_v=float(np.max(np.abs(y[~pre]))) if (~pre).any() else 0.0)

    def _input(self, captures: Mapping[str, Capture]) -> tuple[float, float, float]:
        """The input channel's raw baseline, its random variance and its noise margin (V)."""
        q = self.now.volts_per_div.get("input", 0.0) / CODES_PER_DIV
        base, var = [], []
        for role in self.roles:
            cap, r = captures[role], self.cond.responses[role]
            if cap.input_v is None:
                continue
            before = np.asarray(cap.time_s) < float(r.edge.time_s)
            if before.sum() > 2:
                base.append(float(np.mean(cap.input_v[before])))
                var.append(max(float(np.var(cap.input_v[before])) - q * q / 12.0, 0.0))
        if not base:
            return 0.0, 0.0, 0.0
        v = float(np.mean(var))
        return float(np.mean(base)), v, 3.0 * math.sqrt(v + q * q / 12.0)

    # ------------------------------------------------------------------ the planned record

    def _grids(self, s: RecordSettings) -> tuple[dict[str, np.ndarray], int] | None:
        dt = s.sample_interval_s
        n_pre = s.samples_before
        n_after = RECORD_POINTS - n_pre
        length = MAX_RECORD_TIME_CONSTANTS * self.t63
        user = self.cond.settings.record_length_s
        if user is not None:
            length = min(length, user)
        n_after = min(n_after, int(length / dt + 0.5) + 1)
        if n_after < 3 * self.res.params.size:
            return None
        grid = {c: np.arange(n_after) * dt + (0.5 * dt if c in self.sampled else 0.0) for c in self.fitted}
        return grid, n_pre

    def _responses(self, s: RecordSettings, grid: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        """Each channel's model increment on the planned record."""
        res = self.res
        n, m = res.settings.n_poles, res.settings.n_zeros
        k = float(res.params[0])
        taus = np.exp(res.params[1 : 1 + n])
        num = np.array([k])
        for z in res.params[1 + n : 1 + n + m]:
            num = np.convolve(num, [float(z), 1.0])
        from motorid.identification.closed_form import position_closed_form, step_response_closed_form

        t = next(iter(grid.values()))
        t = t - t[0]
        out = {"velocity": step_response_closed_form(t, num, taus, s.step_volts)}
        if "position" in self.roles:
            out["position"] = (res.position_scale or 1.0) * position_closed_form(t, num, taus, s.step_volts)
        if "current" in self.roles and res.current_num is not None:
            lead = float(np.prod(taus))
            out["current"] = step_response_closed_form(t, np.asarray(res.current_num) * lead, taus, s.step_volts)
        return out

    def clips(self, s: RecordSettings, channel: str, vpd: float | None = None) -> bool:
        """Whether the predicted trace of ``channel`` leaves the screen at ``vpd`` (default: the settings')."""
        vpd = s.volts_per_div[channel] if vpd is None else vpd
        limit = SCREEN_HALF_DIVS * vpd
        if channel == "input":
            base, _, margin = self.input
            return max(abs(base), abs(base + s.step_volts)) + margin > limit
        ch = self.channels[channel]
        if ch.wrapping is not None:
            return ch.wrapping + ch.margin_v > limit
        grids = self._grids(s)
        if grids is None:
            return False
        inc = self._responses(s, grids[0]).get(channel)
        if inc is None:
            return False
        top = max(abs(ch.baseline_v + float(np.max(inc))), abs(ch.baseline_v + float(np.min(inc))), abs(ch.baseline_v))
        if channel == "position" and float(np.max(np.abs(inc))) > ch.travelled_v + ch.margin_v \
                and vpd < self.now.volts_per_div[channel]:
            # farther than the capture went: a potentiometer may wrap at a span the capture never showed, so
            # its trace is not known to fit a finer scale than the capture's
            return True
        return top + ch.margin_v > limit

    def any_clips(self, s: RecordSettings) -> bool:
        """Whether any channel's trace leaves the screen."""
        return any(self.clips(s, c) for c in s.volts_per_div)

    def smallest_scale(self, s: RecordSettings, channel: str) -> float:
        """The smallest volts/div of the ladder at which ``channel`` stays on the screen."""
        probe = 1.0 if channel == "input" else self.channels[channel].probe
        for vpd in volts_per_div_ladder(probe):
            if not self.clips(s, channel, vpd):
                return vpd
        return volts_per_div_ladder(probe)[-1]

    def _step_rel_std(self, s: RecordSettings, n_pre: int, n_after: int) -> float:
        """The measured step's and the velocity level's relative errors, as the identification estimates them.

        :func:`~motorid.identification.stages.step_level_std` and
        :func:`~motorid.identification.stages.output_level_rel_std` on the planned record: a trace whose
        noise is well under a code sits on one code, where they see no quantiser (and a trace at rest
        on the zero code has no level error).
        """
        u = abs(s.step_volts)
        base, in_var, _ = self.input
        terms = 0.0
        if "input" in s.volts_per_div and n_pre > 1:
            q = s.volts_per_div["input"] / CODES_PER_DIV
            var = in_var / s.averages
            random = _quantised_var(q, var) * (1.0 / n_pre + 1.0 / max(n_after, 1)) / max(len(self.roles), 1)
            bias = 0.0 if _one_code(q, var) else _bias(q, var) ** 2 * (1.0 + (base != 0.0))
            terms += (random + bias) / u**2
        if "velocity" in self.channels and n_pre > 1 and "velocity" not in self.res.quantum:
            # (a velocity whose quantiser error the fit counts along the record has its levels' in it)
            ch = self.channels["velocity"]
            q = s.volts_per_div["velocity"] / CODES_PER_DIV
            change = abs(self.res.dc_gain * u)
            pre = ch.pre_var / s.averages
            pre_bias = 0.0 if _one_code(q, pre) and ch.baseline_v == 0.0 else _bias(q, pre)
            # the capture's own settled samples for its own settings (what identify measures); for another
            # record the fit's residuals: a coarse scale hides a ripple under a code that a finer one
            # shows (and that dithers it), a short record's "settled" part is still rising
            settled = ch.settled_var if s == self.now else ch.residual_var
            level = math.hypot(pre_bias, _bias(q, settled / s.averages))
            terms += (level / change) ** 2 if change > 0 else 0.0
        return math.sqrt(terms)

    def planned(self, s: RecordSettings) -> PlannedUncertainty | None:
        """The planned uncertainty of a record at ``s`` (``None``: too short a record)."""
        grids = self._grids(s)
        if grids is None:
            return None
        grid, n_pre = grids
        sigma, pre_sigma = {}, {}
        # each fitted channel's code at the planned volts/div
        code = {c: s.volts_per_div.get(c, self.now.volts_per_div[c]) / CODES_PER_DIV for c in self.fitted}
        for c in self.fitted:
            ch = self.channels[c]
            q2 = code[c] ** 2 / 12.0
            sigma[c] = math.sqrt(ch.random_var / s.averages + q2)
            pre_sigma[c] = math.sqrt(ch.pre_random_var / s.averages + q2)
        instant = tuple((c, s.sample_interval_s / math.sqrt(12.0)) for c in self.fitted if c in self.sampled)
        n_after = next(iter(grid.values())).size
        try:
            quantum = {c: q for c, q in code.items() if c in self.res.quantum}
            # the dither the fit of that record would see: its residuals besides the quantiser's
            dither = {c: math.sqrt(self.channels[c].residual_var / s.averages) for c in quantum}
            return planned_uncertainty(self.res, grid, s.step_volts, sigma, whiten=self.noise.whiten,
                                       pre_samples={c: n_pre for c in self.fitted}, pre_sigma=pre_sigma,
                                       instant_std=instant, step_rel_std=self._step_rel_std(s, n_pre, n_after),
                                       variance_scale=self.s2, quantum=quantum, dither_rms=dither)
        except IdentificationError:
            return None

    def widths(self, s: RecordSettings) -> Widths | None:
        """Predicted widths at ``s``; ``None`` when the record is too short or a trace leaves the screen."""
        key = (tuple(sorted(s.volts_per_div.items())), s.time_per_div_s, s.trigger_position_pct, s.step_volts,
               s.averages)
        if key in self._cache:
            return self._cache[key]
        out = None if self.any_clips(s) else self._widths(s)
        self._cache[key] = out
        return out

    def _widths(self, s: RecordSettings) -> Widths | None:
        pu = self.planned(s)
        if pu is None:
            return None

        def rel(key: str) -> float:
            v, sd = pu.values.get(key, float("nan")), pu.std.get(key, float("inf"))
            return float(2 * 1.96 * sd / abs(v)) if v and math.isfinite(v) and math.isfinite(sd) else float("inf")

        n = self.res.settings.n_poles
        return Widths(dc_gain=rel("dc_gain"), time_constant=rel("time_constant"),
                      dead_time=rel("delay") if "delay" in pu.values else None,
                      electrical_pole=rel("pole_1") if n >= 2 else None)

    def record_t63(self, s: RecordSettings) -> float:
        """The record after the step in 63 % times."""
        return (RECORD_POINTS - s.samples_before) * s.sample_interval_s / self.t63


def _one_code(q: float, analog_var: float) -> bool:
    """Whether a level with this much noise stays on one code of step ``q`` (noise under an eighth of a code)."""
    return analog_var < (q / 8.0) ** 2


def _quantised_var(q: float, analog_var: float) -> float:
    """Variance of quantised samples of a level with Gaussian noise: ``σ²`` plus the quantiser's share.

    The quantiser adds ``q²/12`` once the noise dithers it; a level under a code's width of noise mostly
    stays on one code (the first harmonic of the dither's characteristic function, ``exp(−2π²σ²/q²)``).
    """
    return analog_var + q * q / 12.0 * (1.0 - math.exp(-2.0 * math.pi**2 * analog_var / (q * q)))


def _bias(q: float, analog_var: float) -> float:
    """:func:`~motorid.identification.stages.quantisation_bias_std` of a plateau with this much dither."""
    y = np.array([1.0, -1.0]) * math.sqrt(analog_var + q * q / 12.0)
    return quantisation_bias_std(y, q)


# ---------------------------------------------------------------------------- the capture's settings


def current_settings(captures: Mapping[str, Capture], cond: ConditionedExperiment) -> tuple[RecordSettings, list[str]]:
    """The scope settings the captures were recorded at (their headers).

    Parameters
    ----------
    captures : Mapping[str, Capture]
        The captures by role.
    cond : ConditionedExperiment
        Their conditioned step responses (the step's place in each record).

    Returns
    -------
    (RecordSettings, list of str)
        The settings and notes on what was assumed.

    Raises
    ------
    OptionError
        A capture without the scope's header (vertical and horizontal scales).
    """
    notes: list[str] = []
    vpd: dict[str, float] = {}
    tpds, pcts = [], []
    for role, r in cond.responses.items():
        cap = captures.get(role)
        if cap is None:
            continue
        scale = cap.output_info.vertical_scale
        n = cap.scope.record_length or cap.time_s.size
        if scale is None or cap.scope.horizontal_scale_s is None or n != RECORD_POINTS:
            raise OptionError(f"{cap.source}: advise needs an oscilloscope capture with its header (volts/div, "
                              f"time/div, a {RECORD_POINTS}-point record); this one has none")
        vpd[role] = float(scale)
        if cap.input_v is not None and cap.input_info is not None and cap.input_info.vertical_scale is not None:
            vpd.setdefault("input", float(cap.input_info.vertical_scale))
        tpds.append(float(cap.scope.horizontal_scale_s))
        before = int(np.count_nonzero(np.asarray(cap.time_s) < float(r.edge.time_s)))
        pcts.append(100.0 * before / n)
    if len(set(tpds)) > 1:
        notes.append(f"the captures were recorded at different time/div ({', '.join(sig(t) for t in tpds)} s): "
                     f"the advice takes the first's")
    pct = float(np.round(np.median(pcts), 1))
    return RecordSettings(vpd, tpds[0], pct, float(cond.step_volts), 1), notes


# ---------------------------------------------------------------------------- the advice


def _fit_again(ident: Identification) -> tuple[OeResult, NoiseModel]:
    """The chosen structure's output-error fit and the noise model of its own residuals.

    The identification keeps the model, not the fit's parameter vector: it is fitted again from the
    model (a few iterations), the noise model re-estimated from its residuals and fitted once more, as
    the order selection does for the structure it keeps.
    """
    model, cond = ident.model, ident.conditioned
    settings = model.settings
    if "n_poles" not in settings:
        raise OptionError(f"advise needs the output-error fit (--method auto or oe), not the {model.method} method's "
                          "model: its intervals are what the advice predicts")
    structure = (int(settings["n_poles"]), int(settings["n_zeros"]))
    delay = bool(settings.get("delay", False))
    noise = noise_model(cond, model)
    res, _ = oe_stage(cond, model, structure, delay=delay, noise=noise)
    noise = refine_noise(noise, res)
    res, _ = oe_stage(cond, model, structure, delay=delay, noise=noise)
    return res, noise


def _time_candidates(planner: _Planner, now: RecordSettings) -> list[float]:
    """The ladder's time/div whose record after the step spans :data:`MIN_RECORD_T63` to :data:`MAX_RECORD_T63`."""
    return [tpd for tpd in time_per_div_ladder()
            if MIN_RECORD_T63 <= planner.record_t63(replace(now, time_per_div_s=tpd)) <= MAX_RECORD_T63]


def _score(w: Widths, ref: Widths) -> float:
    return w.time_constant / ref.time_constant + w.dc_gain / ref.dc_gain


def _worth(w: Widths, ref: Widths, threshold: float) -> bool:
    """A change narrows the gain's or τ's interval by more than ``threshold`` and widens neither by as much."""
    worse = max(w.time_constant / ref.time_constant, w.dc_gain / ref.dc_gain)
    return w.gain_over(ref) > threshold and worse <= 1.0 + threshold


def _fit_screen(planner: _Planner, s: RecordSettings) -> RecordSettings:
    """``s`` with each channel at the smallest volts/div that keeps its trace on the screen."""
    return replace(s, volts_per_div={c: planner.smallest_scale(s, c) for c in s.volts_per_div})


def _describe_record(planner: _Planner, s: RecordSettings) -> str:
    return (f"{planner.record_t63(s):.3g} × the 63 % time after the step, "
            f"{planner.t63 / s.sample_interval_s:.3g} samples per 63 % time")


@single_blas_thread
def advise(ident: Identification, captures: Mapping[str, Capture],
           settings: AdviceSettings = AdviceSettings()) -> Advice:
    """How to record the next capture: each scope setting's predicted interval widths.

    Parameters
    ----------
    ident : Identification
        The identification of the first capture(s) (``--method auto`` or ``oe``).
    captures : Mapping[str, Capture]
        The captures it was identified from, by role (their headers give the settings).
    settings : AdviceSettings
        The threshold of a worthwhile change.

    Returns
    -------
    Advice
        The current widths, the suggestions one setting at a time (best for τ first) and the
        combined suggestion.

    Raises
    ------
    OptionError
        Captures without a scope header, a model not from the output-error fit.
    """
    cond = ident.conditioned
    now, notes = current_settings(captures, cond)
    res, noise = _fit_again(ident)
    planner = _Planner(cond, ident.model, res, noise, captures, now)
    ref = planner._widths(now)
    if ref is None or not (math.isfinite(ref.dc_gain) and math.isfinite(ref.time_constant)):
        raise IdentificationError("advise: the fitted model's intervals cannot be predicted from this capture "
                                  "(its Fisher information is singular)")
    thr = settings.threshold
    clipped_now = [c for c in now.volts_per_div if planner.clips(now, c)]
    suggestions: list[Suggestion] = []

    def offer(setting: str, channel: str | None, value: float, trial: RecordSettings, why: str,
              cost: str | None = None) -> None:
        w = planner.widths(trial)
        if w is None:
            return
        forced = channel is not None and channel in clipped_now
        if forced or _worth(w, ref, thr):
            suggestions.append(Suggestion(setting, channel, float(_value_now(now, setting, channel)), float(value),
                                          why, w, cost))

    # volts/div: the smallest that keeps each trace on the screen
    for c, vpd in now.volts_per_div.items():
        best = planner.smallest_scale(now, c)
        if best == vpd:
            continue
        trial = replace(now, volts_per_div={**now.volts_per_div, c: best})
        if c in clipped_now:
            why = f"the {c} trace is predicted to leave the screen at {sig(vpd)} V/div"
        else:
            why = (f"the {c} trace uses {_divisions(planner, now, c):.1f} of 8 divisions: the 8-bit quantiser's step "
                   f"is {sig(1e3 * vpd / CODES_PER_DIV)} mV; at {sig(best)} V/div it is "
                   f"{sig(1e3 * best / CODES_PER_DIV)} mV")
        offer("volts_per_div", c, best, trial, why)
    # time/div: the record after the step and the sample interval together
    scored = []
    for tpd in _time_candidates(planner, now):
        if tpd == now.time_per_div_s:
            continue
        w = planner.widths(replace(now, time_per_div_s=tpd))
        if w is not None and _worth(w, ref, thr):
            scored.append((_score(w, ref), tpd))
    if scored:
        tpd = min(scored)[1]
        trial = replace(now, time_per_div_s=tpd)
        offer("time_per_div_s", None, tpd, trial,
              f"now the record is {_describe_record(planner, now)}; at {sig(tpd)} s/div it is "
              f"{_describe_record(planner, trial)} (sample interval {sig(trial.sample_interval_s)} s)")
    # trigger position: samples before the step pin the offsets, the rest records the response
    scored = []
    for pct in TRIGGER_POSITIONS_PCT:
        trial = replace(now, trigger_position_pct=pct)
        if planner.record_t63(trial) < min(MIN_RECORD_T63, planner.record_t63(now)):
            continue
        w = planner.widths(trial)
        if w is not None and pct != now.trigger_position_pct and _worth(w, ref, thr):
            scored.append((_score(w, ref), pct))
    if scored:
        pct = min(scored)[1]
        offer("trigger_position_pct", None, pct, replace(now, trigger_position_pct=pct),
              f"{replace(now, trigger_position_pct=pct).samples_before} samples before the step instead of "
              f"{now.samples_before}: the offsets against the record after the step")
    # averaging: the smallest count that gets within 10 % of the most averaging's τ width
    avg = [(n, planner.widths(replace(now, averages=n))) for n in AVERAGES if n > now.averages]
    avg_ok = [(n, w) for n, w in avg if w is not None and _worth(w, ref, thr)]
    if avg_ok:
        best_tau = min(w.time_constant for _, w in avg_ok)
        n = next(n for n, w in avg_ok if w.time_constant <= 1.1 * best_tau)
        offer("averages", None, n, replace(now, averages=n),
              f"Average mode over {n} steps divides the random noise's variance by {n} (the quantiser's step stays: "
              "the scope keeps 8-bit records)", cost=f"{n} steps per capture (a repeating step, e.g. a square wave)")
    # step level: more signal over the same noise, at another operating point
    steps = sorted({round(now.step_volts * f, 2) for f in STEP_FACTORS if abs(now.step_volts * f) <= INPUT_RANGE_V})
    scored = []
    for u in steps:
        w = planner.widths(replace(now, step_volts=u))
        if w is not None and _worth(w, ref, thr):
            scored.append((_score(w, ref), u))
    if scored:
        u = min(scored)[1]
        levels = ", ".join(sig(round(u * f, 1)) for f in (0.25, 0.5, 0.75, 1.0))
        offer("step_volts", None, u, replace(now, step_volts=u),
              f"a step of {sig(u)} V instead of {sig(now.step_volts)} V: more signal against the same noise",
              cost="another operating point: keep the step clear of the dead-zone and the amplifier's rails, which a "
                   f"linear model cannot see; for the static characteristic record several levels ({levels} V: "
                   "motorid identify --velocity A --velocity B ...)")
    suggestions.sort(key=lambda x: (x.cost is not None, x.predicted.time_constant))
    combined, combined_w = _combine(planner, now, ref, thr)
    return Advice(now, ref, tuple(suggestions), combined, combined_w, thr, tuple(notes))


def _value_now(now: RecordSettings, setting: str, channel: str | None) -> float:
    if setting == "volts_per_div":
        return now.volts_per_div[channel or ""]
    return float(getattr(now, setting))


def _divisions(planner: _Planner, s: RecordSettings, channel: str) -> float:
    """Peak-to-peak divisions the channel's trace uses."""
    vpd = s.volts_per_div[channel]
    if channel == "input":
        return abs(s.step_volts) / vpd
    ch = planner.channels[channel]
    if ch.wrapping is not None:
        return 2 * ch.wrapping / vpd
    grids = planner._grids(s)
    inc = planner._responses(s, grids[0]).get(channel) if grids is not None else None
    if inc is None:
        return float("nan")
    return float(np.ptp(np.r_[0.0, inc])) / vpd


def _combine(planner: _Planner, now: RecordSettings, ref: Widths, thr: float) -> tuple[RecordSettings, Widths]:
    """Time/div, trigger position and each volts/div together (a grid over the first two)."""
    best: tuple[float, RecordSettings, Widths] | None = None
    for tpd in _time_candidates(planner, now):
        for pct in sorted({*TRIGGER_POSITIONS_PCT, now.trigger_position_pct}):
            trial = _fit_screen(planner, replace(now, time_per_div_s=tpd, trigger_position_pct=pct))
            if planner.record_t63(trial) < MIN_RECORD_T63:
                continue
            w = planner.widths(trial)
            if w is None:
                continue
            score = _score(w, ref)
            if _worth(w, ref, thr) and (best is None or score < best[0]):
                best = (score, trial, w)
    if best is None:
        return now, ref
    return best[1], best[2]

"""The conditioning pipeline: captures → synchronised, reduced step responses.

Order as in the paper (Masoud 2019, section V): step responses (edge, baseline, unwrapping)
→ synchronisation → optional denoising of the current → sample reduction.  Differentiation
is left to the identification method that needs it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from motorid.capture import Capture
from motorid.conditioning.denoise import fft_denoise
from motorid.conditioning.resample import ratio_for_interval, sample_reduction
from motorid.conditioning.response import StepResponse, step_response
from motorid.conditioning.sync import synchronise
from motorid.errors import ConditioningError, OptionError

__all__ = ["ConditioningSettings", "ConditionedExperiment", "condition_experiment"]


@dataclass(frozen=True, slots=True)
class ConditioningSettings:
    """How captures are conditioned (defaults: the paper's).

    Attributes
    ----------
    sample_interval_s : float or None
        Target sample interval after reduction (paper: 0.1 s); ``None`` keeps the recording's.
    ratio : int or None
        Reduction ratio; overrides ``sample_interval_s``.
    reduction : str
        ``subsample`` (the paper's), ``block_mean`` or ``fir``.
    record_length_s : float or None
        Length kept after the step (the paper's 1.9/2.4/2.9 s); all when ``None``.
    sync : str
        ``interp`` or ``index`` (see :func:`synchronise`).
    denoise_current : bool
        FFT-denoise the armature current before reduction.
    step_tolerance : float
        Relative difference of step levels above which captures are refused as not of the
        same experiment.
    """

    sample_interval_s: float | None = 0.1
    ratio: int | None = None
    reduction: str = "subsample"
    record_length_s: float | None = None
    sync: str = "interp"
    denoise_current: bool = True
    step_tolerance: float = 0.03


@dataclass(frozen=True, slots=True)
class ConditionedExperiment:
    """Synchronised step responses of one experiment, full rate and reduced.

    Attributes
    ----------
    time_s, input_v : ndarray
        Reduced grid from the step edge and the input increment on it.
    outputs : dict[str, ndarray]
        Reduced output increments keyed by role.
    full_time_s, full_input_v : ndarray
        The same before reduction.
    full_outputs : dict[str, ndarray]
        Output increments before reduction (current not denoised).
    step_volts : float
        Step level (mean over the captures).
    sources : dict[str, str]
        File of each role.
    responses : dict[str, StepResponse]
        The individual step responses (on each file's own grid).
    settings : ConditioningSettings
        How it was done.
    ratio : int
        Reduction ratio used.
    warnings : tuple of str
        Everything the user should know.
    """

    time_s: np.ndarray
    input_v: np.ndarray
    outputs: dict[str, np.ndarray]
    full_time_s: np.ndarray
    full_input_v: np.ndarray
    full_outputs: dict[str, np.ndarray]
    step_volts: float
    sources: dict[str, str]
    responses: dict[str, StepResponse]
    settings: ConditioningSettings
    ratio: int
    warnings: tuple[str, ...] = field(default=())

    @property
    def sample_interval_s(self) -> float:
        """Sample interval after reduction."""
        return float(self.time_s[1] - self.time_s[0]) if self.time_s.size > 1 else float("nan")


def condition_experiment(
    captures: Mapping[str, Capture],
    settings: ConditioningSettings = ConditioningSettings(),
    *,
    step_volts: float | None = None,
    t0_s: float | None = None,
) -> ConditionedExperiment:
    """Condition the captures of one step experiment.

    Parameters
    ----------
    captures : Mapping[str, Capture]
        Captures keyed by role (``position``, ``velocity``, ``current``).
    settings : ConditioningSettings
        Reduction, record length, synchronisation.
    step_volts : float, optional
        Step level for captures without an input channel.
    t0_s : float, optional
        Step instant on the files' time axis (for captures without an input channel).

    Returns
    -------
    ConditionedExperiment
        Synchronised, reduced step responses.

    Raises
    ------
    ConditioningError
        Captures of different step levels (naming both files and levels), or too little
        record after the step.
    """
    if not captures:
        raise OptionError("give at least one capture (--velocity or --position)")
    responses = {
        role: step_response(cap, role, step_volts=step_volts, t0_s=t0_s) for role, cap in captures.items()
    }
    warnings: list[str] = []
    for r in responses.values():
        warnings.extend(f"{r.source}: {w}" for w in r.warnings)
    items = list(responses.values())
    for a in items:
        for b in items:
            if a is b or abs(a.step_volts) < abs(b.step_volts):
                continue
            if abs(a.step_volts - b.step_volts) > settings.step_tolerance * max(abs(a.step_volts), 1e-12):
                raise ConditioningError(
                    f"captures of different step levels: {a.source} has {a.step_volts:.4g} V, "
                    f"{b.source} has {b.step_volts:.4g} V; record all captures with the same step"
                )
    synced = synchronise(items, length_s=settings.record_length_s, method=settings.sync)
    dt = float(synced.time_s[1] - synced.time_s[0])
    if settings.ratio is not None:
        ratio = int(settings.ratio)
    elif settings.sample_interval_s is not None:
        ratio = ratio_for_interval(dt, settings.sample_interval_s)
    else:
        ratio = 1
    outs = dict(synced.outputs)
    if settings.denoise_current and "current" in outs:
        outs["current"] = fft_denoise(outs["current"], dt).values
    roles = list(outs)
    stacked = np.vstack([synced.input_v] + [outs[r] for r in roles])
    red = sample_reduction(synced.time_s, stacked, ratio, settings.reduction)
    if red.time_s.size < 6:
        raise ConditioningError(
            f"only {red.time_s.size} samples left after reduction by {ratio}, at least 6 are "
            "needed: use a shorter --sample-interval or a longer record"
        )
    return ConditionedExperiment(
        time_s=red.time_s,
        input_v=red.values[0],
        outputs={r: red.values[i + 1] for i, r in enumerate(roles)},
        full_time_s=synced.time_s,
        full_input_v=synced.input_v,
        full_outputs=dict(synced.outputs),
        step_volts=float(np.mean([r.step_volts for r in items])),
        sources=synced.sources,
        responses=responses,
        settings=settings,
        ratio=ratio,
        warnings=tuple(warnings),
    )

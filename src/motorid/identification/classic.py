"""Classic first-order identification: steady-state gain and the 63.2 % time constant.

The baseline students start from (lab report §1.1; Masoud 2019, Fig. 1 and eq. 43): the
velocity step response is taken as ``K·V0·(1 − e^(−t/τ))``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from motorid.blockwise import BLOCK, line_slope
from motorid.identification.arrays import check_step_level, response_arrays
from motorid.identification.result import IdentificationError

__all__ = ["SETTLE_WARN", "ClassicResult", "classic_first_order", "first_crossing"]

#: Change over the last 20 % of the record, relative to the final value, above which the
#: record is reported as not settled.
SETTLE_WARN = 0.02
_RISE = 1.0 - math.exp(-1.0)  # 0.632…


@dataclass(frozen=True, slots=True)
class ClassicResult:
    """Outcome of :func:`classic_first_order`.

    Attributes
    ----------
    dc_gain : float
        Steady-state velocity per input volt.
    time_constant_s : float
        Time from the step to 63.2 % of the final value.
    final_value : float
        Steady-state velocity in volts (mean of the last 10 % of the record).
    step_volts : float
    warnings : tuple of str
    """

    dc_gain: float
    time_constant_s: float
    final_value: float
    step_volts: float
    warnings: tuple[str, ...]

    @property
    def k(self) -> float:
        """The paper's ``k`` in ``k/(s+p)`` (eq. 43): ``dc_gain / τ``."""
        return self.dc_gain / self.time_constant_s

    @property
    def p(self) -> float:
        """The paper's ``p`` in ``k/(s+p)``: ``1/τ``."""
        return 1.0 / self.time_constant_s

    def to_model(self) -> Any:
        """The result as a :class:`motorid.model.MotorModel` with the state ``velocity``.

        Returns
        -------
        MotorModel
            A first-order model ``k/(s+p)``.
        """
        from motorid.model import MotorModel

        return MotorModel(
            A=np.array([[-self.p]]), B=np.array([[self.k]]), C=np.array([[1.0]]), D=np.array([[0.0]]),
            states=("velocity",),
            outputs=("velocity",), step_volts=self.step_volts, method="classic",
            settings={"final_fraction": 0.1, "rise_fraction": _RISE}, warnings=self.warnings,
        )


def first_crossing(time_s: np.ndarray, y: np.ndarray, level: float) -> tuple[float, int]:
    """First time ``y`` reaches ``level``, linearly interpolated.

    Rising for a positive level, falling for a negative one; interpolated between the samples either
    side.

    Parameters
    ----------
    time_s : ndarray
        Sample times in s.
    y : ndarray
        The response.
    level : float
        The level to reach.

    Returns
    -------
    (float, int)
        The time and the index of the first sample at or past the level; ``(nan, -1)`` when
        it is never reached, ``(time_s[0], 0)`` when the first sample is already past it.
    """
    sign = np.sign(level) or 1.0
    i = -1
    for start in range(0, y.size, BLOCK):
        # in blocks: the same test per sample, without the index array of a long record's samples past it
        hit = (y[start : start + BLOCK] - level) * sign >= 0
        if hit.any():
            i = start + int(np.argmax(hit))
            break
    if i < 0:
        return float("nan"), -1
    if i == 0:
        return float(time_s[0]), 0
    dy = y[i] - y[i - 1]
    frac = (level - y[i - 1]) / dy if dy != 0 else 0.0
    return float(time_s[i - 1] + frac * (time_s[i] - time_s[i - 1])), i


def classic_first_order(time_s: Any, y: Any, step_volts: float, *, t0: float = 0.0) -> ClassicResult:
    """Gain and 63.2 % time constant of a velocity step response.

    Parameters
    ----------
    time_s : array_like
        Sample times in seconds.
    y : array_like
        Velocity channel in volts, starting from 0 before the step.
    step_volts : float
        Input step level.
    t0 : float
        Time of the step edge.

    Returns
    -------
    ClassicResult
        ``dc_gain = y_ss / step_volts`` with ``y_ss`` the mean of the last 10 % of the
        record; ``τ`` = first crossing of ``0.632·y_ss`` after ``t0`` (linear interpolation
        between samples) minus ``t0``.  Warns when the record has not settled (the change
        over its last 20 %, from a straight-line fit, exceeds ``SETTLE_WARN`` of ``y_ss``).

    Raises
    ------
    OptionError
        On mismatched arrays or a zero step level.
    IdentificationError
        When the response has no steady state or never reaches 63.2 % of it.

    References
    ----------
    Tsiolakis 2022, §1.1; Masoud 2019, Fig. 1 and eq. 43.
    """
    t, v = response_arrays(time_s, y, "velocity")
    check_step_level(step_volts)
    after = t >= t0
    if not after.all():  # (a record from the step on is used as it is, not copied)
        t, v = t[after], v[after]
    del after
    if t.size < 10:
        raise IdentificationError(f"the classic method needs at least 10 samples after the step, got {t.size}")
    warnings: list[str] = []
    n_tail = max(1, t.size // 10)
    final = float(np.mean(v[-n_tail:]))
    if final == 0.0:
        raise IdentificationError("the velocity has no steady state (mean of the last 10 % is 0)")
    n_settle = max(2, t.size // 5)
    slope = line_slope(t[-n_settle:], v[-n_settle:])  # (np.polyfit's temporaries: 100 MB on a 10 M log)
    drift = abs(slope * (t[-1] - t[-n_settle])) / abs(final)
    if drift > SETTLE_WARN:
        warnings.append(f"velocity has not settled: it changes {100 * drift:.1f}% over the last 20% of the "
                        "record; record longer for a reliable gain")
    t63, i = first_crossing(t, v, _RISE * final)
    if i < 0:
        raise IdentificationError("the velocity never reaches 63.2 % of its final value")
    if i == 0:
        warnings.append("velocity is already above 63.2 % at the step; time constant is unreliable")
    tau = float(t63 - t0)
    if tau <= 0:
        raise IdentificationError("the 63.2 % crossing is at the step edge; cannot estimate a time constant")
    return ClassicResult(dc_gain=final / float(step_volts), time_constant_s=tau, final_value=final,
                         step_volts=float(step_volts), warnings=tuple(warnings))

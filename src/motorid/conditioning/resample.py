"""Sample reduction by an integer ratio (Masoud 2019, section V-3).

The paper keeps every r-th sample (``subsample``), which aliases everything above the new
Nyquist frequency — PWM noise and tacho ripple included — into the band of the motor.  Two
anti-aliased variants: ``block_mean`` (mean of each block of r samples, time-stamped at the
block's centre so no delay is introduced) and ``fir`` (``scipy.signal.decimate`` with a
zero-phase FIR low-pass).  ``bench/reduction.py`` and the tests measure the difference.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.errors import OptionError

__all__ = ["REDUCTION_METHODS", "Reduced", "ratio_for_interval", "sample_reduction"]

#: Names accepted by :func:`sample_reduction`.
REDUCTION_METHODS: tuple[str, ...] = ("subsample", "block_mean", "fir")


@dataclass(frozen=True, slots=True)
class Reduced:
    """A reduced record.

    Attributes
    ----------
    time_s : ndarray
        New sample times.
    values : ndarray
        Reduced samples; the last axis is time.
    ratio : int
        Reduction ratio.
    method : str
        One of :data:`REDUCTION_METHODS`.
    """

    time_s: np.ndarray
    values: np.ndarray
    ratio: int
    method: str


def ratio_for_interval(sample_interval_s: float, target_interval_s: float) -> int:
    """The integer ratio that brings ``sample_interval_s`` nearest to ``target_interval_s``.

    Parameters
    ----------
    sample_interval_s : float
        The recorded sample interval in s.
    target_interval_s : float
        The sample interval wanted after reduction, in s.

    Returns
    -------
    int
        The reduction ratio (at least 1).

    Raises
    ------
    OptionError
        When the target is shorter than the recorded sample interval.
    """
    if not np.isfinite(target_interval_s) or target_interval_s <= 0:
        raise OptionError(f"sample interval must be a positive number of seconds, got {target_interval_s!r}")
    ratio = round(target_interval_s / sample_interval_s)
    if ratio < 1:
        raise OptionError(
            f"sample interval {target_interval_s:g} s is shorter than the recording's "
            f"{sample_interval_s:g} s: choose at least {sample_interval_s:g} s"
        )
    return ratio


def sample_reduction(time_s: np.ndarray, values: np.ndarray, ratio: int, method: str = "subsample") -> Reduced:
    """Reduce a uniformly sampled record by an integer ratio.

    Parameters
    ----------
    time_s : ndarray, shape (n,)
        Sample times.
    values : ndarray, shape (..., n)
        Samples; the last axis is time.
    ratio : int
        Keep one sample in ``ratio``.
    method : str
        ``"subsample"`` (the paper's), ``"block_mean"`` or ``"fir"``.

    Returns
    -------
    Reduced
        The reduced record.

    Raises
    ------
    OptionError
        For a ratio below 1 or an unknown method.

    References
    ----------
    Masoud 2019, section V-3 (sample reduction) and Tables 1–3 (its effect on k and τ).
    """
    t = np.asarray(time_s, dtype=float)
    v = np.asarray(values, dtype=float)
    if int(ratio) != ratio or ratio < 1:
        raise OptionError(f"reduction ratio must be a whole number ≥ 1, got {ratio!r}")
    ratio = int(ratio)
    if method not in REDUCTION_METHODS:
        raise OptionError(f"unknown reduction method {method!r}; use one of {', '.join(REDUCTION_METHODS)}")
    if ratio == 1:
        return Reduced(t.copy(), v.copy(), 1, method)
    if method == "subsample":
        return Reduced(t[::ratio].copy(), v[..., ::ratio].copy(), ratio, method)
    if method == "block_mean":
        m = t.size // ratio
        tb = t[: m * ratio].reshape(m, ratio).mean(axis=1)
        vb = v[..., : m * ratio].reshape(*v.shape[:-1], m, ratio).mean(axis=-1)
        return Reduced(tb, vb, ratio, method)
    # zero-phase FIR: scipy's default is a Hamming-window FIR of order 20·ratio; too long
    # for short records, so fall back to block means there.
    if t.size <= 3 * 20 * ratio + 1:
        red = sample_reduction(t, v, ratio, "block_mean")
        return Reduced(red.time_s, red.values, ratio, method)
    from scipy.signal import decimate  # scipy.signal loads on use (start-up)

    out = decimate(v, ratio, ftype="fir", zero_phase=True, axis=-1)
    return Reduced(t[::ratio][: out.shape[-1]].copy(), out, ratio, method)

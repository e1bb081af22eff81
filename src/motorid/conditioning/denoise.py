"""FFT denoising of the armature current (the method the paper describes as in development).

The current monitor of a PWM H-bridge carries switching noise far above the motor's band
(Masoud 2019, Fig. 18, section V-5).  The record is made periodic by removing the straight
line through its end points (so the FFT sees no jump at the wrap-around), transformed with
``numpy.fft.rfft``, multiplied by a raised-cosine low-pass and transformed back.  The cut-off,
when not given, is chosen from the data: where the low-frequency band of the spectrum first
falls to the noise floor (median power of the upper half of the band).  No library picks that cut-off,
hence this module.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.errors import OptionError

__all__ = ["Denoised", "fft_denoise"]


@dataclass(frozen=True, slots=True)
class Denoised:
    """A denoised record.

    Attributes
    ----------
    values : ndarray
        The filtered signal (same length as the input).
    cutoff_hz : float
        The low-pass cut-off used.
    auto : bool
        Whether the cut-off was chosen from the data.
    """

    values: np.ndarray
    cutoff_hz: float
    auto: bool


def _auto_cutoff(freq: np.ndarray, power: np.ndarray, floor_factor: float) -> float:
    half = power[freq > freq[-1] / 2]
    floor = float(np.median(half)) if half.size else 0.0
    # smooth the periodogram over a few bins before comparing with the floor
    k = max(3, freq.size // 200)
    smooth = np.convolve(power, np.ones(k) / k, mode="same")
    # the motor's band is the contiguous low-frequency part above the floor; PWM tones and
    # their harmonics stand above the floor too, but far out, past a gap: stop at the gap
    below = np.flatnonzero(smooth[1:] <= floor_factor * floor)
    end = int(below[0]) + 1 if below.size else freq.size - 1
    return float(freq[max(end, 4)])


def fft_denoise(
    y: np.ndarray,
    dt: float,
    *,
    cutoff_hz: float | None = None,
    floor_factor: float = 10.0,
) -> Denoised:
    """Low-pass a record in the frequency domain.

    Parameters
    ----------
    y : ndarray
        Uniformly sampled signal.
    dt : float
        Sample interval in seconds.
    cutoff_hz : float, optional
        Cut-off frequency; chosen from the spectrum when omitted.
    floor_factor : float
        For the automatic cut-off: how far above the noise floor counts as signal.

    Returns
    -------
    Denoised
        The filtered record and the cut-off used.

    Raises
    ------
    OptionError
        For a non-positive cut-off.

    References
    ----------
    Masoud 2019, section V-5 and Figs. 31–32 (FFT denoising of the armature current).
    """
    y = np.asarray(y, dtype=float)
    n = y.size
    if cutoff_hz is not None and (not np.isfinite(cutoff_hz) or cutoff_hz <= 0):
        raise OptionError(f"denoise cut-off must be a positive frequency, got {cutoff_hz!r}")
    m = max(1, n // 100)  # end levels from 1% of the record, not one noisy sample
    y0, y1 = float(np.mean(y[:m])), float(np.mean(y[-m:]))
    line = y0 + (y1 - y0) * (np.arange(n) - (m - 1) / 2) / max(n - m, 1)
    spec = np.fft.rfft(y - line)
    freq = np.fft.rfftfreq(n, dt)
    auto = cutoff_hz is None
    fc = _auto_cutoff(freq, np.abs(spec) ** 2, floor_factor) if cutoff_hz is None else float(cutoff_hz)
    # raised-cosine roll-off between fc and 1.5 fc: a brick wall would ring (Gibbs)
    gain = np.clip((1.5 * fc - freq) / (0.5 * fc), 0.0, 1.0)
    gain = 0.5 - 0.5 * np.cos(np.pi * gain)
    out = np.fft.irfft(spec * gain, n) + line
    return Denoised(out, fc, auto)

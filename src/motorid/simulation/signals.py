"""Input signals of the trainer: switch S1 steps and the onboard test-signal generator."""

from __future__ import annotations

import numpy as np
from scipy import signal as sps

from motorid.errors import OptionError

__all__ = ["TEST_SIGNALS", "step_signal", "test_signal"]

#: Onboard generator waveforms (paper §VI-B: about 6.4 V, 0.1 Hz).
TEST_SIGNALS: tuple[str, ...] = ("sine", "triangle", "square")


def step_signal(time_s: np.ndarray, step_time_s: float, level_v: float) -> np.ndarray:
    """Switch S1 thrown to ``level_v`` at ``step_time_s`` (0 V before).

    Parameters
    ----------
    time_s : ndarray
        Sample times.
    step_time_s : float
        Instant the switch closes.
    level_v : float
        Set level.

    Returns
    -------
    ndarray
        The input at each sample (a sample at or after the instant sees the new level).
    """
    t = np.asarray(time_s, dtype=float)
    return np.where(t >= step_time_s, float(level_v), 0.0)


def test_signal(
    time_s: np.ndarray, kind: str, *, amplitude_v: float = 6.4, frequency_hz: float = 0.1, phase_rad: float = 0.0
) -> np.ndarray:
    """The onboard sine, triangle or square wave.

    Parameters
    ----------
    time_s : ndarray
        Sample times.
    kind : str
        ``"sine"``, ``"triangle"`` or ``"square"``.
    amplitude_v : float
        Peak volts (the trainer's generator: about 6.4 V).
    frequency_hz : float
        Frequency (about 0.1 Hz).
    phase_rad : float
        Phase at t = 0.

    Returns
    -------
    ndarray
        The waveform at ``time_s``.

    Raises
    ------
    OptionError
        For an unknown waveform.

    References
    ----------
    Masoud 2019, section VI-B (validation inputs).
    """
    arg = 2 * np.pi * frequency_hz * np.asarray(time_s, dtype=float) + phase_rad
    if kind == "sine":
        return amplitude_v * np.sin(arg)
    if kind == "triangle":
        return amplitude_v * sps.sawtooth(arg + np.pi / 2, width=0.5)
    if kind == "square":
        return amplitude_v * sps.square(arg)
    raise OptionError(f"unknown test signal {kind!r}; use one of {', '.join(TEST_SIGNALS)}")

"""Input signals of the trainer: switch S1 steps and the onboard test-signal generator."""

from __future__ import annotations

import numpy as np
from scipy import signal as sps

from motorid.errors import OptionError

__all__ = ["TEST_SIGNALS", "step_signal", "test_signal"]

#: Onboard generator waveforms (paper §VI-B: about 6.4 V, 0.1 Hz).
TEST_SIGNALS: tuple[str, ...] = ("sine", "triangle", "square")


def step_signal(time_s: np.ndarray, step_time_s: float, level_v: float) -> np.ndarray:
    """Switch S1 thrown to ``level_v`` at ``step_time_s`` (0 before)."""
    t = np.asarray(time_s, dtype=float)
    return np.where(t >= step_time_s, float(level_v), 0.0)


def test_signal(
    time_s: np.ndarray, kind: str, *, amplitude_v: float = 6.4, frequency_hz: float = 0.1, phase_rad: float = 0.0
) -> np.ndarray:
    """The onboard sine, triangle or square wave.

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

"""The oscilloscope: TDS2000-series acquisition of two channels.

2500 points per record over 10 horizontal divisions, 8-bit vertical resolution (25 codes per
division, ±5.12 divisions on screen), CH1 = the input, CH2 = the measured signal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.capture import Capture, ChannelInfo, ScopeInfo

__all__ = ["ScopeSettings", "RECORD_LENGTH", "record_time", "acquire", "quantise"]

#: Points per record of the TDS1000/2000 series.
RECORD_LENGTH = 2500


@dataclass(frozen=True, slots=True)
class ScopeSettings:
    """Front-panel settings.

    Attributes
    ----------
    sec_per_div : float
        Horizontal scale (10 divisions per record).
    ch1_volts_per_div, ch2_volts_per_div : float
        Vertical scales.
    """

    sec_per_div: float = 1.0
    ch1_volts_per_div: float = 2.0
    ch2_volts_per_div: float = 2.0

    @property
    def sample_interval_s(self) -> float:
        """Seconds per sample."""
        return 10.0 * self.sec_per_div / RECORD_LENGTH


def record_time(settings: ScopeSettings, trigger_index: int) -> np.ndarray:
    """The file's time axis: 0 at the trigger point."""
    return (np.arange(RECORD_LENGTH) - trigger_index) * settings.sample_interval_s


def quantise(v: np.ndarray, volts_per_div: float) -> np.ndarray:
    """8-bit conversion: 25 codes per division, clipped to ±5.12 divisions."""
    lsb = volts_per_div / 25.0
    codes = np.clip(np.round(np.asarray(v, dtype=float) / lsb), -128, 127)
    return codes * lsb


def acquire(
    settings: ScopeSettings,
    trigger_index: int,
    ch1_v: np.ndarray,
    ch2_v: np.ndarray,
    *,
    role: str | None,
    source: str,
    quantised: bool = True,
) -> Capture:
    """Digitise the two channels into a :class:`Capture` with TDS2000 metadata."""
    t = record_time(settings, trigger_index)
    c1 = quantise(ch1_v, settings.ch1_volts_per_div) if quantised else np.asarray(ch1_v, float)
    c2 = quantise(ch2_v, settings.ch2_volts_per_div) if quantised else np.asarray(ch2_v, float)
    scope = ScopeInfo(
        model="TDS 2012C", serial="VIRTUAL", firmware="FV:v24.26", record_length=RECORD_LENGTH,
        horizontal_scale_s=settings.sec_per_div, trigger_index=trigger_index,
    )
    return Capture(
        source=source, format="trainer", time_s=t, output_v=c2,
        output_info=ChannelInfo("CH2", "V", settings.ch2_volts_per_div, 0.0, 1.0, 0.0),
        input_v=c1, input_info=ChannelInfo("CH1", "V", settings.ch1_volts_per_div, 0.0, 1.0, 0.0),
        scope=scope, role_hint=None,
    )

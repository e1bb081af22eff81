"""The oscilloscope: TDS2000-series acquisition of two channels.

2500 points per record over 10 horizontal divisions, 8-bit vertical resolution (25 codes per
division, ±5.12 divisions on screen), CH1 = the input, CH2 = the measured signal.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.capture import Capture, ChannelInfo, ScopeInfo
from motorid.errors import OptionError

__all__ = ["RECORD_LENGTH", "ScopeSettings", "acquire", "draw_trigger_index", "quantise", "record_time"]

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
        Vertical scales (CH1 = the input, CH2 = the measured signal).
    pretrigger_range : (float, float)
        Fraction of the record before the trigger point: each acquisition draws its own
        value in this range (the operator's horizontal position differs between captures).

    Raises
    ------
    OptionError
        For non-positive scales or a pre-trigger range outside [0, 1).
    """

    sec_per_div: float = 1.0
    ch1_volts_per_div: float = 2.0
    ch2_volts_per_div: float = 2.0
    pretrigger_range: tuple[float, float] = (0.08, 0.20)

    def __post_init__(self) -> None:
        if not (self.sec_per_div > 0 and self.ch1_volts_per_div > 0 and self.ch2_volts_per_div > 0):
            raise OptionError("scope settings: sec/div and volts/div must be > 0")
        lo, hi = self.pretrigger_range
        if not 0.0 <= lo <= hi < 1.0:
            raise OptionError(
                f"scope settings: pretrigger_range needs 0 <= lo <= hi < 1, got {self.pretrigger_range!r}"
            )

    @property
    def sample_interval_s(self) -> float:
        """Seconds per sample."""
        return 10.0 * self.sec_per_div / RECORD_LENGTH


def draw_trigger_index(settings: ScopeSettings, rng: np.random.Generator) -> int:
    """A random trigger point within the settings' pre-trigger range.

    Parameters
    ----------
    settings : ScopeSettings
        Gives the pre-trigger fraction range.
    rng : numpy.random.Generator
        Source of randomness.

    Returns
    -------
    int
        0-based sample index of t = 0.
    """
    lo, hi = settings.pretrigger_range
    return int(rng.integers(int(lo * RECORD_LENGTH), int(hi * RECORD_LENGTH) + 1))


def record_time(settings: ScopeSettings, trigger_index: int) -> np.ndarray:
    """The file's time axis: 0 at the trigger point, negative before it.

    Parameters
    ----------
    settings : ScopeSettings
        Gives the sample interval ``10·sec_per_div / 2500``.
    trigger_index : int
        Sample index of t = 0.

    Returns
    -------
    ndarray, shape (2500,)
        Sample times in seconds.
    """
    return (np.arange(RECORD_LENGTH) - trigger_index) * settings.sample_interval_s


def quantise(v: np.ndarray, volts_per_div: float) -> np.ndarray:
    """8-bit conversion: 25 codes per division, clipped to the screen (codes −128…127).

    Parameters
    ----------
    v : ndarray
        Analog volts.
    volts_per_div : float
        Vertical scale; the LSB is ``volts_per_div / 25``.

    Returns
    -------
    ndarray
        Volts on the 8-bit grid, clipped at −5.12/+5.08 divisions.
    """
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
    """Digitise the two channels into a :class:`Capture` with TDS2000 metadata.

    Parameters
    ----------
    settings : ScopeSettings
        Horizontal and vertical scales.
    trigger_index : int
        Sample index of t = 0.
    ch1_v, ch2_v : ndarray, shape (2500,)
        Analog input and measured signal at the sample instants.
    role : str or None
        What CH2 measures.  Not stored: a real scope file does not know it, so the
        capture's ``role_hint`` stays ``None`` and role guessing is exercised.
    source : str
        Label such as ``"<trainer:velocity>"``.
    quantised : bool
        Apply the 8-bit conversion (``False``: keep the analog values).

    Returns
    -------
    Capture
        ``format="trainer"``, model ``TDS 2012C``, record length 2500, probe 1×.
    """
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

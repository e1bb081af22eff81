"""The waveform preamble of a TDS1000/TDS2000/TBS1000: the numbers that turn codes into volts and seconds.

Each field is asked for by its own keyword (``WFMPre:YMUlt?``, ``WFMPre:XINcr?`` …) rather
than read by position from one ``WFMPre?`` answer: older and newer firmware list the fields
of ``WFMPre?`` in different orders (TDS2000 programmer manual, 071-1075, ``WFMPre?``).
An answer may echo its keyword when the scope's ``HEADer`` is still on
(``:WFMPRE:YMULT 8.0E-2``); the keyword is then checked and dropped.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from motorid.errors import InstrumentError

__all__ = ["PREAMBLE_FIELDS", "Preamble", "parse_field", "query_preamble"]

#: Preamble fields: attribute name → the query keyword (short form in capitals).
PREAMBLE_FIELDS: dict[str, str] = {
    "ymult": "YMUlt",
    "yzero": "YZEro",
    "yoff": "YOFf",
    "xincr": "XINcr",
    "xzero": "XZEro",
    "pt_off": "PT_Off",
    "n_points": "NR_Pt",
}


@dataclass(frozen=True, slots=True)
class Preamble:
    """The scaling of one channel's record (programmer manual, ``WFMPre``).

    Attributes
    ----------
    ymult : float
        Volts per code (``YMUlt``), probe attenuation included.
    yzero : float
        Volts added after scaling (``YZEro``).
    yoff : float
        Code of the waveform's zero (``YOFf``), in codes.
    xincr : float
        Seconds per point (``XINcr``).
    xzero : float
        Time of the point ``pt_off`` (``XZEro``), seconds.
    pt_off : float
        Point index (0-based, from ``DATa:STARt``) at which the time is ``xzero`` (``PT_Off``).
    n_points : int
        Points in the record the scope will send (``NR_Pt``).
    """

    ymult: float
    yzero: float
    yoff: float
    xincr: float
    xzero: float
    pt_off: float
    n_points: int

    def volts(self, codes: np.ndarray) -> np.ndarray:
        """Volts of the codes: ``V = (code − YOFF)·YMULT + YZERO``.

        Parameters
        ----------
        codes : ndarray
            Digitiser codes as sent by ``CURVe?``.

        Returns
        -------
        ndarray
            Volts (probe attenuation included).
        """
        return (np.asarray(codes, dtype=float) - self.yoff) * self.ymult + self.yzero

    def times(self, n: int) -> np.ndarray:
        """Time of each of ``n`` points: ``t = XZERO + XINCR·(i − PT_OFF)``, i = 0 … n−1.

        Parameters
        ----------
        n : int
            Number of points.

        Returns
        -------
        ndarray
            Seconds relative to the trigger.
        """
        return self.xzero + self.xincr * (np.arange(n) - self.pt_off)

    @property
    def screen_centre_v(self) -> float:
        """Volts at code 0, the middle of the screen."""
        return -self.yoff * self.ymult + self.yzero


_NUMBER = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$")


def _short(keyword: str) -> str:
    """The short form of a SCPI keyword: its capital letters (``YMUlt`` → ``YMU``)."""
    return "".join(c for c in keyword if c.isupper() or c == "_" or c.isdigit())


def parse_field(answer: str, query: str) -> float:
    """The number in the answer to a query, with or without the echoed keyword.

    Parameters
    ----------
    answer : str
        What the scope answered, e.g. ``"8.0E-2"`` or ``":WFMPRE:YMULT 8.0E-2"``.
    query : str
        The query sent (``"WFMPre:YMUlt?"``); its last keyword is checked against an echoed one.

    Returns
    -------
    float
        The value.

    Raises
    ------
    InstrumentError
        The answer is not a number, or it names another field.
    """
    keyword = query.rstrip("?").split(":")[-1]
    text = answer.strip().rstrip(";")
    head, _, value = text.rpartition(" ")
    if head:
        # HEADer ON: ":WFMPRE:YMULT 8.0E-2" or "YMU 8.0E-2" (long or short form)
        said = head.split(":")[-1].upper()
        short = _short(keyword)
        if not (said.startswith(short) and keyword.upper().startswith(said)):
            raise InstrumentError(f"WFMPre:{keyword}? was answered with {said!r}: the scope is busy with "
                                  "another query; switch it off and on, and acquire again")
    value = value.strip().strip('"')
    if not _NUMBER.match(value):
        raise InstrumentError(f"{query} answered {text[:40]!r}, not a number: is the channel displayed? "
                              "Check the scope's screen and acquire again")
    number = float(value)
    if not math.isfinite(number):
        raise InstrumentError(f"{query} answered {text[:40]!r}, not a finite number: acquire again")
    return number


def query_preamble(query: Callable[[str], str]) -> Preamble:
    """Ask the scope for each preamble field by keyword.

    Parameters
    ----------
    query : callable
        Sends a query and returns the answer (a pyvisa resource's ``query``).

    Returns
    -------
    Preamble
        The channel selected by ``DATa:SOUrce``.

    Raises
    ------
    InstrumentError
        An answer is not a number, or the scaling is impossible (``YMUlt`` or ``XINcr`` ≤ 0).
    """
    values = {name: parse_field(query(f"WFMPre:{kw}?"), f"WFMPre:{kw}?") for name, kw in PREAMBLE_FIELDS.items()}
    if not values["ymult"] > 0 or not values["xincr"] > 0:
        raise InstrumentError(f"the preamble gives YMUlt {values['ymult']:g} and XINcr {values['xincr']:g}; both "
                              "must be > 0: acquire again (if it persists, reset the scope with Default Setup)")
    n = values["n_points"]
    if n == 0:
        raise InstrumentError("the scope holds no record of this channel yet: press RUN/STOP or SINGLE on the "
                              "scope (or use --single) and acquire again")
    if n != int(n) or n < 0:
        raise InstrumentError(f"the preamble gives NR_Pt {n:g}, not a point count: acquire again")
    fields = {k: v for k, v in values.items() if k != "n_points"}
    return Preamble(**fields, n_points=int(n))

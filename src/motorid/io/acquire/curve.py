"""The samples of one channel as ``CURVe?`` sends them, and the check for a clipped trace.

``CURVe?`` sends an IEEE 488.2 block of signed bytes (``DATa:ENCdg RIBinary``, ``DATa:WIDth 1``)
or comma-separated numbers (``DATa:ENCdg ASCii``).
"""

from __future__ import annotations

import math

import numpy as np

from motorid.errors import InstrumentError

__all__ = [
    "CODES_PER_DIV",
    "CODE_MAX",
    "CODE_MIN",
    "clipping_warning",
    "decode_ascii_curve",
    "decode_binary_curve",
    "volts_per_div_that_fits",
]

#: The 8-bit digitiser's range (signed codes, ``DATa:WIDth 1``).
CODE_MIN, CODE_MAX = -128, 127
#: Codes per vertical division of the TDS1000/2000/TBS1000 (200 codes over 8 divisions).
CODES_PER_DIV = 25
#: The scopes' volts/div settings at the probe tip of a 1× probe (1-2-5 sequence).
_STEPS = (1.0, 2.0, 5.0)


def decode_binary_curve(block: bytes, *, n_points: int | None = None) -> np.ndarray:
    """Codes from an IEEE 488.2 definite-length block of signed bytes (``#42500…``).

    Parameters
    ----------
    block : bytes
        The answer to ``CURVe?`` with ``DATa:ENCdg RIBinary`` and ``DATa:WIDth 1``
        (a trailing line feed is allowed).
    n_points : int, optional
        The count the preamble announced (``NR_Pt``); checked when given.

    Returns
    -------
    ndarray of int
        One code per point, −128 … 127.

    Raises
    ------
    InstrumentError
        Not a block, a block shorter than its header says, or another count than ``n_points``.
    """
    from pyvisa.util import from_ieee_block

    try:
        # pyvisa parses the '#<digits><length>' header; RIBinary is signed, most significant byte first
        codes = from_ieee_block(bytes(block), datatype="b", is_big_endian=True,
                                container=np.array)  # type: ignore[arg-type]  # pyvisa types container too narrowly
    except ValueError:
        start = bytes(block[:12])
        raise InstrumentError(f"CURVe? did not send a whole binary block (it begins {start!r}); acquire again, "
                              "or use --encoding ascii") from None
    return _checked(np.asarray(codes, dtype=np.int16), n_points)


def decode_ascii_curve(text: str, *, n_points: int | None = None) -> np.ndarray:
    """Codes from ``CURVe?`` with ``DATa:ENCdg ASCii``: ``"12,13,-5,…"`` (a ``CURVE`` header allowed).

    Parameters
    ----------
    text : str
        The answer.
    n_points : int, optional
        The count the preamble announced (``NR_Pt``); checked when given.

    Returns
    -------
    ndarray of int
        One code per point, −128 … 127.

    Raises
    ------
    InstrumentError
        Empty, a field that is not a whole number, a code outside −128 … 127, or another
        count than ``n_points``.
    """
    body = text.strip()
    if body[:1].isalpha() or body.startswith(":"):
        body = body.split(" ", 1)[1] if " " in body else ""  # HEADer ON: "CURVE 12,13,…"
    fields = [f.strip() for f in body.split(",")] if body else []
    try:
        codes = np.array([int(f) for f in fields], dtype=np.int16)
    except (ValueError, OverflowError):
        bad = next(f for f in fields if not f.lstrip("+-").isdigit())
        raise InstrumentError(f"CURVe? sent {bad[:20]!r} among its numbers: the transfer was garbled; "
                              "acquire again") from None
    if codes.size and (codes.min() < CODE_MIN or codes.max() > CODE_MAX):
        raise InstrumentError(f"CURVe? sent codes outside {CODE_MIN}…{CODE_MAX}: set DATa:WIDth 1 "
                              "(motorid sets it; another program may have changed it) and acquire again")
    return _checked(codes, n_points)


def _checked(codes: np.ndarray, n_points: int | None) -> np.ndarray:
    if codes.size == 0:
        raise InstrumentError("CURVe? sent no points: the channel has no record yet; press Single or Run "
                              "on the scope (or use --single) and acquire again")
    if n_points is not None and codes.size != n_points:
        raise InstrumentError(f"CURVe? sent {codes.size} points but the preamble announced {n_points}: the "
                              "transfer was cut short; acquire again (or use --encoding ascii)")
    return codes


def volts_per_div_that_fits(excursion_v: float, probe_atten: float = 1.0) -> float:
    """The smallest 1-2-5 volts/div that puts ``excursion_v`` within 4 divisions of the centre.

    Half the digitiser range is 5.1 divisions: this leaves a division to spare.

    Parameters
    ----------
    excursion_v : float
        The largest distance of the trace from the screen centre, volts.
    probe_atten : float
        Probe attenuation (the scales are those of a 1× probe times it).

    Returns
    -------
    float
        Volts per division.
    """
    # motorid.conditioning.checks.fitting_volts_per_div advises on files already read; it sits
    # above io in the layers, so the acquisition (io) has this rule of its own
    need = abs(excursion_v) / 4.0
    if not need > 0 or not math.isfinite(need):
        return _STEPS[0] * probe_atten
    decade = 10.0 ** math.floor(math.log10(need / probe_atten))
    for k in range(3):
        for step in _STEPS:
            s = step * decade * 10**k * probe_atten
            if s >= need * (1 - 1e-9):
                return s
    return _STEPS[-1] * decade * 100 * probe_atten  # pragma: no cover (need lies in this decade)


def clipping_warning(codes: np.ndarray, channel: str, volts_per_div: float, screen_centre_v: float,
                     probe_atten: float = 1.0) -> str | None:
    """A warning when a trace reached the digitiser's rails: it left the screen there.

    Parameters
    ----------
    codes : ndarray
        The channel's codes.
    channel : str
        ``"CH2"``.
    volts_per_div : float
        The channel's scale (``CH<n>:SCAle?``).
    screen_centre_v : float
        Volts at the middle of the screen (code 0).
    probe_atten : float
        Probe attenuation (for the advised scale).

    Returns
    -------
    str or None
        ``"CH2: 312 of 2500 samples (12.5 %) at the top of the 8-bit range …: set CH2 to 5 V/div …"``.
    """
    top = int(np.count_nonzero(codes >= CODE_MAX))
    bottom = int(np.count_nonzero(codes <= CODE_MIN))
    if top == 0 and bottom == 0:
        return None
    lsb = volts_per_div / CODES_PER_DIV
    where = []
    if top:
        where.append(f"above {screen_centre_v + CODE_MAX * lsb:.4g} V")
    if bottom:
        where.append(f"below {screen_centre_v + CODE_MIN * lsb:.4g} V")
    # the true excursion is at least the rail's: advise the scale that fits that with a spare division
    excursion = max(CODE_MAX * lsb if top else 0.0, -CODE_MIN * lsb if bottom else 0.0)
    fits = volts_per_div_that_fits(excursion, probe_atten)
    n = codes.size
    return (f"{channel}: {top + bottom} of {n} samples ({100 * (top + bottom) / n:.1f} %) at the limits of "
            f"the 8-bit range: the trace left the screen ({' and '.join(where)} at {volts_per_div:g} V/div); "
            f"set {channel} to {fits:g} V/div or more (or move it back with the vertical position knob) "
            "and acquire again")

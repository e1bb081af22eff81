"""Numbers as a student reads them: four significant figures, ``-2.800 ± 1.150j``, names in words.

One source for the terminal (:mod:`motorid.cli`) and the text summary
(:mod:`motorid.report.summary`); the JSON files keep full precision and never pass through here.
Python's ``format`` gives significant figures (``.4g``) but switches to exponents at 10⁴, keeps
``-0`` and has no notion of a conjugate pair: the few lines below add exactly that.
No imports beyond the standard library, so the command line can use it before numpy loads.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

__all__ = ["DIGITS", "METRIC_NAMES", "REAL_TOL", "complex_text", "metric_name", "roots_text", "sig"]

#: Significant figures printed by default.
DIGITS = 4

#: Metric and fit keys (JSON names) in words, for the terminal and the report.
METRIC_NAMES: dict[str, str] = {
    "rise_time_s": "rise time (10–90 %)",
    "settling_time_s": "settling time (2 %)",
    "settling_time_2pct": "settling time (2 %)",
    "overshoot_pct": "overshoot",
    "steady_state_error_v": "steady-state error",
    "tracking_rms_v": "tracking error (RMS)",
    "peak_control_v": "peak |u|",
    "velocity_nrmse": "velocity NRMSE",
    "position_nrmse": "position NRMSE",
    "current_nrmse": "current NRMSE",
    "velocity_fit_percent": "velocity fit",
    "position_fit_percent": "position fit",
    "current_fit_percent": "current fit",
    "dc_gain": "dc gain",
    "time_constant": "time constant (s)",
    "markov_order": "poles (Markov)",
    "oe_order": "poles (output-error)",
    "order": "order",
    "method": "method",
    "agree": "agree",
}


def metric_name(key: str) -> str:
    """The words for a metric or fit key (``settling_time_s`` → ``settling time (2 %)``).

    Parameters
    ----------
    key : str
        The JSON key.

    Returns
    -------
    str
        The key in words; an unknown key with its underscores as spaces.
    """
    return METRIC_NAMES.get(key, key.replace("_", " "))


def _decimals(x: float, digits: int) -> int:
    """Decimal places that give ``x`` ``digits`` significant figures (negative: round to tens…)."""
    return digits - 1 - math.floor(math.log10(abs(x)))


def sig(x: float, digits: int = DIGITS) -> str:
    """``x`` to ``digits`` significant figures, in plain notation from 1e-4 up to 1e6.

    Trailing zeros are dropped (``5.92``, not ``5.920``), a rounded zero has no sign (``0``, not
    ``-0``), and very small or large magnitudes use an exponent (``1.235e-07``).

    Parameters
    ----------
    x : float
        The number.
    digits : int
        Significant figures.

    Returns
    -------
    str
        The number as text; ``nan``, ``inf`` and ``-inf`` as Python writes them.
    """
    x = float(x)
    if not math.isfinite(x):
        return str(x)
    if x == 0.0:
        return "0"
    if not 1e-4 <= abs(x) < 1e6:
        text = f"{x:.{digits - 1}e}"
        mant, exp = text.split("e")
        if "." in mant:
            mant = mant.rstrip("0").rstrip(".")
        return f"{mant}e{exp}"
    places = _decimals(x, digits)
    rounded = round(x, places)
    if rounded == 0.0:
        return "0"
    if rounded != 0.0 and _decimals(rounded, digits) < places:  # 9.9996 -> 10.00: one place fewer
        places -= 1
    text = f"{rounded:.{max(places, 0)}f}"
    if "." in text:
        text = text.rstrip("0").rstrip(".")
    return "0" if text in ("-0", "0") else text


#: An imaginary part below this fraction of ``max(1, |z|)`` is rounding (a double real pole
#: comes out of an eigenvalue solver as ``p ± 1e-8j``): the number is printed as real.
REAL_TOL = 1e-6


def _is_real(z: complex) -> bool:
    return abs(z.imag) <= REAL_TOL * max(1.0, abs(z))


def _fixed(x: float, places: int) -> str:
    text = f"{x:.{max(places, 0)}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def _shared_places(z: complex, digits: int) -> int:
    big = max(abs(z.real), abs(z.imag))
    return _decimals(big, digits) if big > 0 else 0


#: How a repeated root is marked (more than three times: ``(×4)``).
_MULTIPLICITY = {1: "", 2: " (double)", 3: " (triple)"}


def _rounds_to_real(z: complex, digits: int) -> bool:
    """The imaginary part is zero at the decimal places ``z`` is printed with."""
    places = _shared_places(z, digits)
    return places >= 0 and abs(z) < 1e6 and float(_fixed(abs(z.imag), places)) == 0.0


def complex_text(z: complex, digits: int = DIGITS, *, pair: bool = False) -> str:
    """A complex number as ``-2.800 + 1.150j``; a real one (``|imag|`` negligible) without ``+0j``.

    Both parts are written with the same decimal places, set by ``digits`` significant figures
    of the larger part.

    Parameters
    ----------
    z : complex
        The number.
    digits : int
        Significant figures of the larger part.
    pair : bool
        Write the conjugate pair ``z, z̄`` as ``-2.800 ± 1.150j``.

    Returns
    -------
    str
        The number as text.
    """
    z = complex(z)
    if not (math.isfinite(z.real) and math.isfinite(z.imag)):
        return str(z)
    if _is_real(z):
        return sig(z.real, digits)
    places = _shared_places(z, digits)
    if places < 0 or abs(z) >= 1e6 or abs(z) < 1e-4:  # exponents: each part on its own
        re_, im_ = sig(z.real, digits), sig(abs(z.imag), digits)
    else:
        re_, im_ = _fixed(z.real, places), _fixed(abs(z.imag), places)
        if float(re_) == 0.0 and z.real != 0.0:  # a tiny real part keeps its sign: stability reads from it
            re_ = sig(z.real, digits)
    sign = "±" if pair else ("+" if z.imag > 0 else "−")
    return f"{re_} {sign} {im_}j"


def roots_text(values: Iterable[complex], digits: int = DIGITS) -> str:
    """Poles or zeros as text, a conjugate pair once as ``-2.800 ± 1.150j``.

    Parameters
    ----------
    values : iterable of complex
        The roots, in the order to print them (pairs need not be adjacent).
    digits : int
        Significant figures.

    Returns
    -------
    str
        Comma-separated roots.
    """
    left = [complex(v) for v in values]
    parts: list[str] = []
    while left:
        z = left.pop(0)
        if _is_real(z) or _rounds_to_real(z, digits):
            # a repeated real root (a double pole, split by the eigenvalue solver into two reals
            # or a pair with a vanishing imaginary part) is printed once, with its multiplicity
            text = sig(z.real, digits)
            same = [i for i, w in enumerate(left) if (_is_real(w) or _rounds_to_real(w, digits))
                    and sig(w.real, digits) == text]
            for i in reversed(same):
                left.pop(i)
            parts.append(text + _MULTIPLICITY.get(1 + len(same), f" (×{1 + len(same)})"))
            continue
        # its conjugate, if present: the closest root to z̄ within a relative tolerance
        match = min(range(len(left)), key=lambda i: abs(left[i] - z.conjugate()), default=None)
        if match is not None and abs(left[match] - z.conjugate()) <= 1e-6 * max(1.0, abs(z)):
            left.pop(match)
            parts.append(complex_text(complex(z.real, abs(z.imag)), digits, pair=True))
        else:
            parts.append(complex_text(z, digits))
    return ", ".join(parts)

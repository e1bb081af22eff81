"""Polynomials and transfer functions written the way the paper prints them."""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["poly_text"]


def poly_text(coeffs: Any) -> str:
    """A polynomial in s, highest power first: ``2.175s - 0.0079``, ``s^2 + 2.31s + 0.024``.

    Parameters
    ----------
    coeffs : array_like
        Coefficients, highest power first.

    Returns
    -------
    str
        The polynomial as text.
    """
    c = [float(x) for x in np.atleast_1d(coeffs)]
    n = len(c) - 1
    parts = []
    for i, a in enumerate(c):
        p = n - i
        if a == 0 and len(c) > 1:
            continue
        mag = f"{abs(a):.4g}"
        term = mag if p == 0 else ("" if mag == "1" else mag) + ("s" if p == 1 else f"s^{p}")
        parts.append(("-" if a < 0 else "+") + " " + term)
    text = " ".join(parts) or "0"
    return text[2:] if text.startswith("+ ") else "-" + text[2:]

"""What every identification method shares: its error type and small numeric helpers."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.errors import IdentificationError

__all__ = ["IdentificationError", "ParameterEstimate", "equilibrated_condition"]


@dataclass(frozen=True, slots=True)
class ParameterEstimate:
    """One identified quantity with its uncertainty (as lmfit's ``Parameter``).

    Attributes
    ----------
    value : float or complex
        The estimate (a complex pole or zero is a complex number).
    stderr : float
        Standard error (NaN when the method gives no interval).
    ci95 : tuple of (float, float) or None
        95 % interval (``None`` when the method gives none); for a complex pole or zero,
        the interval of its real part.
    unit : str
        The unit of ``value``, ``stderr`` and ``ci95`` (``rpm/V``, ``V/V``, ``s``, ``1/s``; empty
        when not set).
    """

    value: float | complex
    stderr: float = float("nan")
    ci95: tuple[float, float] | None = None
    unit: str = ""





# IdentificationError lives in motorid.errors with every other user-facing error


def equilibrated_condition(regressor: np.ndarray) -> float:
    """Condition number of a regressor after scaling its columns to unit 2-norm.

    Parameters
    ----------
    regressor : ndarray, shape (N, p)
        The least-squares matrix (one row per equation).

    Returns
    -------
    float
        2-norm condition number of the column-equilibrated matrix; ``inf`` when a column
        is zero or the matrix is rank deficient.

    Notes
    -----
    Raw condition numbers depend on the units of each column (position volts vs. input
    volts, seconds vs. milliseconds); equilibrating first makes the number a property of
    the data, not of the units, so the same warning threshold works everywhere.
    """
    q = np.asarray(regressor, dtype=float)
    norms = np.linalg.norm(q, axis=0)
    if q.size == 0 or np.any(norms == 0.0) or not np.all(np.isfinite(q)):
        return float("inf")
    sv = np.linalg.svd(q / norms, compute_uv=False)
    if sv[-1] <= sv[0] * np.finfo(float).eps:
        return float("inf")
    return float(sv[0] / sv[-1])

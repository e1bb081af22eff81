"""What every identification method shares: its error type and small numeric helpers."""

from __future__ import annotations

import numpy as np

from motorid.errors import IdentificationError
from motorid.model.uncertainty import ParameterEstimate  # typed with the model: its JSON is the model's

__all__ = ["STOPPED_EARLY", "IdentificationError", "ParameterEstimate", "equilibrated_condition"]

#: The start of a fit's warning when its solver stopped before converging (its evaluation limit);
#: the sanity gate turns it into a failed check.
STOPPED_EARLY = "output-error fit stopped early"


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

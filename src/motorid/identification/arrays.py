"""The checks every estimator makes on the arrays and the step level it is given from Python."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from motorid.errors import OptionError

__all__ = ["check_step_level", "response_arrays"]


def response_arrays(time_s: Any, y: Any, what: str = "response") -> tuple[np.ndarray, np.ndarray]:
    """Time and response as flat float arrays of the same length.

    Parameters
    ----------
    time_s, y : array_like
        Sample times and the response at them.
    what : str
        What ``y`` is, for the message ("response", "velocity").

    Returns
    -------
    (ndarray, ndarray)
        ``time_s`` and ``y``, raveled.

    Raises
    ------
    OptionError
        When their lengths differ.
    """
    t = np.asarray(time_s, dtype=float).ravel()
    v = np.asarray(y, dtype=float).ravel()
    if t.size != v.size:
        raise OptionError(f"time and {what} arrays differ in length ({t.size} vs {v.size})")
    return t, v


def check_step_level(step_volts: Any) -> None:
    """Refuse a step level that is zero or not a finite number.

    Parameters
    ----------
    step_volts : float
        The step's level in volts.

    Raises
    ------
    OptionError
        A zero, NaN or infinite level.
    """
    if not step_volts or not math.isfinite(step_volts):
        raise OptionError(f"the step level must be a non-zero number of volts, got {step_volts!r}")

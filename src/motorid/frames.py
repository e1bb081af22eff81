"""Time series as a pandas DataFrame, for notebooks (pandas is optional: ``pip install pandas``).

One helper for every result that holds time series (a closed-loop run, a validation): the
columns by name, time as the index and each column's unit in ``DataFrame.attrs["units"]``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from motorid.errors import MotorIdError

__all__ = ["to_dataframe"]


def to_dataframe(columns: Mapping[str, np.ndarray], units: Mapping[str, str], *, index: str = "time") -> Any:
    """A DataFrame of equally long columns, indexed by ``index`` (seconds).

    Parameters
    ----------
    columns : Mapping[str, ndarray]
        The series by name, ``index`` among them.
    units : Mapping[str, str]
        Each column's unit (``V``, ``rpm``, ``s``); kept in ``attrs["units"]``.
    index : str
        The column that becomes the index.

    Returns
    -------
    pandas.DataFrame

    Raises
    ------
    MotorIdError
        When pandas is not installed (it is an optional dependency).
    """
    try:
        import pandas as pd
    except ImportError:
        raise MotorIdError("to_dataframe needs pandas, an optional dependency: pip install pandas") from None
    data = {name: np.asarray(values) for name, values in columns.items() if name != index}
    frame = pd.DataFrame(data, index=pd.Index(np.asarray(columns[index], dtype=float), name=f"{index}_s"))
    frame.attrs["units"] = {name: units.get(name, "") for name in data}
    return frame

"""Pickling of frozen dataclasses whose mappings are read-only views.

The result types keep their mappings as :class:`types.MappingProxyType` so that nobody edits a
model in place; :mod:`pickle` cannot copy such a view, and the slotted dataclass's own
``__getstate__`` hands it the views.  These two functions are the classes' ``__getstate__`` and
``__setstate__``: the views travel as plain dicts and are read-only again on arrival, so a model
or a result crosses a process boundary (the web page's bounded workers, ``multiprocessing``,
``joblib``) and ``copy.deepcopy`` works.  ``copyreg`` could teach pickle the views once for the
whole interpreter, but that is a global change to other people's pickling.
"""

from __future__ import annotations

import dataclasses
from types import MappingProxyType
from typing import Any

__all__ = ["frozen_getstate", "frozen_setstate"]


def frozen_getstate(obj: Any) -> list[Any]:
    """The field values in order, read-only mappings as ``("mappingproxy", dict)``.

    Parameters
    ----------
    obj : dataclass instance
        A frozen, slotted dataclass (the method's ``self``).

    Returns
    -------
    list
        One entry per field.
    """
    out: list[Any] = []
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        out.append(("mappingproxy", dict(value)) if isinstance(value, MappingProxyType) else ("value", value))
    return out


def frozen_setstate(obj: Any, state: list[Any]) -> None:
    """Set the fields from :func:`frozen_getstate`'s list (the views made read-only again).

    Parameters
    ----------
    obj : dataclass instance
        The instance being unpickled (the method's ``self``).
    state : list
        What :func:`frozen_getstate` returned.
    """
    for f, (kind, value) in zip(dataclasses.fields(obj), state, strict=True):
        object.__setattr__(obj, f.name, MappingProxyType(value) if kind == "mappingproxy" else value)

"""JSON Schemas of the documents motorid writes, shipped with the package.

``docs/formats.md`` explains every key; these files say the same for a validator (draft
2020-12).  Documents may carry keys the schemas do not name: keys are only ever added.

=====================  ==========================================================
schema name            the document
=====================  ==========================================================
``model``              ``motorid identify --json`` (``motorid.model/1``)
``design``             ``motorid design --json`` (``motorid.design/1``)
``inspect``            ``motorid inspect --json`` (a list, one object per capture)
``modes``              ``motorid modes --json`` (``motorid.modes/1``)
``simulation``         ``motorid simulate --json`` (``motorid.simulation/1``)
``batch-summary``      one row of ``motorid batch``'s ``summary.csv``
``advice``             ``motorid advise --json`` (``motorid.advice/1``)
=====================  ==========================================================
"""

from __future__ import annotations

import json
from importlib import resources
from typing import Any

__all__ = ["SCHEMA_NAMES", "schema"]

#: The documents with a schema file ``<name>.schema.json`` in this package.
SCHEMA_NAMES: tuple[str, ...] = ("model", "design", "inspect", "modes", "simulation", "batch-summary", "advice")


def schema(name: str) -> dict[str, Any]:
    """The JSON Schema of one of motorid's documents.

    Parameters
    ----------
    name : str
        One of :data:`SCHEMA_NAMES`.

    Returns
    -------
    dict
        The schema (draft 2020-12).

    Raises
    ------
    ValueError
        ``name`` is not one of :data:`SCHEMA_NAMES`.
    """
    if name not in SCHEMA_NAMES:
        raise ValueError(f"no schema named {name!r}; the schemas are {', '.join(SCHEMA_NAMES)}")
    text = resources.files(__name__).joinpath(f"{name}.schema.json").read_text(encoding="utf-8")
    result: dict[str, Any] = json.loads(text)
    return result

"""Reading a design JSON (``motorid.design/1``) back.

As the typed :class:`Design` for ``simulate`` and as a plain dict for the report.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Any

from motorid.errors import CaptureFormatError
from motorid.io.jsonfile import read_json

if TYPE_CHECKING:
    from motorid.control.design import Design
    from motorid.control.pid import PidDesign

__all__ = ["controller_from_json", "load_controller", "load_design", "read_design_json"]


def read_design_json(path: Path) -> dict[str, Any]:
    """A design JSON (``motorid.design/1``) as a dict, checked for its schema.

    Parameters
    ----------
    path : Path
        The design JSON file.

    Returns
    -------
    dict
        The decoded object.

    Raises
    ------
    CaptureFormatError
        When the file is not JSON or not a design.
    """
    try:
        doc = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise CaptureFormatError(f"not a readable design JSON ({exc})", file=str(path)) from None
    if not isinstance(doc, dict) or doc.get("schema") != "motorid.design/1":
        raise CaptureFormatError("not a motorid design (schema motorid.design/1 expected)", file=str(path))
    return doc


def load_design(path: Path) -> Design:
    """Read a design JSON file as a :class:`~motorid.control.design.Design`.

    Parameters
    ----------
    path : Path
        The design JSON file.

    Returns
    -------
    Design

    Raises
    ------
    ModelFormatError, OptionError
        One-line errors naming the file.
    """
    from motorid.control.design import Design

    return Design.from_json(read_json(path, "design"), file=str(path))


def controller_from_json(data: Any, *, file: str | None = None) -> Design | PidDesign:
    """The controller of a design JSON: a :class:`~motorid.control.pid.PidDesign` when it has a ``pid`` object.

    Parameters
    ----------
    data : Any
        The decoded design JSON.
    file : str, optional
        Named in errors.

    Returns
    -------
    Design or PidDesign

    Raises
    ------
    OptionError
        One-line errors naming the key (and ``file``).
    """
    from motorid.control.design import Design
    from motorid.control.pid import PidDesign

    if isinstance(data, dict) and "pid" in data:
        return PidDesign.from_json(data, file=file)
    return Design.from_json(data, file=file)


def load_controller(path: Path) -> Design | PidDesign:
    """Read a design JSON file as the controller it holds (state feedback or a PID).

    Parameters
    ----------
    path : Path
        The design JSON file.

    Returns
    -------
    Design or PidDesign

    Raises
    ------
    ModelFormatError, OptionError
        One-line errors naming the file.
    """
    return controller_from_json(read_json(path, "design"), file=str(path))

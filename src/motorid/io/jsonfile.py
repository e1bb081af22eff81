"""Reading a JSON file a user names (a model, a design), with one-line errors naming it."""

from __future__ import annotations

import json
from pathlib import Path

from motorid.errors import ModelFormatError, OptionError

__all__ = ["read_json"]


def read_json(path: Path, what: str) -> object:
    """Decode the JSON file ``path``, naming it (and the line of a syntax error) on failure.

    Parameters
    ----------
    path : Path
        The file.
    what : str
        What the file should hold ("model", "design"), for the messages.

    Returns
    -------
    object
        The decoded JSON value.

    Raises
    ------
    OptionError
        When the file is missing or unreadable.
    ModelFormatError
        When it is not JSON.
    """
    if not path.is_file():
        raise OptionError(f"{what} file not found", file=str(path))
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ModelFormatError(f"not a JSON {what} ({exc.__class__.__name__}: line "
                               f"{getattr(exc, 'lineno', '?')})", file=str(path)) from None
    except RecursionError:
        raise ModelFormatError(f"not a motorid {what}: the JSON is nested too deeply", file=str(path)) from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise ModelFormatError(f"not a motorid {what}: {' '.join(str(exc).split(';')[0].split())}",
                               file=str(path)) from None
    except OSError as exc:
        raise OptionError(f"cannot read the {what} file ({exc.strerror or exc})", file=str(path)) from None

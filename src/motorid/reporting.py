"""``motorid report`` / ``identify --report``: gather what a report shows and write the page."""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from motorid.capture import Capture
from motorid.errors import CaptureFormatError, MotorIdError
from motorid.identification import Identification, IdentifySettings
from motorid.report import ReportInputs, build_report
from motorid.sweep import sensitivity_table

__all__ = ["make_report", "read_design"]


def read_design(path: Path) -> dict[str, Any]:
    """A design JSON (``motorid.design/1``), checked for its schema.

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


def make_report(
    ident: Identification,
    captures: Mapping[str, Capture],
    *,
    validation: Mapping[str, Capture] | None = None,
    design: Mapping[str, Any] | None = None,
    truth: Mapping[str, Any] | None = None,
    sweep: bool = True,
    title: str = "motorid report",
) -> str:
    """The HTML report of an identification (see :func:`motorid.report.build_report`).

    The sensitivity table is the paper's: pinv with the reduced state over 1.9/2.4/2.9 s ×
    40–120 ms, so a student sees the drift the paper reports next to the model.
    """
    table = None
    if sweep:
        try:
            order = 2 if "position" in captures else 1  # the paper's reduced state [θ, θ̇]
            table = sensitivity_table(captures, settings=IdentifySettings(method="pinv", order=order))
        except MotorIdError:
            table = None  # e.g. a record shorter than the paper's lengths: the section says so
    return build_report(ReportInputs(ident, captures, validation or {}, table, design, truth, title))

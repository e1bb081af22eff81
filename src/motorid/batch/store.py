"""Each experiment's outputs in the batch folder, and what a rerun may skip.

``DIR/<experiment>/`` gets ``model.json``, ``report.html`` (and ``design.json``), then
``result.json`` last: the summary row, the roles, the worker's time and the content hash of
the inputs and settings.  ``result.json`` is the commit mark: written only after the other
files are in place (each file atomically), so a batch killed at any instant leaves every
experiment either complete or absent, and a rerun recomputes exactly the absent ones and
those whose files or settings changed.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from motorid.batch.task import ExperimentOutcome
from motorid.io import atomic_outputs

__all__ = ["RESULT_FILE", "experiment_dir", "load_record", "write_outcome"]

RESULT_FILE = "result.json"
RESULT_SCHEMA = "motorid.batch-result/1"


def experiment_dir(out: Path, name: str) -> Path:
    """The folder of one experiment's outputs.

    Parameters
    ----------
    out : Path
        The batch folder.
    name : str
        The experiment's name (a ``/``-separated relative path).

    Returns
    -------
    Path
        ``out`` / the name's parts.
    """
    return out.joinpath(*name.split("/"))


def load_record(out: Path, name: str, input_hash: str | None) -> dict[str, Any] | None:
    """The stored record of an experiment, if its inputs and settings are unchanged.

    Parameters
    ----------
    out : Path
        The batch folder.
    name : str
        The experiment's name.
    input_hash : str or None
        The content hash now (``None``: could not be computed, never skip).

    Returns
    -------
    dict or None
        The record ``write_outcome`` wrote, or ``None`` (none, unreadable, other hash).
    """
    if input_hash is None:
        return None
    path = experiment_dir(out, name) / RESULT_FILE
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if not isinstance(doc, dict) or doc.get("schema") != RESULT_SCHEMA or doc.get("input_hash") != input_hash:
        return None
    return doc


def write_outcome(out: Path, outcome: ExperimentOutcome, input_hash: str | None, *,
                  report_kind: str = "full") -> dict[str, Any]:
    """Write one experiment's files, then its ``result.json``.

    Parameters
    ----------
    out : Path
        The batch folder.
    outcome : ExperimentOutcome
        From the worker.
    input_hash : str or None
        The content hash of its inputs and settings.
    report_kind : {"full", "lazy"}
        What ``outcome.report_html`` is: the report, or the page that stands in for it
        (:mod:`motorid.batch.lazy`); recorded as ``report`` in ``result.json``.

    Returns
    -------
    dict
        The record written to ``result.json``.

    Raises
    ------
    OutputWriteError
        A file that cannot be written (full disk, permissions).
    """
    folder = experiment_dir(out, outcome.name)
    folder.mkdir(parents=True, exist_ok=True)
    for stale in folder.glob(".*.part*"):  # temporary files of a batch killed while writing here
        stale.unlink(missing_ok=True)
    files = {"model": ("model.json", outcome.model_json), "design": ("design.json", outcome.design_json),
             "report": ("report.html", outcome.report_html)}
    written = {}
    with atomic_outputs() as outs:
        for key, (fname, text) in files.items():
            if text is not None:
                outs.write_text(folder / fname, text)
                written[key] = fname
    # a failed rerun must not leave the last run's model beside its error
    for key, (fname, _) in files.items():
        if key not in written:
            (folder / fname).unlink(missing_ok=True)
    record = {
        "schema": RESULT_SCHEMA,
        "experiment": outcome.name,
        "input_hash": input_hash,
        "status": outcome.status,
        "error": outcome.error,
        "row": dict(outcome.row),
        "roles": dict(outcome.roles),
        "files": written,
        "report": report_kind if "report" in written else None,
        "seconds": round(outcome.seconds, 3),
        "cpu_seconds": round(outcome.cpu_seconds, 3),
    }
    with atomic_outputs() as outs:
        outs.write_text(folder / RESULT_FILE, json.dumps(record, indent=2) + "\n")
    return record

"""``run_batch``: find, skip what is done, identify the rest in parallel, write the summary.

The parent process discovers the experiments, hashes their inputs and settings, skips those
whose ``result.json`` holds the same hash, sends the rest to the engine and writes each
result as it arrives (:mod:`motorid.batch.store`); the summary is written at the end from
the stored records, so a resumed batch gives the same summary as an uninterrupted one.
"""

from __future__ import annotations

import errno

import json
import os
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

from motorid.batch.discover import ExperimentSpec, discover_experiments, folders_without_captures
from motorid.batch.engine import parallel_map
from motorid.batch.lazy import render_command, report_stub
from motorid.batch.page import summary_html
from motorid.batch.store import load_record, write_outcome
from motorid.batch.summary import SummaryRow, summary_csv, summary_rows
from motorid.batch.task import BatchSettings, run_experiment_task
from motorid.errors import OptionError
from motorid.io import atomic_outputs, check_writable

__all__ = ["BatchResult", "run_batch"]

#: One line per run: which experiments were computed and which skipped (and the wall time).
LOG_FILE = "batch-log.jsonl"
#: The batch folder's own files: no experiment folder may take these names.
BATCH_FILES: tuple[str, ...] = ("summary.csv", "summary.html", LOG_FILE)

#: ``progress(done, failed, total, name)``: called at the start (``name`` empty) and after
#: each experiment, skipped ones first.
ProgressCallback = Callable[[int, int, int, str], None]


@dataclass(frozen=True, slots=True)
class BatchResult:
    """What a batch did.

    Attributes
    ----------
    out : Path
        The batch folder.
    rows : tuple of SummaryRow
        The summary, sorted by experiment.
    computed : tuple of str
        Experiments identified by this run.
    skipped : tuple of str
        Experiments whose stored result was kept (inputs and settings unchanged).
    seconds : float
        Wall time of the run.
    without_captures : tuple of (str, tuple of str)
        Folders under the roots that hold files but no capture (named with some of their files).
    """

    out: Path
    rows: tuple[SummaryRow, ...]
    computed: tuple[str, ...]
    skipped: tuple[str, ...]
    seconds: float
    without_captures: tuple[tuple[str, tuple[str, ...]], ...] = ()

    @property
    def failed(self) -> tuple[str, ...]:
        """Experiments that gave no model."""
        return tuple(r.experiment for r in self.rows if r.status == "failed")


def _hash(spec: ExperimentSpec, fingerprint: dict[str, Any]) -> str | None:
    try:
        return spec.content_hash(fingerprint)
    except OSError:  # a file that vanished or cannot be read: the worker reports why
        return None


def _in_symlink_loop(path: Path) -> bool:
    """Whether ``path`` (or the ancestor that exists) lies in a loop of symbolic links.

    Python < 3.13 raises RuntimeError from ``resolve()``; 3.13 resolves such a path without a
    word and the loop shows as ``ELOOP`` when the path is used: ask the file system.
    """
    try:
        path.resolve(strict=False)
    except RuntimeError:
        return True
    for p in (path, *path.parents):
        try:
            p.stat()
            return False
        except FileNotFoundError:
            continue
        except OSError as exc:
            return exc.errno == errno.ELOOP
    return False


def run_batch(
    roots: Sequence[str | os.PathLike[str]],
    out: str | os.PathLike[str],
    settings: BatchSettings | None = None,
    *,
    jobs: int = 1,
    scheduler: str | None = None,
    seed: int = 0,
    force: bool = False,
    progress: ProgressCallback | None = None,
    only: Sequence[str] | None = None,
    command: Sequence[str] | None = None,
) -> BatchResult:
    """Identify every experiment under ``roots`` into ``out`` (``motorid batch``).

    Parameters
    ----------
    roots : sequence of paths
        Folders to search for experiments (see :mod:`motorid.batch.discover`).
    out : path
        The batch folder (created): ``<experiment>/model.json``, ``report.html``,
        ``result.json``; ``summary.csv``, ``summary.html``, ``batch-log.jsonl``.
    settings : BatchSettings, optional
        Identify options and what to write (default: ``method="auto"``, reports).
    jobs : int
        Worker processes on this machine (1: in this process).
    scheduler : str, optional
        A Dask scheduler's address: run on its workers instead.
    seed : int
        The batch's seed; each experiment's is derived from it and its name.
    force : bool
        Recompute every experiment, even those whose stored result is current.
    progress : callable, optional
        ``progress(done, failed, total, name)`` (see :data:`ProgressCallback`).
    only : sequence of str, optional
        Compute only the experiments whose name matches one of these shell patterns
        (``fnmatch``); the others are kept as stored when current, and left out of this run's
        summary when not.
    command : sequence of str, optional
        The batch's command line without ``--reports``/``--only``: lazy reports show it, with
        ``--reports full --only NAME``, as the command that renders the full report.

    Returns
    -------
    BatchResult
        The summary and what was computed or skipped.

    Raises
    ------
    OptionError
        No experiments, a bad roles file, bad options, an unreachable scheduler.
    OutputWriteError
        The batch folder cannot be written.
    """
    t_start = time.perf_counter()
    settings = BatchSettings() if settings is None else settings
    out = Path(out)
    check_writable({"--out": out}, force=True, folder=True)
    if _in_symlink_loop(out):
        raise OptionError("lies in a loop of symbolic links: give --out a real folder", file=str(out))
    specs = discover_experiments(roots, skip=out)
    for spec in specs:  # an experiment's folder beside the summary must not be one of the batch's own files
        top = spec.name.split("/")[0]
        if top in BATCH_FILES:
            raise OptionError(f"the experiment {spec.name!r} would write into {out / top}, which is the batch's own "
                              f"{top}: rename that folder (the batch writes {', '.join(BATCH_FILES)})")
    out.mkdir(parents=True, exist_ok=True)
    fingerprint = settings.fingerprint()
    hashes = {s.name: _hash(s, fingerprint) for s in specs}
    records: dict[str, dict[str, Any]] = {}
    wanted = [s for s in specs if only is None or any(fnmatchcase(s.name, pat) for pat in only)]
    if only is not None and not wanted:
        raise OptionError(f"--only {' '.join(only)}: no experiment matches "
                          f"(found {len(specs)}, e.g. {specs[0].name!r})")
    full_reports = settings.report and not settings.lazy_reports
    for s in specs:
        rec = load_record(out, s.name, hashes[s.name])
        if rec is not None:
            records[s.name] = rec
    chosen = {s.name for s in wanted}

    def current(name: str) -> bool:
        # a lazy report's stand-in page does not serve a batch that asks for full reports
        rec = records.get(name)
        return rec is not None and not (name in chosen and (force or (full_reports and rec.get("report") == "lazy")))

    todo = [s for s in wanted if not current(s.name)]
    for s in todo:
        records.pop(s.name, None)
    specs = [s for s in specs if s.name in records or s.name in chosen]
    skipped = tuple(s.name for s in specs if s.name in records)
    total = len(specs)
    failed = sum(r["status"] == "failed" for r in records.values())
    if progress is not None:
        progress(len(records), failed, total, "")
    computed: list[str] = []
    items = [(s.name, (s, settings)) for s in todo]
    for name, outcome in parallel_map(run_experiment_task, items, jobs=jobs, scheduler=scheduler, seed=seed):
        kind = "full"
        if settings.lazy_reports and outcome.status != "failed":
            outcome = replace(outcome, report_html=report_stub(name, outcome.status, outcome.row,
                                                               render_command(command, name)))
            kind = "lazy"
        records[name] = write_outcome(out, outcome, hashes[name], report_kind=kind)
        computed.append(name)
        failed += outcome.status == "failed"
        if progress is not None:
            progress(len(records), failed, total, name)
    rows = summary_rows([records[s.name] for s in specs])
    with atomic_outputs() as outs:
        outs.write_text(out / "summary.csv", summary_csv(rows))
        outs.write_text(out / "summary.html", summary_html(rows))
    seconds = time.perf_counter() - t_start
    log = {"computed": sorted(computed), "skipped": list(skipped), "failed": [r.experiment for r in rows
                                                                             if r.status == "failed"],
           "jobs": jobs, "scheduler": scheduler, "seconds": round(seconds, 3)}
    with open(out / LOG_FILE, "a", encoding="utf-8") as fh:
        fh.write(json.dumps(log) + "\n")
    return BatchResult(out, tuple(rows), tuple(sorted(computed)), skipped, seconds,
                       tuple(folders_without_captures(roots, skip=out)))

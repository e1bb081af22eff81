"""``motorid batch``: every experiment under the roots, in parallel, with a class summary.

Thin: checks the options, calls :func:`motorid.batch.run_batch` with a rich progress bar on
stderr (experiments done/failed, ETA) when stderr is a terminal or with ``--progress``, and
prints what was written.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

from motorid.options import COLUMNS, COUNTED_VELOCITY

__all__ = ["register"]


def batch(
    roots: Annotated[list[Path], typer.Argument(help="Folders holding the experiments (searched recursively).")],
    out: Annotated[Path, typer.Option("--out", help="Batch folder: per-experiment outputs and summary.csv/.html.")],
    jobs: Annotated[int, typer.Option("--jobs", "-j", help="Worker processes on this machine (-1: one per core).")] = 1,
    scheduler: Annotated[str | None, typer.Option(
        "--scheduler", help="Dask scheduler address (tcp://host:8786): run on its workers instead.")] = None,
    method: Annotated[str, typer.Option(help="Identification method (see identify).")] = "auto",
    order: Annotated[str, typer.Option(help="auto, 1, 2 or 3 (see identify).")] = "auto",
    ratio: Annotated[int | None, typer.Option(help="Sample reduction ratio (overrides --sample-interval).")] = None,
    sample_interval: Annotated[float | None, typer.Option(
        "--sample-interval", help="Sample interval after reduction, s (default: chosen from the response).")] = None,
    record_length: Annotated[float | None, typer.Option(
        "--record-length", help="Seconds kept after the step (default: all).")] = None,
    reduction: Annotated[str, typer.Option(help="subsample (paper), block_mean or fir.")] = "subsample",
    derivative: Annotated[str, typer.Option(help="euler, central, five_point (paper) or savgol.")] = "five_point",
    structure: Annotated[str, typer.Option(help="pinv: free, or known.")] = "free",
    markov_params: Annotated[int | None, typer.Option("--markov-params", help="Markov parameters.")] = None,
    markov_window: Annotated[float | None, typer.Option("--markov-window", help="Markov window Tε in s.")] = None,
    markov_basis: Annotated[str, typer.Option("--markov-basis", help="laguerre or taylor.")] = "laguerre",
    sync: Annotated[str, typer.Option(help="Synchronisation: interp or index (the paper's).")] = "interp",
    delay: Annotated[bool | None, typer.Option(
        "--delay/--no-delay", help="oe/auto: fit a dead time always / never (default: BIC decides).")] = None,
    step_volts: Annotated[float | None, typer.Option(
        "--step-volts", help="Step level for captures without an input channel (experiment.toml wins).")] = None,
    t0: Annotated[float | None, typer.Option("--t0", help="Step instant on the files' time axis.")] = None,
    columns: Annotated[str | None, typer.Option(help=COLUMNS.sentence)] = None,
    force_role: Annotated[bool, typer.Option(
        "--force-role", help="Keep the roles a roles file names even when a capture looks like another.")] = False,
    counted_velocity: Annotated[bool, typer.Option(
        "--counted-velocity", help=COUNTED_VELOCITY.sentence[:-1] + " (every experiment with a velocity capture; "
                                   "experiment.toml's counted_velocity = true for one).")] = False,
    report: Annotated[bool, typer.Option("--report/--no-report", help="Write each experiment's HTML report.")] = True,
    reports: Annotated[str | None, typer.Option(
        "--reports", help="full (each experiment's report, about 2 s each), lazy (a small page per experiment with "
                          "the command that renders its report on demand) or none (as --no-report).")] = None,
    only: Annotated[list[str] | None, typer.Option(
        "--only", help="Compute only the experiments whose name matches (shell pattern; repeatable).")] = None,
    validate: Annotated[bool, typer.Option(
        "--validate", help="Validate each model on the experiment's other captures (sine, triangle…) in its report.",
    )] = False,
    damping: Annotated[float | None, typer.Option("--damping", help="Design: damping ζ (with --wn).")] = None,
    wn: Annotated[float | None, typer.Option(
        "--wn", help="Design: natural frequency in rad/s (with --damping).")] = None,
    seed: Annotated[int, typer.Option(help="Seed of the batch (each experiment's is derived from its name).")] = 0,
    force: Annotated[bool, typer.Option("--force", help="Recompute every experiment, even unchanged ones.")] = False,
    progress: Annotated[bool, typer.Option(
        "--progress", help="Show the progress bar on stderr even when it is not a terminal.")] = False,
) -> None:
    """Identify every experiment under the roots (joblib here, or a Dask cluster) and summarise the class."""
    from rich.console import Console
    from rich.markup import escape
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    from motorid.batch import BatchSettings, run_batch
    from motorid.cli.app import _check_options, _console, _parse_columns  # imported late: app imports this module
    from motorid.errors import OptionError

    _check_options(method=method, order=order, reduction=reduction, derivative=derivative, structure=structure,
                   sync=sync, ratio=ratio, sample_interval=sample_interval, record_length=record_length,
                   step_volts=step_volts, t0=t0, markov_params=markov_params, markov_window=markov_window,
                   markov_basis=markov_basis)
    if (damping is None) != (wn is None):
        raise OptionError("--damping and --wn go together: give both to design a controller for every model")
    identify = {
        "method": method, "order": order if order == "auto" else int(order),
        "sample_interval": "auto" if sample_interval is None else sample_interval, "ratio": ratio,
        "record_length_s": record_length, "reduction": reduction, "derivative": derivative,
        "structure": structure, "markov_params": markov_params, "markov_window_s": markov_window,
        "markov_basis": markov_basis, "sync": sync, "delay": delay,
    }
    if reports is not None and reports not in ("full", "lazy", "none"):
        raise OptionError(f"--reports {reports!r}: use full, lazy or none")
    if reports is not None:
        report = reports != "none"
    settings = BatchSettings(
        identify=identify, step_volts=step_volts, t0=t0, columns=_parse_columns(columns), report=report,
        lazy_reports=reports == "lazy",
        validate=validate, design=None if damping is None else {"damping": damping, "wn": wn}, force_role=force_role,
        counted_velocity=counted_velocity,
    )
    show = progress or sys.stderr.isatty()
    columns_ = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                TextColumn("failed {task.fields[failed]}"), TimeRemainingColumn())
    with Progress(*columns_, console=Console(stderr=True), transient=not progress, disable=not show) as bar:
        task = bar.add_task("experiments", total=None, failed=0)

        def tick(done: int, failed: int, total: int, name: str) -> None:
            bar.update(task, completed=done, total=total, failed=failed)

        result = run_batch(roots, out, settings, jobs=jobs, scheduler=scheduler, seed=seed, force=force,
                           progress=tick, only=only, command=_own_command(sys.argv))
    con = _console()
    rows = result.rows
    counts = {s: sum(r.status == s for r in rows) for s in ("ok", "warning", "failed")}
    con.print(f"{len(rows)} experiments: {counts['ok']} ok, {counts['warning']} with warnings, "
              f"{counts['failed']} failed ({len(result.computed)} computed, {len(result.skipped)} unchanged, "
              f"{result.seconds:.1f} s)")
    for r in rows:
        if r.status == "failed":
            con.print(f"[red]failed[/red] {escape(r.experiment)}: {escape(r.error)}", highlight=False)
        elif r.outlier:
            con.print(f"[yellow]outlier[/yellow] {escape(r.experiment)}: {r.outlier} (z gain {r.gain_z:.2f}, "
                      f"z τ {r.tau_z:.2f})", highlight=False)
    for folder, files in result.without_captures:
        con.print(f"[yellow]no capture[/yellow] {escape(folder)}: {escape(', '.join(files))} — not an experiment "
                  "(captures are ALLnnnn folders, Tektronix or plain CSV logs, .xlsx exports)", highlight=False)
    con.print(f"summary: {Path(out) / 'summary.csv'}")
    con.print(f"summary page: {Path(out) / 'summary.html'}")


def _own_command(argv: list[str]) -> list[str]:
    """The batch's command line without ``--reports``, ``--only`` and ``--force`` (for lazy reports' pages)."""
    import os

    args = ["motorid"]
    rest = iter(argv[1:])
    for a in rest:
        if a in ("--reports", "--only"):
            next(rest, None)
        elif a.startswith(("--reports=", "--only=")) or a in ("--force", "--report", "--no-report", "--progress"):
            continue
        else:
            args.append(a)
    # paths as given are relative to where the batch ran: name them absolutely (the batch folder
    # may not exist yet)
    after_out = [i > 0 and args[i - 1] == "--out" for i in range(len(args))]
    return [os.path.abspath(a) if out_value or (not a.startswith("-") and os.path.exists(a))
            else ("--out=" + os.path.abspath(a[6:]) if a.startswith("--out=") else a)
            for a, out_value in zip(args, after_out, strict=True)]


def register(app: typer.Typer) -> None:
    """Add ``motorid batch`` to the main app.

    Parameters
    ----------
    app : typer.Typer
        The ``motorid`` app.
    """
    app.command("batch")(batch)

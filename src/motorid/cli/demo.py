"""``motorid demo``: record an example experiment on the virtual trainer.

The experiment is written as scope files and read back as a user's captures would be read.

The example is the paper's procedure (Masoud 2019, section V): three separate acquisitions of
the same step — position (``ALL0000``), velocity (``ALL0001``), armature current
(``ALL0002``) — and the onboard sine, triangle and square test signals for validation
(``ALL0003``–``ALL0005``), each in the TDS2000 'Save All' layout, plus ``truth.json`` with the
exact linearised transfer functions and, per capture, the true step instant, level and
number of encoder wraps.  The captures are then read back and identified (``--method auto``),
the model written to ``model.json`` and the whole story to ``report.html``.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

from motorid._threads import single_blas_thread
from motorid.conditioning.inspect import CaptureSummary, describe_capture
from motorid.errors import OptionError, OutputExistsError
from motorid.io import atomic_folder, check_writable, read_capture, write_tds_capture

__all__ = ["CAPTURE_ORDER", "DEMO_STEPS", "RIG_DEMO_STEPS", "DemoResult", "DemoRow", "RigDemoResult", "read_options_of",
           "run_demo", "run_rig_demo"]

#: The steps ``run_demo`` reports to its ``progress`` callback.
DEMO_STEPS: tuple[str, ...] = ("trainer simulation", "writing and reading the captures", "identifying",
                               "report")
#: Folder index of each capture of the example experiment.
CAPTURE_ORDER: tuple[str, ...] = ("position", "velocity", "current", "sine", "triangle", "square")


@dataclass(frozen=True, slots=True)
class DemoRow:
    """One written capture: what the trainer knows and what was read back."""

    name: str
    folder: str
    true_step_time_s: float
    true_step_volts: float
    true_wraps: int
    read: CaptureSummary


@dataclass(frozen=True, slots=True)
class DemoResult:
    """What ``run_demo`` wrote and read back."""

    out: Path
    rows: tuple[DemoRow, ...]
    truth_path: Path
    experiment: Any
    identification: Any


def _targets(out: Path) -> list[Path]:
    captures = [out / f"ALL{i:04d}" for i in range(len(CAPTURE_ORDER))]
    return [*captures, out / "truth.json", out / "model.json", out / "report.html"]


@single_blas_thread
def run_demo(
    out: Path | str,
    *,
    preset: str = "paper",
    seed: int = 0,
    step_volts: float = 5.92,
    force: bool = False,
    progress: Callable[..., None] | None = None,
) -> DemoResult:
    """Generate, write and read back the example experiment.

    Parameters
    ----------
    out : path
        Folder to write into (created if needed).
    preset : str
        Virtual trainer preset (see :data:`motorid.trainer.PRESET_NAMES`).
    seed : int
        Seed of the simulated noise and trigger offsets.
    step_volts : float
        Step level.
    force : bool
        Overwrite existing files; without it nothing is written when any target exists.
    progress : callable, optional
        Called as ``progress(done, total, label)`` before each of the :data:`DEMO_STEPS` steps
        and once at the end (the command line's progress bar, :mod:`motorid.cli.progress`).

    Returns
    -------
    DemoResult
        The written folders with the truth and what ``inspect`` reads from them.

    Raises
    ------
    OutputExistsError
        A target exists and ``force`` is false.
    OptionError
        ``out`` is a file, or lies below a file or in a folder that cannot be written.
    """
    from motorid.trainer import run_experiment

    out = Path(out)
    check_writable([out], force=force, folder=True)
    existing = [p for p in _targets(out) if p.exists()]
    if existing and not force:
        raise OutputExistsError(
            f"{len(existing)} output(s) exist (e.g. {existing[0].name}); use --force to overwrite",
            file=str(out),
        )
    def step(done: int) -> None:
        if progress is not None:
            progress(done, len(DEMO_STEPS), DEMO_STEPS[done] if done < len(DEMO_STEPS) else None)

    step(0)
    exp = run_experiment(preset, step_volts=step_volts, seed=seed)
    # all the demo's files appear, or none: a failure (full disk) puts back what was there
    with atomic_folder(out, _targets(out)):
        result = _write_demo(out, exp, preset=preset, seed=seed, step_volts=step_volts, force=force, step=step)
    step(len(DEMO_STEPS))
    return result


def _write_demo(out: Path, exp: Any, *, preset: str, seed: int, step_volts: float, force: bool,
                step: Callable[[int], None]) -> DemoResult:
    """Write the example captures, read them back, identify, write the model and report."""
    step(1)
    captures = dict(exp.captures)
    captures.update(exp.validation)
    rows: list[DemoRow] = []
    truth_caps: dict[str, Any] = {}
    for i, name in enumerate(CAPTURE_ORDER):
        if name not in captures:
            continue
        folder = write_tds_capture(out, captures[name], index=i, force=force)
        truth = exp.capture_truth.get(name)
        read = describe_capture(read_capture(folder))
        st = truth.step_time_s if truth is not None else float("nan")
        sv = truth.step_volts if truth is not None else float("nan")
        wr = truth.wraps if truth is not None else 0
        rows.append(DemoRow(name, str(folder), st, sv, wr, read))
        truth_caps[name] = {"folder": folder.name, "step_time": st, "step_volts": sv, "wraps": wr}
    truth_path = out / "truth.json"
    doc = {
        "schema": "motorid.trainer-truth/1",
        "preset": preset,
        "seed": seed,
        "step_volts": step_volts,
        "captures": truth_caps,
        "transfer_functions": exp.truth.to_json(),
        "config": asdict(exp.config),
    }
    truth_path.write_text(json.dumps(doc, indent=2, default=float) + "\n", encoding="utf-8")
    # the main job on what was written: identify from the files, as a user would, through the front door
    from motorid import frontdoor

    folders = {role: out / f"ALL{CAPTURE_ORDER.index(role):04d}"
               for role in ("position", "velocity", "current") if role in exp.captures}
    step(2)
    fit = frontdoor.identify(frontdoor.read_experiment(**folders))  # type: ignore[arg-type]
    ident = fit.identification
    model_path = out / "model.json"
    model_path.write_text(ident.model.to_json_text(), encoding="utf-8")
    step(3)
    frontdoor.write_report(out / "report.html", fit, truth=doc,
                           validation={name: out / f"ALL{CAPTURE_ORDER.index(name):04d}"
                                       for name in ("sine", "triangle", "square") if name in exp.validation},
                           title=f"motorid demo: virtual trainer '{preset}', seed {seed}")
    return DemoResult(out, tuple(rows), truth_path, exp, ident)


@dataclass(frozen=True, slots=True)
class RigDemoResult:
    """What ``run_rig_demo`` wrote and identified.

    Attributes
    ----------
    out : Path
        The folder.
    files : Mapping[str, Path]
        The rig's files by role (``log`` for a one-file log).
    cli_args : tuple of str
        The ``motorid identify`` arguments a user gives for these files (default options).
    truth : RealSetupTruth
        What a perfect identification would report (gain, residence time, units).
    truth_path, model_path : Path
        ``truth.json`` and ``model.json``.
    fit : IdentificationResult
        The identification through the front door.
    """

    out: Path
    files: Mapping[str, Path]
    cli_args: tuple[str, ...]
    truth: Any
    truth_path: Path
    model_path: Path
    fit: Any


#: The steps ``run_rig_demo`` reports to its ``progress`` callback.
RIG_DEMO_STEPS: tuple[str, ...] = ("trainer simulation, written as the rig writes it", "identifying")


def read_options_of(args: Sequence[str]) -> dict[str, Any]:
    """``motorid identify`` arguments as :func:`motorid.read_experiment`'s keyword options.

    The flags are the ones :mod:`motorid.options` declares for reading an experiment (a rig
    preset's arguments use no others).

    Parameters
    ----------
    args : sequence of str
        Flag, value pairs (``--velocity log.csv --step-volts 6``).

    Returns
    -------
    dict
        ``{"velocity": "log.csv", "step_volts": 6.0}``.
    """
    from motorid.options import READ, ROLES

    names = {o.flag: o.name for o in ROLES + READ}
    out: dict[str, Any] = {}
    for flag, value in zip(args[::2], args[1::2], strict=True):
        name = names[flag]
        if name in ("step_volts", "t0"):
            out[name] = float(value)
        elif name == "segment":
            out[name] = int(value)
        elif name == "columns":
            from motorid.io._table import parse_column_map

            out[name] = parse_column_map(value)
        else:
            out[name] = value
    return out


@single_blas_thread
def run_rig_demo(
    out: Path | str,
    *,
    rig: str,
    seed: int = 0,
    force: bool = False,
    progress: Callable[..., None] | None = None,
) -> RigDemoResult:
    """Record a step on the virtual trainer as a real rig logs it, and identify it as a user would.

    Parameters
    ----------
    out : path
        Folder to write into (created if needed).
    rig : str
        One of :data:`motorid.options.TRAINER_RIGS`.
    seed : int
        Seed of the noise, the clocks' phases and the step instant.
    force : bool
        Overwrite existing files.
    progress : callable, optional
        ``progress(done, total, label)`` before each of :data:`RIG_DEMO_STEPS` and at the end.

    Returns
    -------
    RigDemoResult

    Raises
    ------
    OptionError
        An unknown rig, or ``out`` cannot be written.
    OutputExistsError
        ``truth.json`` or ``model.json`` exist and ``force`` is false.
    """
    from motorid import frontdoor
    from motorid.options import TRAINER_RIGS
    from motorid.trainer.realsetups import write_real_setup

    if rig not in TRAINER_RIGS:
        raise OptionError(f"--rig {rig!r}: use one of {', '.join(TRAINER_RIGS)}")
    out = Path(out)
    check_writable([out], force=force, folder=True)
    truth_path, model_path = out / "truth.json", out / "model.json"
    existing = [p for p in (truth_path, model_path) if p.exists()]
    if existing and not force:
        raise OutputExistsError(f"{existing[0].name} exists; use --force to overwrite it", file=str(out))

    def step(done: int) -> None:
        if progress is not None:
            progress(done, len(RIG_DEMO_STEPS), RIG_DEMO_STEPS[done] if done < len(RIG_DEMO_STEPS) else None)

    step(0)
    rec = write_real_setup(rig, out, seed=seed, force=force)
    step(1)
    fit = frontdoor.identify(frontdoor.read_experiment(**read_options_of(rec.cli_args)))
    model_path.write_text(fit.model.to_json_text(), encoding="utf-8")
    t = rec.truth
    doc = {"schema": "motorid.rig-truth/1", "rig": rig, "seed": seed,
           "files": {role: str(p.relative_to(out)) for role, p in rec.files.items()},
           "identify_args": [str(Path(a).relative_to(out)) if a.startswith(str(out)) else a for a in rec.cli_args],
           "dc_gain": t.dc_gain, "output_units": t.output_units, "time_constant_s": t.time_constant_s,
           "delay_s": t.delay_s, "residence_time_s": t.residence_time_s, "step_volts": t.step_volts,
           "from_volts": t.from_volts, "step_time_s": t.step_time_s,
           # the lag the velocity sensor adds (a count over each interval: half of it), inside delay_s
           # and residence_time_s: --counted-velocity models it, and the motor's own is the difference
           "sensor_lag_s": t.sensor_lag_s}
    truth_path.write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    step(len(RIG_DEMO_STEPS))
    return RigDemoResult(out, MappingProxyType(dict(rec.files)), rec.cli_args, t, truth_path, model_path, fit)

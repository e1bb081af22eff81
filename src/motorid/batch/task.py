"""One experiment of a batch, as a worker runs it: roles, read, identify, report — never raises.

The worker returns everything the batch writes (model JSON, design JSON, report HTML and the
summary row) instead of writing files itself: the output folder need not be shared with a
Dask cluster's machines, and the parent writes each result the moment it arrives, so an
interrupted batch keeps every finished experiment.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

from motorid.frozen import frozen_getstate, frozen_setstate
from motorid.batch.discover import ExperimentSpec, _reduce_frozen
from motorid.errors import MotorIdError, OptionError
from motorid.options import IDENTIFY, defaults

__all__ = ["BatchSettings", "ExperimentOutcome", "assign_roles", "run_experiment_task"]

#: The outcome of an experiment: identified cleanly, identified with warnings, or not at all.
STATUSES = ("ok", "warning", "failed")
#: Identify options the batch passes to :func:`motorid.identify`, with its defaults.
IDENTIFY_OPTIONS: dict[str, Any] = defaults(IDENTIFY)


@dataclass(frozen=True, slots=True)
class BatchSettings:
    """Everything that decides a batch's results (the resume hash covers all of it).

    Attributes
    ----------
    identify : Mapping[str, Any]
        Keyword options of :func:`motorid.identify` (``method``, ``order``, ``sample_interval``…);
        checked on construction.
    step_volts : float or None
        Step level [V] for captures without an input channel (an ``experiment.toml`` wins).
    t0 : float or None
        Step instant [s] (an ``experiment.toml`` wins).
    columns : Mapping[str, str] or None
        Plain-CSV column map (an ``experiment.toml`` wins).
    report : bool
        Write each experiment's HTML report.
    lazy_reports : bool
        With ``report``: write a small page per experiment in place of its report, with the
        command that renders the full one on demand (:mod:`motorid.batch.lazy`).  Not part of
        the resume hash: a lazy batch's results serve a later ``--reports full`` run, which
        computes again only the experiments whose report is still lazy.
    validate : bool
        Validate each model on the experiment's other captures (sine, triangle, square:
        those named ``validate`` in its roles file, else those whose role is unknown), in
        its report.
    design : Mapping[str, Any] or None
        Keyword options of :func:`motorid.design` (e.g. ``{"damping": 0.7, "wn": 5.0}``):
        design a controller on every model (``design.json``, shown in the report).
    force_role : bool
        Keep roles named by a roles file even when a capture looks like another role.
    counted_velocity : bool
        Every experiment's velocity counts encoder edges over each sample interval (an
        ``experiment.toml``'s ``counted_velocity = true`` says so for one experiment); an
        experiment without a velocity capture is identified as it is.

    Raises
    ------
    OptionError
        An unknown identify option or a bad value (naming the option).
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    identify: Mapping[str, Any] = field(default_factory=dict)
    step_volts: float | None = None
    t0: float | None = None
    columns: Mapping[str, str] | None = None
    report: bool = True
    lazy_reports: bool = False
    validate: bool = False
    design: Mapping[str, Any] | None = None
    force_role: bool = False
    counted_velocity: bool = False

    def __post_init__(self) -> None:
        unknown = sorted(set(self.identify) - set(IDENTIFY_OPTIONS))
        if unknown:
            raise OptionError(f"unknown identify option(s) {', '.join(unknown)}: use {', '.join(IDENTIFY_OPTIONS)}")
        _check_identify({**IDENTIFY_OPTIONS, **self.identify})
        for name in ("step_volts", "t0"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise OptionError(f"{name}={v!r}: give a finite number")
        if self.lazy_reports and not self.report:
            raise OptionError("lazy reports need reports: leave --no-report out (or use --reports none alone)")
        if self.step_volts == 0:
            raise OptionError("step_volts must not be 0 V (a negative value is a step down)")
        object.__setattr__(self, "identify", MappingProxyType(dict(self.identify)))
        if self.columns is not None:
            object.__setattr__(self, "columns", MappingProxyType(dict(self.columns)))
        if self.design is not None:
            object.__setattr__(self, "design", MappingProxyType(dict(self.design)))

    __reduce__ = _reduce_frozen

    def fingerprint(self) -> dict[str, Any]:
        """The settings and motorid's version as a JSON-ready dict (part of the resume hash).

        Returns
        -------
        dict
            Every field, with the identify options' defaults filled in.
        """
        from importlib.metadata import PackageNotFoundError, version

        try:
            motorid_version = version("motorid")
        except PackageNotFoundError:  # a source tree that is not installed
            from motorid import __version__ as motorid_version
        return {
            "motorid": motorid_version,
            "identify": {**IDENTIFY_OPTIONS, **self.identify},
            "step_volts": self.step_volts, "t0": self.t0,
            "columns": None if self.columns is None else dict(self.columns),
            "report": self.report, "validate": self.validate,
            "design": None if self.design is None else dict(self.design),
            "force_role": self.force_role,
            # only when set: the resume hashes of batches without it stay as they were
            **({"counted_velocity": True} if self.counted_velocity else {}),
        }


def _check_identify(o: Mapping[str, Any]) -> None:
    """Check the identify options before any work, as :func:`motorid.identify` would.

    The same mapping as the front door's ``identify`` onto the settings, which validate
    themselves naming the parameter: a bad option is one error, not one failure per experiment.
    """
    from motorid.conditioning.pipeline import ConditioningSettings
    from motorid.identification.pipeline import IdentifySettings

    IdentifySettings(
        method=o["method"], order=o["order"],
        conditioning=ConditioningSettings(
            sample_interval_s=None if o["ratio"] is not None else o["sample_interval"], ratio=o["ratio"],
            reduction=o["reduction"], record_length_s=o["record_length_s"], sync=o["sync"],
        ),
        derivative=o["derivative"], structure=o["structure"], markov_params=o["markov_params"],
        markov_window_s=o["markov_window_s"], delay=o["delay"], markov_basis=o["markov_basis"],
    )


@dataclass(frozen=True, slots=True)
class ExperimentOutcome:
    """What a worker found for one experiment (the parent writes it).

    Attributes
    ----------
    name : str
        The experiment's name.
    status : str
        ``ok``, ``warning`` (a model, with warnings or failed sanity checks) or ``failed``.
    row : Mapping[str, Any]
        The summary values: ``dc_gain``, ``dc_gain_ci95``, ``time_constant``,
        ``time_constant_ci95``, ``order``, ``method``, ``fit_percent``, ``velocity_nrmse``,
        ``warnings`` (empty when failed).
    roles : Mapping[str, str]
        The capture each role was read from (relative to the experiment folder), and how
        the roles were found (``roles_from``: ``guessed`` or the roles file).
    model_json, design_json, report_html : str or None
        The files' contents.
    error : str
        The one-line reason of a failure (paths relative to the experiment folder).
    seconds : float
        Wall time in the worker [s].
    cpu_seconds : float
        CPU time of the worker process meanwhile [s] (far below ``seconds``: other processes
        shared the cores).
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    name: str
    status: str
    row: Mapping[str, Any] = field(default_factory=dict)
    roles: Mapping[str, str] = field(default_factory=dict)
    model_json: str | None = None
    design_json: str | None = None
    report_html: str | None = None
    error: str = ""
    seconds: float = 0.0
    cpu_seconds: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "row", MappingProxyType(dict(self.row)))
        object.__setattr__(self, "roles", MappingProxyType(dict(self.roles)))

    __reduce__ = _reduce_frozen


def _label(paths: tuple[str, ...]) -> str:
    return "+".join(paths)


#: A step starts from rest when its level before the edge is within this fraction of its amplitude.
AT_REST_OF_AMPLITUDE = 0.05


def _steps_from_rest(capture: Any) -> bool:
    """Whether the capture's input channel steps from about 0 V (the paper's experiment)."""
    from motorid.conditioning.edge import step_edge

    if capture.input_v is None:
        return False
    try:
        edge = step_edge(capture.time_s, capture.input_v, file=capture.source)
    except MotorIdError:
        return False
    return abs(edge.baseline_v) <= AT_REST_OF_AMPLITUDE * abs(edge.amplitude_v)


def assign_roles(captures: Mapping[tuple[str, ...], Any]) -> tuple[dict[str, tuple[str, ...]], list[tuple[str, ...]]]:
    """Give each capture of a folder without a roles file its role, from its signal.

    A capture's own labels win (a plain-CSV log's column names); each file takes one role, as on
    the command line; then confident guesses (:func:`motorid.conditioning.role.guess_role`); then
    guesses that are not confident, for roles still free.

    Parameters
    ----------
    captures : Mapping[tuple of str, Capture]
        Each capture read without a role, keyed by its paths.

    Returns
    -------
    roles : dict
        Role → the capture's paths.
    others : list
        Captures with no role (validation candidates: sine, triangle, square).

    Raises
    ------
    OptionError
        Two captures that look like the same role, or none like a velocity or position.
    """
    from motorid.capture import ROLES
    from motorid.conditioning.role import guess_role

    guesses = {key: guess_role(cap) for key, cap in captures.items()}
    roles: dict[str, tuple[str, ...]] = {}
    for confident in (True, False):
        claims: dict[str, list[tuple[str, ...]]] = {}
        for key, g in guesses.items():
            if g.role in ROLES and g.confident == confident and key not in roles.values():
                claims.setdefault(g.role, []).append(key)
        for role, keys in claims.items():
            if role in roles:
                continue
            if len(keys) > 1:
                # the step experiment starts from rest; a slow square wave (validation) that
                # shows one edge in the window swings between two non-zero levels
                at_rest = [k for k in keys if _steps_from_rest(captures[k])]
                keys = at_rest if len(at_rest) == 1 else keys
            if len(keys) > 1:
                raise OptionError(f"{len(keys)} captures look like {role} ({', '.join(map(_label, keys))}): name "
                                  "the roles in an experiment.toml or manifest.csv in the folder")
            roles[role] = keys[0]
    # a plain-CSV log's further role columns (a position beside the velocity) are not taken: the
    # same file gives the same model as `motorid identify --velocity FILE` (its conditioning notes
    # the column left out); an experiment.toml can name the file for both roles
    if "velocity" not in roles and "position" not in roles:
        seen = "; ".join(f"{_label(k)}: {g.role} ({g.reason})" for k, g in guesses.items()) or "no captures"
        raise OptionError(f"no capture looks like a velocity or position step response ({seen}): name the "
                          "roles in an experiment.toml or manifest.csv in the folder")
    used = set(roles.values())
    return roles, [k for k in captures if k not in used]


def _paths_arg(folder: Path, paths: tuple[str, ...]) -> str | list[str]:
    return str(folder / paths[0]) if len(paths) == 1 else [str(folder / p) for p in paths]


def _interval(est: Any) -> list[float] | None:
    return None if est.ci95 is None else [float(est.ci95[0]), float(est.ci95[1])]


def _identify_one(spec: ExperimentSpec, settings: BatchSettings) -> ExperimentOutcome:
    import motorid as mi
    from motorid.io import read_capture
    from motorid.report.assemble import make_report

    folder = Path(spec.folder)
    columns = spec.columns if spec.columns is not None else settings.columns
    colmap = None if columns is None else dict(columns)
    if spec.roles:
        roles, others = dict(spec.roles), list(spec.validate)
        roles_from = "experiment.toml" if (folder / "experiment.toml").is_file() else "manifest.csv"
    else:
        caps = {key: read_capture(_paths_arg(folder, key), columns=colmap) for key in spec.captures}
        roles, others = assign_roles(caps)
        roles_from = "guessed"
    paths = {role: _paths_arg(folder, p) for role, p in roles.items()}
    exp = mi.read_experiment(
        position=paths.get("position"), velocity=paths.get("velocity"), current=paths.get("current"),
        step_volts=spec.step_volts if spec.step_volts is not None else settings.step_volts,
        t0=spec.t0 if spec.t0 is not None else settings.t0,
        columns=colmap,
        force_role=settings.force_role or not spec.roles,  # guessed roles agree with the guess
        segment=spec.segment,
        counted_velocity=(spec.counted_velocity or settings.counted_velocity) and "velocity" in paths,
    )
    fit = mi.identify(exp, **settings.identify)
    warnings = [_relative(w, spec.folder) for w in fit.warnings]
    design_doc = None
    if settings.design is not None:
        try:
            design_doc = mi.design(fit, **settings.design).to_json()
        except MotorIdError as exc:
            warnings.append(_relative(f"design: {exc}", spec.folder))
    report = None
    if settings.report and not settings.lazy_reports:
        validation = {}
        if settings.validate:
            validation = {_label(k): read_capture(_paths_arg(folder, k), columns=colmap) for k in others}
        report = make_report(fit.identification, exp.captures, validation=validation, design=design_doc,
                             title=f"motorid batch: {spec.name}")
    model = fit.model
    fit_pct = fit.fit.get("velocity_fit_percent", fit.fit.get("position_fit_percent"))
    row = {
        "dc_gain": complex(fit.params["dc_gain"].value).real,
        "dc_gain_ci95": _interval(fit.params["dc_gain"]),
        "time_constant": complex(fit.params["time_constant"].value).real,
        "time_constant_ci95": _interval(fit.params["time_constant"]),
        "order": len(model.poles()),
        "method": model.method,
        "dc_gain_unit": model.dc_gain_unit,
        "fit_percent": None if fit_pct is None else float(fit_pct),
        "velocity_nrmse": fit.fit.get("velocity_nrmse"),
        "warnings": warnings,
    }
    return ExperimentOutcome(
        name=spec.name,
        status="warning" if warnings or not fit.sanity.passed else "ok",
        row=row,
        roles={**{role: _label(p) for role, p in roles.items()}, "roles_from": roles_from},
        model_json=model.to_json_text(),
        design_json=None if design_doc is None else json.dumps(design_doc, indent=2) + "\n",
        report_html=report,
    )


def _relative(message: str, folder: str) -> str:
    """A message with the experiment folder's prefix taken off its paths."""
    return message.replace(folder.rstrip("/") + "/", "")


def _one_line(message: str, folder: str) -> str:
    """The first line of a message, paths relative to the experiment folder."""
    return _relative((message.strip().splitlines() or [""])[0], folder)


def run_experiment_task(job: tuple[ExperimentSpec, BatchSettings]) -> ExperimentOutcome:
    """Identify one experiment; every failure becomes a ``failed`` outcome, never an exception.

    Parameters
    ----------
    job : tuple of (ExperimentSpec, BatchSettings)
        The experiment and the batch's settings.

    Returns
    -------
    ExperimentOutcome
        ``ok``/``warning`` with the model, or ``failed`` with the one-line reason (a user's
        error as the command line prints it; anything else as ``internal error: …``).
    """
    spec, settings = job
    t_start, cpu_start = time.perf_counter(), time.process_time()
    try:
        outcome = _identify_one(spec, settings)
    except MotorIdError as exc:
        outcome = ExperimentOutcome(spec.name, "failed", error=_one_line(str(exc), spec.folder))
    except Exception as exc:  # a bug in one experiment must not stop the class's batch
        outcome = ExperimentOutcome(spec.name, "failed",
                                    error=_one_line(f"internal error: {type(exc).__name__}: {exc}", spec.folder))
    return replace(outcome, seconds=time.perf_counter() - t_start, cpu_seconds=time.process_time() - cpu_start)

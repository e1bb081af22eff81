"""Find the experiments under a batch's roots: folders of captures, with or without a manifest.

An *experiment folder* is a folder that holds captures of one motor's step experiment:

- scope ``ALLnnnn`` folders (the TDS2000 'Save All' layout; the paper's triple is
  ``ALL0000``–``ALL0002``), Tektronix channel files ``FnnnnCH1.CSV`` + ``FnnnnCH2.CSV``
  lying loose (grouped by their ``Fnnnn`` prefix), ``.xlsx`` workbooks and plain CSV logs;
- optionally an ``experiment.toml`` or a ``manifest.csv`` naming the role of each capture
  (see :func:`read_roles_file`); without one the roles are guessed from the signals when
  the experiment is identified (:mod:`motorid.batch.task`).

A root may itself be an experiment folder, or a single capture file (a plain CSV log with
several channel columns is a whole experiment).  Sub-folders are searched too (a class's
``section/student/run`` tree); ``ALLnnnn`` folders are captures, never searched further.
Discovery only lists files: nothing is parsed here, so a corrupt capture fails its own
experiment (in the worker), not the discovery of the others.
"""

from __future__ import annotations

import csv
import hashlib
import os
import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

from motorid.errors import OptionError

__all__ = [
    "EXPERIMENT_TOML",
    "MANIFEST_CSV",
    "ExperimentSpec",
    "discover_experiments",
    "folders_without_captures",
    "read_roles_file",
]

#: Files that name the roles of an experiment folder's captures.
EXPERIMENT_TOML = "experiment.toml"
MANIFEST_CSV = "manifest.csv"
#: Suffixes of loose capture files (the readers recognise the format from the content).
CAPTURE_SUFFIXES = (".csv", ".xlsx", ".tsv")
#: Suffixes of text files that are captures only when their content reads as a log (a serial
#: monitor's ``.txt``, a logger's ``.log``/``.dat``): a student's ``notes.txt`` is not one.
TEXT_LOG_SUFFIXES = (".txt", ".log", ".dat")
#: Roles a manifest can give; ``validate`` marks validation captures (sine, triangle ...).
MANIFEST_ROLES = ("position", "velocity", "current", "validate")
#: Keys an ``experiment.toml`` may hold besides the roles.
TOML_OPTIONS = ("step_volts", "t0", "columns", "segment", "counted_velocity")

_ALL_FOLDER = re.compile(r"^ALL\d{4}$", re.IGNORECASE)
_TDS_CHANNEL = re.compile(r"^(F\d{4})CH\d\.CSV$", re.IGNORECASE)


def _reduce_frozen(obj: Any) -> tuple[Any, tuple[Any, ...]]:
    """Pickle a frozen dataclass holding read-only mappings: rebuild it from plain dicts.

    ``MappingProxyType`` cannot be pickled, and a worker process gets its tasks pickled.
    """
    values = []
    for f in fields(obj):
        v = getattr(obj, f.name)
        values.append(dict(v) if isinstance(v, MappingProxyType) else v)
    return type(obj), tuple(values)


@dataclass(frozen=True, slots=True)
class ExperimentSpec:
    """One experiment found under a root: its captures, and the roles if a file names them.

    Attributes
    ----------
    name : str
        The folder's path relative to its root (``/``-separated); the root's own name when the
        root itself is the experiment.
    folder : str
        The experiment folder (absolute); for a root that is one file, that file's folder.
    captures : tuple of tuple of str
        Each capture as its path(s) relative to ``folder``: one file or ``ALLnnnn`` folder,
        or a Tektronix CH1/CH2 pair.
    roles : Mapping[str, tuple of str]
        Roles named by ``experiment.toml``/``manifest.csv`` (``position``, ``velocity``,
        ``current`` → a capture's paths); empty: guess them.
    validate : tuple of tuple of str
        Validation captures named by the roles file.
    step_volts, t0 : float or None
        Step level [V] and step instant [s] from ``experiment.toml`` (else the batch's).
    columns : Mapping[str, str] or None
        Plain-CSV column map from ``experiment.toml``.
    segment : int or None
        The step of a several-steps velocity log to identify (``experiment.toml``'s ``segment``).
    counted_velocity : bool
        The velocity counts encoder edges over each sample interval (``experiment.toml``'s
        ``counted_velocity``; :func:`motorid.read_experiment`).
    files : tuple of str
        Every input file (relative to ``folder``) whose content the resume hash covers.
    """

    name: str
    folder: str
    captures: tuple[tuple[str, ...], ...]
    roles: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    validate: tuple[tuple[str, ...], ...] = ()
    step_volts: float | None = None
    t0: float | None = None
    columns: Mapping[str, str] | None = None
    files: tuple[str, ...] = ()
    segment: int | None = None
    counted_velocity: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "roles", MappingProxyType(dict(self.roles)))
        if self.columns is not None:
            object.__setattr__(self, "columns", MappingProxyType(dict(self.columns)))

    __reduce__ = _reduce_frozen

    def content_hash(self, settings: Mapping[str, Any]) -> str:
        """SHA-256 (hex) of the inputs' names and contents, the roles file and ``settings``.

        Parameters
        ----------
        settings : Mapping
            The batch settings that change a result (JSON-serialisable).

        Returns
        -------
        str
            Equal for a rerun on unchanged files with unchanged settings.
        """
        import json

        h = hashlib.sha256()
        h.update(json.dumps(settings, sort_keys=True, default=str).encode())
        h.update(json.dumps({"roles": dict(self.roles), "validate": self.validate, "step_volts": self.step_volts,
                             "t0": self.t0, "columns": None if self.columns is None else dict(self.columns),
                             **({"segment": self.segment} if self.segment is not None else {}),
                             **({"counted_velocity": True} if self.counted_velocity else {})},
                            sort_keys=True).encode())
        from motorid.io._common import MAX_TEXT_BYTES

        for rel in self.files:
            h.update(rel.encode() + b"\0")
            path = Path(self.folder) / rel
            st = path.stat()
            if st.st_size > MAX_TEXT_BYTES:
                # no reader takes it (refused in one line when read): not worth a minute of hashing
                h.update(f"size={st.st_size};mtime={st.st_mtime_ns}".encode())
            else:
                with open(path, "rb") as fh:
                    for block in iter(lambda: fh.read(1 << 20), b""):
                        h.update(block)
            h.update(b"\0")
        return h.hexdigest()


def _visible(p: Path) -> bool:
    return not p.name.startswith((".", "~$", "_"))


def _capture_entries(folder: Path) -> list[tuple[str, ...]]:
    """The captures lying in ``folder``: ALLnnnn folders, Tektronix pairs, workbooks, CSV logs."""
    captures: list[tuple[str, ...]] = []
    pairs: dict[str, list[str]] = {}
    for p in sorted(folder.iterdir()):
        if not _visible(p):
            continue
        if p.is_dir():
            if _ALL_FOLDER.match(p.name):
                captures.append((p.name,))
            continue
        if p.name.lower() in (MANIFEST_CSV, "summary.csv"):
            continue
        if p.suffix.lower() in TEXT_LOG_SUFFIXES:
            if _reads_as_log(p):
                captures.append((p.name,))
            continue
        if p.suffix.lower() not in CAPTURE_SUFFIXES:
            continue
        m = _TDS_CHANNEL.match(p.name)
        if m:
            pairs.setdefault(m.group(1).upper(), []).append(p.name)
        else:
            captures.append((p.name,))
    captures.extend(tuple(sorted(names)) for names in pairs.values())
    return sorted(captures)


def _reads_as_log(path: Path) -> bool:
    """Whether a text file's head is a table or log the readers take (its format from its content)."""
    from motorid.errors import MotorIdError
    from motorid.io import detect_format

    try:
        return detect_format(path) == "plain-csv"
    except (MotorIdError, OSError):
        return False


def _files_of(folder: Path, captures: Iterable[Sequence[str]]) -> list[str]:
    files: list[str] = []
    for cap in captures:
        for rel in cap:
            p = folder / rel
            if p.is_dir():
                files.extend(f"{rel}/{f.name}" for f in sorted(p.iterdir()) if f.is_file() and _visible(f))
            elif p.is_file():
                files.append(rel)
    return files


def _spec_path(value: Any, where: str) -> tuple[str, ...]:
    """A capture named in a roles file: ``"ALL0001"``, ``"F0001CH1.CSV+F0001CH2.CSV"`` or a list."""
    if isinstance(value, str):
        parts = [v.strip() for v in value.split("+") if v.strip()]
    elif isinstance(value, list) and all(isinstance(v, str) for v in value):
        parts = [v.strip() for v in value]
    else:
        raise OptionError(f"{where}: give a capture as a path relative to the folder (or a list of two "
                          f"channel files), got {value!r}")
    if not parts:
        raise OptionError(f"{where}: empty capture path")
    return tuple(parts)


def read_roles_file(folder: Path) -> dict[str, Any] | None:
    """Read ``experiment.toml`` or ``manifest.csv`` of an experiment folder, if it has one.

    ``experiment.toml``::

        position = "ALL0000"
        velocity = "ALL0001"                       # or "F0001CH1.CSV+F0001CH2.CSV"
        current = "ALL0002"
        validate = ["ALL0003", "ALL0004"]          # optional validation captures
        step_volts = 5.92                          # optional: captures without CH1
        t0 = 0.0                                   # optional: the step instant [s]
        columns = {time = "t", velocity = "rpm"}   # optional: plain-CSV column map
        segment = 2                                # optional: one step of a several-steps log
        counted_velocity = true                    # optional: the velocity counts edges per interval

    ``manifest.csv``: a header ``role,path`` and one row per capture (``role`` one of
    ``position``, ``velocity``, ``current``, ``validate``).

    Parameters
    ----------
    folder : Path
        The experiment folder.

    Returns
    -------
    dict or None
        ``roles`` (role → paths), ``validate`` (list of paths), ``step_volts``, ``t0``,
        ``columns``, ``segment``, ``counted_velocity``; ``None`` without a roles file.

    Raises
    ------
    OptionError
        A file that cannot be parsed, an unknown key or role, a capture that does not exist
        (the message names the file).
    """
    toml_path, csv_path = folder / EXPERIMENT_TOML, folder / MANIFEST_CSV
    if toml_path.is_file():
        where = str(toml_path)
        try:
            doc = tomllib.loads(toml_path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
            raise OptionError(f"not valid TOML ({exc}): fix the file or remove it to guess the roles",
                              file=where) from None
        unknown = sorted(set(doc) - set(MANIFEST_ROLES) - set(TOML_OPTIONS))
        if unknown:
            raise OptionError(f"unknown key(s) {', '.join(unknown)}: use {', '.join(MANIFEST_ROLES + TOML_OPTIONS)}",
                              file=where)
        roles = {r: _spec_path(doc[r], f"{where}: {r}") for r in MANIFEST_ROLES[:3] if r in doc}
        val = doc.get("validate", [])
        validate = [_spec_path(v, f"{where}: validate") for v in (val if isinstance(val, list) else [val])]
        out: dict[str, Any] = {"roles": roles, "validate": validate, "file": EXPERIMENT_TOML}
        for key in ("step_volts", "t0"):
            v = doc.get(key)
            if v is not None and not isinstance(v, (int, float)):
                raise OptionError(f"{key} = {v!r}: give a number", file=where)
            out[key] = None if v is None else float(v)
        cols = doc.get("columns")
        if cols is not None and not (isinstance(cols, dict) and all(isinstance(v, str) for v in cols.values())):
            raise OptionError("columns: give a table of role = column name, e.g. {time = \"t\", velocity = \"rpm\"}",
                              file=where)
        out["columns"] = cols
        seg = doc.get("segment")
        if seg is not None and (isinstance(seg, bool) or not isinstance(seg, int) or seg < 1):
            raise OptionError(f"segment = {seg!r}: give a whole number ≥ 1 (the step of a several-steps log)",
                              file=where)
        out["segment"] = seg
        counted = doc.get("counted_velocity", False)
        if not isinstance(counted, bool):
            raise OptionError(f"counted_velocity = {counted!r}: give true or false", file=where)
        if counted and "velocity" not in roles:
            raise OptionError("counted_velocity = true describes a velocity capture: name it with velocity = ...",
                              file=where)
        out["counted_velocity"] = counted
    elif csv_path.is_file():
        where = str(csv_path)
        with open(csv_path, newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.DictReader(fh))
        if not rows or not {"role", "path"} <= {(k or "").strip().lower() for k in rows[0]}:
            raise OptionError("needs a header row 'role,path' and one row per capture", file=where)
        roles, validate = {}, []
        for i, row in enumerate(rows, start=2):
            row = {(k or "").strip().lower(): (v or "").strip() for k, v in row.items()}
            role = row["role"].lower()
            if role not in MANIFEST_ROLES:
                raise OptionError(f"role {row['role']!r} is not one of {', '.join(MANIFEST_ROLES)}", file=where, row=i)
            spec = _spec_path(row["path"], f"{where}:{i}")
            if role == "validate":
                validate.append(spec)
            elif role in roles:
                raise OptionError(f"role {role} given twice: one capture per role", file=where, row=i)
            else:
                roles[role] = spec
        out = {"roles": roles, "validate": validate, "step_volts": None, "t0": None, "columns": None,
               "segment": None, "counted_velocity": False, "file": MANIFEST_CSV}
    else:
        return None
    if not (set(out["roles"]) & {"position", "velocity"}):
        raise OptionError("names no velocity or position capture: name at least one", file=where)
    for spec in [*out["roles"].values(), *out["validate"]]:
        for rel in spec:
            if not (folder / rel).exists():
                raise OptionError(f"names {rel}, which does not exist in {folder}", file=where)
    return out


def _spec_for(root: Path, folder: Path, name: str, captures: list[tuple[str, ...]]) -> ExperimentSpec:
    roles_file = read_roles_file(folder)
    if roles_file is None:
        return ExperimentSpec(name, str(folder), tuple(captures), files=tuple(_files_of(folder, captures)))
    named = [*roles_file["roles"].values(), *roles_file["validate"]]
    files = [*_files_of(folder, named), roles_file["file"]]
    return ExperimentSpec(
        name, str(folder), tuple(dict.fromkeys(named)), roles=roles_file["roles"],
        validate=tuple(roles_file["validate"]), step_volts=roles_file["step_volts"], t0=roles_file["t0"],
        columns=roles_file["columns"], files=tuple(files), segment=roles_file["segment"],
        counted_velocity=roles_file["counted_velocity"],
    )


def _walk(root: Path, skip: Path | None) -> Iterable[tuple[Path, list[tuple[str, ...]]]]:
    """Experiment folders under ``root`` (depth first, sorted), with their loose captures.

    Each real folder is visited once and only inside the root: a symlink to ``.`` or ``..``, or
    one out of the root, is not followed (a student's link would make the walk loop, grow
    exponentially or leave the class's folder).
    """
    root_real = root.resolve()
    seen: set[Path] = set()
    stack = [root]
    while stack:
        folder = stack.pop()
        real = folder.resolve()
        if real in seen or (real != root_real and root_real not in real.parents):
            continue
        seen.add(real)
        if skip is not None and real == skip:
            continue
        entries = _capture_entries(folder)
        if entries or (folder / EXPERIMENT_TOML).is_file() or (folder / MANIFEST_CSV).is_file():
            yield folder, entries
        subs = [p for p in sorted(folder.iterdir(), reverse=True)
                if p.is_dir() and _visible(p) and not _ALL_FOLDER.match(p.name)]
        stack.extend(subs)


def folders_without_captures(roots: Sequence[str | os.PathLike[str]], *,
                             skip: str | os.PathLike[str] | None = None) -> list[tuple[str, tuple[str, ...]]]:
    """Folders under the roots that hold files but no capture and no experiment below them.

    A student who handed in a photo of the scope, a ``.pdf`` or a log in a format no reader takes
    would otherwise be missing from the summary without a word.

    Parameters
    ----------
    roots : sequence of paths
        The batch's roots (files among them are ignored).
    skip : path, optional
        A folder not to search (the batch's output).

    Returns
    -------
    list of (str, tuple of str)
        Each such folder by its path relative to its root, with the names of up to five of its files.
    """
    skip_path = None if skip is None else Path(skip).resolve()
    out: list[tuple[str, tuple[str, ...]]] = []
    for raw in roots:
        root = Path(raw).absolute()
        if not root.is_dir() or _ALL_FOLDER.match(root.name):
            continue
        with_experiments = {folder.resolve() for folder, _ in _walk(root, skip_path)}
        for folder in sorted(p for p in root.rglob("*") if p.is_dir() and _visible(p)):
            if (any(part.startswith((".", "~$", "_")) for part in folder.relative_to(root).parts)
                    or _ALL_FOLDER.match(folder.name) or any(_ALL_FOLDER.match(part) for part in folder.parts)):
                continue
            real = folder.resolve()
            if real in with_experiments or any(e == real or real in e.parents for e in with_experiments):
                continue
            if skip_path is not None and (real == skip_path or skip_path in real.parents):
                continue
            files = tuple(sorted(f.name for f in folder.iterdir() if f.is_file() and _visible(f)))
            if files:
                out.append((folder.relative_to(root).as_posix(), files[:5]))
    return out


def discover_experiments(roots: Sequence[str | os.PathLike[str]], *, skip: str | os.PathLike[str] | None = None
                         ) -> list[ExperimentSpec]:
    """Every experiment under the roots, sorted by name.

    Parameters
    ----------
    roots : sequence of paths
        Folders to search (or single capture files, each an experiment).
    skip : path, optional
        A folder not to search (the batch's own output folder when it lies under a root).

    Returns
    -------
    list of ExperimentSpec
        Named by their path relative to their root; when two roots give the same name, each
        such name is prefixed with its root's folder name.

    Raises
    ------
    OptionError
        A root that does not exist, a roles file that cannot be used, no experiment found,
        or two experiments still named alike.
    """
    if not roots:
        raise OptionError("give at least one ROOT folder to search for experiments")
    skip_path = None if skip is None else Path(skip).resolve()
    found: list[tuple[Path, ExperimentSpec]] = []
    for raw in roots:
        root = Path(raw)
        if not root.exists():
            raise OptionError("no such folder or file: give the folder that holds the experiments", file=str(root))
        root = root.absolute()
        if root.is_file():
            found.append((root, ExperimentSpec(root.stem, str(root.parent), ((root.name,),), files=(root.name,))))
            continue
        if _ALL_FOLDER.match(root.name):
            # one scope folder alone: a velocity (or position) capture, its roles guessed
            found.append((root, ExperimentSpec(root.name, str(root.parent), ((root.name,),),
                                               files=tuple(_files_of(root.parent, [(root.name,)])))))
            continue
        for folder, entries in _walk(root, skip_path):
            rel = folder.relative_to(root).as_posix()
            found.append((root, _spec_for(root, folder, root.name if rel == "." else rel, entries)))
    if not found:
        where = ", ".join(str(r) for r in roots)
        raise OptionError(f"no experiments found under {where}: give folders holding ALLnnnn folders, "
                          "Tektronix/plain CSV captures or .xlsx workbooks")
    names = [spec.name for _, spec in found]
    clash = {n for n in names if names.count(n) > 1}
    if clash:
        found = [(r, _renamed(s, f"{r.name}/{s.name}") if s.name in clash else s) for r, s in found]
        names = [spec.name for _, spec in found]
        still = sorted({n for n in names if names.count(n) > 1})
        if still:
            raise OptionError(f"two experiments are both named {still[0]!r}: give roots with different names")
    return sorted((s for _, s in found), key=lambda s: s.name)


def _renamed(spec: ExperimentSpec, name: str) -> ExperimentSpec:
    return replace(spec, name=name)

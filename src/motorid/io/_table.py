"""A capture from a table of named columns (plain CSV logs, spreadsheets without scope blocks).

Private to :mod:`motorid.io`.  Decides which column is the time, the step input and the
measured output — from a user's mapping (``--columns time=t,input=u,velocity=rpm``) or by
keywords in the header names — and builds the :class:`~motorid.capture.Capture`.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from motorid.capture import ROLES, Capture, ChannelInfo
from motorid.errors import CaptureFormatError, OptionError
from motorid.io._common import check_time_steps, column_to_floats, parse_number, uniform_grid
from motorid.io._counts import count_lattice

__all__ = ["COLUMN_KEYS", "TIME_UNITS", "capture_from_table", "check_role", "classify_name", "parse_column_map",
           "role_from_name"]

#: The keys a column mapping may use.
COLUMN_KEYS: tuple[str, ...] = ("time", "input", "position", "velocity", "current", "output")


def parse_column_map(spec: str | Mapping[str, str] | None) -> dict[str, str] | None:
    """A column map from ``--columns``' text (``time=t,input=u,velocity=rpm``) or a mapping.

    The command line, the Python front door and the web form read the map with this one
    function, so a Python caller may pass the command line's text too.

    Parameters
    ----------
    spec : str, Mapping[str, str] or None
        ``ROLE=COLUMN`` pairs separated by commas, or the mapping itself.

    Returns
    -------
    dict or None
        Role → column name; None for nothing given.

    Raises
    ------
    OptionError
        A pair that is not ``ROLE=COLUMN``, or a mapping whose keys or values are not text.

    Examples
    --------
    >>> parse_column_map("time=1, input=2,velocity=3")
    {'time': '1', 'input': '2', 'velocity': '3'}
    """
    if spec is None or (isinstance(spec, str) and not spec.strip()):
        return None
    if isinstance(spec, str):
        mapping: dict[str, str] = {}
        for part in spec.split(","):
            key, sep, value = part.partition("=")
            if not sep or not key.strip() or not value.strip():
                raise OptionError(f"--columns: {part!r} is not ROLE=COLUMN (e.g. time=t,input=u,velocity=rpm)")
            mapping[key.strip()] = value.strip()
        return mapping
    if not isinstance(spec, Mapping) or not all(isinstance(k, str) and isinstance(v, str) for k, v in spec.items()):
        raise OptionError(f"--columns: give ROLE=COLUMN text or a mapping of text to text, not {spec!r}")
    return dict(spec) or None

# Keywords per category.  "Long" keywords match anywhere in the lower-cased name (German
# compounds such as "Motorspannung", "Sollgeschwindigkeit"); "short" ones must be a whole
# token of the name split at non-letters ("t", "u", "pos"), so that "t" does not match "tacho".
_SETPOINT = (("setpoint", "soll", "reference", "target", "demand"), ("ref", "sp", "cmd", "command", "r"))
_KEYWORDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "time": (("time", "zeit", "timestamp"), ("t", "sec", "secs", "seconds", "s", "ms", "millis", "us", "micros")),
    "velocity": (("speed", "velocity", "tacho", "geschwindigkeit", "drehzahl", "omega"), ("rpm", "vel")),
    "position": (("position", "angle", "theta", "encoder", "winkel"), ("pos", "phi", "enc", "deg")),
    "current": (("current", "strom"), ("ia", "amp", "amps", "ampere")),
    "output": (("output", "response"), ("y", "out", "ch2")),
    "input": (("input", "voltage", "volt", "spannung", "step", "pwm", "duty", "power"),
              ("u", "vin", "ch1", "uin", "ua")),
}
# Checked in this order: a setpoint is never the input; "tacho_voltage" is a velocity, not
# the input; "time" first so that "t" is taken before the other categories look at it.
_ORDER = ("time", "velocity", "position", "current", "output", "input")

_TIME_SCALE = {"ms": 1e-3, "millis": 1e-3, "msec": 1e-3, "us": 1e-6, "micros": 1e-6, "usec": 1e-6}
#: ``time_unit`` values (the ``--time-unit`` option, or ``time_unit`` in a column map): seconds per unit.
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
#: An unlabelled time column of whole numbers stepping by this much or more is not in seconds (a
#: motor logged once a second or slower shows nothing); up to :data:`MS_STEP_MAX` it is read as
#: milliseconds (``millis()``), beyond it could be ms or µs and the user is asked.
MS_STEP_MIN, MS_STEP_MAX = 1.0, 100.0
#: ... and up to this step it could be ms or µs (larger steps are neither: the range check refuses).
MS_TO_US_MAX = 1e4
_UNITS = {"v": "V", "volt": "V", "volts": "V", "mv": "mV", "a": "A", "amp": "A", "amps": "A", "ma": "mA",
          "rpm": "rpm", "deg": "deg", "rad": "rad",
          "raw": "raw", "counts": "counts", "s": "s", "ms": "ms"}


def _tokens(name: str) -> list[str]:
    return [t for t in re.split(r"[^0-9a-zäöüß]+", name.lower()) if t]


def _matches(name: str, words: tuple[tuple[str, ...], tuple[str, ...]], *, first_token_only: bool = False) -> bool:
    low = name.lower()
    long_words, short_words = words
    toks = _tokens(name)
    if first_token_only:
        toks = toks[:1]
    return any(w in low for w in long_words) or any(t in short_words for t in toks)


def classify_name(name: str) -> str | None:
    """The category a column name suggests.

    Returns
    -------
    str or None
        ``"setpoint"``, one of ``time``/``velocity``/``position``/``current``/``output``/
        ``input``, or ``None`` when no keyword matches.
    """
    if _matches(name, _SETPOINT):
        return "setpoint"
    toks = _tokens(name)
    if len(toks) > 1 and toks[0] == "i":
        return "current"  # "i_a", "I motor"; a lone "i" is a loop index, not a current
    for cat in _ORDER:
        # A unit token names a time column only in front ("t_ms", "s"): "speed_s" is a speed.
        if _matches(name, _KEYWORDS[cat], first_token_only=cat == "time"):
            return cat
    return None


def role_from_name(name: str) -> str | None:
    """The output role (:data:`~motorid.capture.ROLES`) a channel label names, if any."""
    cat = classify_name(name)
    return cat if cat in ROLES else None


def check_role(role: str | None) -> str | None:
    """Check a user-declared role.

    Raises
    ------
    OptionError
        When ``role`` is not one of :data:`~motorid.capture.ROLES`.
    """
    if role is not None and role not in ROLES:
        raise OptionError(f"role {role!r} is not one of {', '.join(ROLES)}")
    return role


#: Column names that are a unit and nothing else (a log's ``rpm`` column is in rpm).
_UNIT_NAMES = {"rpm": "rpm", "counts": "counts", "deg": "deg", "degrees": "deg", "rad": "rad", "radians": "rad"}


#: Tokens of a column name that say its values are not volts: a duty cycle in percent, a duty
#: cycle as a fraction, a PWM register's counts (an Arduino's ``analogWrite`` value).  A gain is
#: then per %, per unit of duty or per count, and is labelled so.
_PERCENT_TOKENS, _NOT_VOLTS = ("pct", "percent"), {"duty": "duty", "pwm": "pwm"}


def _units_from_name(name: str) -> str:
    bracket = re.search(r"[\[(]\s*([^\])]+?)\s*[\])]\s*$", name)
    if bracket:
        return bracket.group(1)
    unit = _unit_words(name)
    if unit:
        return unit
    low = _tokens(name)
    if "%" in name or any(t in _PERCENT_TOKENS for t in low):
        return "%"
    return next((_NOT_VOLTS[t] for t in low if t in _NOT_VOLTS), "")


#: Quantities a rate is written of at the end of a name: ``omega_rad_s``, ``speed_deg_per_s``.
_PER_SECOND = {"rad": "rad/s", "deg": "deg/s", "rev": "rev/s", "counts": "counts/s", "ticks": "ticks/s", "m": "m/s",
               "mm": "mm/s"}
#: Rates written as one word.
_RATE_WORDS = {"rps": "rev/s", "dps": "deg/s", "radps": "rad/s", "cps": "counts/s"}


def _unit_words(name: str) -> str:
    """A unit the name spells as words of its own: ``rpm``, ``speed_rpm``, ``u_V``, ``omega_rad_s``.

    A rate is read whole (``omega_rad_s`` is rad/s, not seconds: the last word alone would say
    ``s``).
    """
    if name.strip().lower() in _UNIT_NAMES:
        return _UNIT_NAMES[name.strip().lower()]
    toks = [t.lower() for t in re.split(r"[_\s]+", name.strip()) if t]
    if len(toks) > 1 and toks[-1] in ("s", "sec"):
        quantity = toks[-3] if toks[-2] == "per" and len(toks) > 2 else toks[-2]
        if quantity in _PER_SECOND:
            return _PER_SECOND[quantity]
    if len(toks) > 1 and toks[-1] in _RATE_WORDS:
        return _RATE_WORDS[toks[-1]]
    if len(toks) > 1 and toks[-1] in _UNITS:
        return _UNITS[toks[-1]]
    return ""


def _time_scale(name: str) -> float | None:
    """Seconds per unit of a time column, from its name; None when the name does not say.

    ms or µs: ``t_ms``, ``time [ms]``, ``(us)``, ``µs``, ``millis``; seconds: ``time_s``, ``t [s]``,
    ``seconds``.
    """
    for tok in _tokens(name.replace("µ", "u").replace("μ", "u")):
        if tok in _TIME_SCALE:
            return _TIME_SCALE[tok]
        if tok in ("s", "sec", "secs", "seconds"):
            return 1.0
    return None


def _time_column(raw: np.ndarray, name: str, time_unit: str | None, file: str, where: str) -> tuple[np.ndarray, str]:
    """The time column in seconds, and a note when its unit was inferred from its values.

    An explicit ``time_unit`` wins; then the unit in the column's name; then a column of whole
    numbers stepping by at least :data:`MS_STEP_MIN` is milliseconds when the step is at most
    :data:`MS_STEP_MAX` (said in the note) and refused otherwise; anything else is seconds.
    """
    if time_unit is not None:
        if time_unit not in TIME_UNITS:
            raise OptionError(f"--time-unit (time_unit) must be one of {', '.join(TIME_UNITS)}, not {time_unit!r}")
        return raw * TIME_UNITS[time_unit], ""
    scale = _time_scale(name)
    if scale is not None:
        return raw * scale, ""
    steps = np.diff(raw[: min(raw.size, 10_000)])
    step = float(np.median(steps)) if steps.size else 0.0
    if not MS_STEP_MIN <= step <= MS_TO_US_MAX:
        return raw, ""  # decided without the whole-number test (a copy of a 10 M-row column)
    whole = raw.size > 1 and bool(np.all(np.isfinite(raw))) and bool(np.all(raw == np.round(raw)))
    if not whole:
        return raw, ""
    if step <= MS_STEP_MAX:
        return raw * 1e-3, (f"{where} {name!r} holds whole numbers stepping by {step:g}, no unit in its name: "
                            "read as milliseconds (a motor logged every second or slower would show nothing); give "
                            "--time-unit s if they are seconds")
    raise CaptureFormatError(
        f"{where} {name!r} holds whole numbers stepping by {step:g} and its name gives no unit: milliseconds or "
        "microseconds? Give --time-unit ms or --time-unit us (or name the column t_ms / t_us)", file=file)


@dataclass(frozen=True, slots=True)
class _Assignment:
    """Column index of each category chosen."""

    time: int
    input: int | None
    output: int
    role_hint: str | None
    role_columns: dict[str, int]  # further role columns (position when output is velocity…)


def _column_list(names: Sequence[str], limit: int = 12) -> str:
    """The header names for a message: quoted, each cut to 30 characters, at most ``limit``."""
    shown = [repr(n if len(n) <= 30 else n[:29] + "…") for n in names[:limit]]
    more = f", … ({len(names)} columns)" if len(names) > limit else ""
    return ", ".join(shown) + more


#: A time stamp written as a date and time (``2024-05-01 12:00:00.010``, ISO 8601) or a time of day
#: (``12:00:00.010``), as loggers that stamp with the clock write it.
DATETIME_CELL = re.compile(r"^\s*(\d{4}-\d{2}-\d{2}[ T])?\d{1,2}:\d{2}:\d{2}(\.\d+)?\s*$")


def _clock_seconds(col: Sequence[object] | np.ndarray, name: str, rows: Sequence[int] | np.ndarray, file: str,
                   where: str) -> tuple[np.ndarray, str]:
    """A column of clock stamps as seconds from its first one, and the note that says so.

    numpy parses ISO 8601 (a date and a time, or a time of day on the epoch's date) to
    microseconds; a cell it cannot read is named by its line.
    """
    text = [str(c).strip() for c in col]
    if "-" not in text[0]:  # times of day: on the epoch's date
        text = ["1970-01-01T" + c for c in text]
    try:
        stamps = np.array(text).astype("datetime64[us]")
    except ValueError:
        bad = next(i for i, c in enumerate(text) if not DATETIME_CELL.match(c.removeprefix("1970-01-01T")))
        raise CaptureFormatError(f"{where} {name!r}: cannot read {str(col[bad])[:40]!r} as a date and time like "
                                 f"the first stamp {str(col[0]).strip()!r}", file=file, row=int(rows[bad])) from None
    seconds = (stamps - stamps[0]).astype(np.int64) / 1e6
    return seconds, (f"{where} {name!r} holds clock stamps: read as seconds from its first, "
                     f"{str(col[0]).strip()}")


#: A unit in brackets at the end of a column name.
_UNIT_SUFFIX = re.compile(r"\s*[\[(][^\])]*[\])]\s*$")


def _resolve_mapping(
    names: Sequence[str], columns: Mapping[str, str] | None, file: str
) -> dict[str, int]:
    if not columns:
        return {}
    available = _column_list(names)
    out: dict[str, int] = {}
    for key, col in columns.items():
        if key not in COLUMN_KEYS:
            raise OptionError(
                f"unknown column role {key!r}: use {', '.join(COLUMN_KEYS)}, or time_unit=s|ms|us (columns: "
                f"{available})",
                file=file,
            )
        idx = [i for i, n in enumerate(names) if n == col]
        if not idx:
            idx = [i for i, n in enumerate(names) if n.lower() == str(col).strip().lower()]
        if not idx:
            # the name without its unit: "Time" for "Time (ms)", "speed" for "speed [rpm]"
            idx = [i for i, n in enumerate(names)
                   if _UNIT_SUFFIX.sub("", n).strip().lower() == str(col).strip().lower()]
        if len(idx) != 1:
            why = "is not a column" if not idx else "names several columns"
            raise OptionError(f"{key}={col!r} {why} of this file; available columns: {available}", file=file)
        if idx[0] in out.values():
            raise OptionError(f"column {col!r} is mapped to two roles", file=file)
        out[key] = idx[0]
    return out


def _assign(
    names: Sequence[str], numeric: Sequence[bool], mapping: dict[str, int], role: str | None, file: str
) -> _Assignment:
    used = set(mapping.values())
    cats: dict[str | None, list[int]] = {c: [] for c in (*_ORDER, "setpoint", None)}
    for i, n in enumerate(names):
        if i not in used and numeric[i]:
            cats[classify_name(n)].append(i)

    def pick(cat: str) -> int | None:
        if cat in mapping:
            return mapping[cat]
        return cats[cat][0] if cats[cat] else None

    available = _column_list(names)
    time = pick("time")
    if time is None:
        raise CaptureFormatError(
            f"no time column among {available}: name it 'time' or map it with --columns time=NAME",
            file=file,
        )
    role_cols = {r: c for r in ROLES if (c := pick(r)) is not None and c != time}
    generic = pick("output")
    inp = pick("input")
    hint: str | None
    if role is not None and role in role_cols:
        output, hint = role_cols[role], role
    elif "output" in mapping:
        output, hint = mapping["output"], role
    elif mapped := [r for r in ("velocity", "position", "current") if r in mapping]:
        # a role the user mapped by name wins over one guessed from the other names
        output, hint = mapping[mapped[0]], role or mapped[0]
    else:
        first = next((r for r in ("velocity", "position", "current") if r in role_cols), None)
        if first is not None:
            output, hint = role_cols[first], role or first
        elif generic is not None:
            output, hint = generic, role
        else:
            rest = [i for i in cats[None] if i not in (time, inp)]
            if len(rest) == 1:
                output, hint = rest[0], role
            elif inp is not None and not rest and "input" not in mapping:
                # "time, value": a lone channel is the measured quantity, not the step.
                output, inp, hint = inp, None, role
            else:
                # an example with this file's own names (a PicoScope's "Channel A", "Channel B")
                bare = [_UNIT_SUFFIX.sub("", names[i]).strip() for i in ([inp] if inp is not None else []) + rest]
                example = (f", e.g. --columns \"input={bare[0]},velocity={bare[1]}\"" if inp is None and len(bare) >= 2
                           else f", e.g. --columns \"velocity={bare[-1]}\"" if bare else "")
                raise CaptureFormatError(
                    f"cannot tell which column is the measured output among {available}: "
                    f"map it with --columns velocity=NAME (or position=, current=, output=){example}",
                    file=file,
                )
    if inp == output:
        inp = None
    role_cols = {r: c for r, c in role_cols.items() if c not in (output, inp)}
    return _Assignment(time, inp, output, hint, role_cols)


def capture_from_table(
    names: Sequence[str],
    cells: Sequence[Sequence[object] | np.ndarray],
    rows: Sequence[int] | np.ndarray,
    *,
    file: str,
    fmt: str,
    columns: Mapping[str, str] | None = None,
    role: str | None = None,
    decimal_comma: bool = False,
    warnings: Sequence[str] = (),
    where: str = "column",
) -> Capture:
    """Build a capture from header names and their cell columns.

    Parameters
    ----------
    names : sequence of str
        Header names, one per column.
    cells : sequence of sequences
        ``cells[j][i]`` is column ``j`` at sample ``i`` (text or numbers).
    rows : sequence of int
        1-based file row of each sample (for error messages).
    file, fmt : str
        Source file name and the capture's ``format``.
    columns : Mapping[str, str], optional
        Role → column name (keys :data:`COLUMN_KEYS`); unmapped roles are guessed.
    role : str, optional
        The output's role when the user declares it.
    decimal_comma : bool
        Cells use a decimal comma.
    warnings : sequence of str
        Warnings to carry into the capture.
    where : str
        How a column is named in messages (``"column"``).

    Returns
    -------
    Capture

    Raises
    ------
    OptionError
        Unknown mapping key, a mapped column not in the header, an invalid role.
    CaptureFormatError
        No time or output column, a non-numeric cell (naming the row).
    CaptureDataError
        NaN, non-increasing or non-uniform time (naming the row).
    """
    check_role(role)
    names = [str(n).strip() for n in names]
    columns = dict(columns or {})
    time_unit = columns.pop("time_unit", None)
    mapping = _resolve_mapping(names, columns, file)
    # A column of clock stamps (a logger's date and time) is the time in seconds from its first stamp
    clock_notes: list[str] = []
    cells = list(cells)
    for j, col in enumerate(cells):
        if (len(col) > 0 and isinstance(col[0], str) and DATETIME_CELL.match(col[0])
                and (classify_name(names[j]) == "time" or mapping.get("time") == j)):
            cells[j], note = _clock_seconds(col, names[j], rows, file, where)
            clock_notes.append(note)
    # A column is numeric when its first cell is a number; then all of it must be (checked
    # when converting), else the column is text (a date, a comment) and is left out.
    numeric = [len(col) > 0 and parse_number(col[0], decimal_comma=decimal_comma) is not None for col in cells]
    asg = _assign(names, numeric, mapping, role, file)

    def values(j: int) -> np.ndarray:
        return column_to_floats(cells[j], rows, file=file, what=f"{where} {names[j]!r}", decimal_comma=decimal_comma)

    time_s, time_note = _time_column(values(asg.time), names[asg.time], time_unit, file, where)
    output = values(asg.output)
    inp = None if asg.input is None else values(asg.input)
    checked = {names[asg.output]: output}
    if asg.input is not None and inp is not None:
        checked[names[asg.input]] = inp
    extra: dict[str, np.ndarray] = {}
    for r, j in asg.role_columns.items():
        extra[r] = checked[names[j]] = values(j)
    taken = {asg.time, asg.output, asg.input, *asg.role_columns.values()}
    for j, name in enumerate(names):
        if j in taken or not numeric[j]:
            continue
        key = name or f"column{j + 1}"
        while key in extra:
            key += "_"
        extra[key] = values(j)
    steps = check_time_steps(time_s, {f"{where} {k!r}": v for k, v in checked.items()}, file=file,
                             line_of=lambda i: int(rows[i]) if 0 <= i < len(rows) else None,
                             time_name=f"{where} {names[asg.time]!r}", jitter_ok=True)
    notes = list(warnings) + clock_notes + ([time_note] if time_note else [])
    # on the stamps and values as logged: resampling would blur the counts
    counts = count_lattice(time_s, output)
    time_s, output, inp, extra, grid_note, resolution = uniform_grid(time_s, output, inp, extra, file=file,
                                                                     steps=steps)
    if grid_note:
        notes.append(grid_note)
    role_keys = set(asg.role_columns)
    for key, v in extra.items():
        if key in role_keys:
            continue
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            # a column no model uses may hold gaps; say so rather than refuse the file
            notes.append(f"{where} {key!r} has {bad.size} value(s) that are not finite numbers "
                         f"(first at line {rows[int(bad[0])]}); it is not used")

    def info(j: int) -> ChannelInfo:
        return ChannelInfo(name=names[j], units=_units_from_name(names[j]))

    return Capture.adopt(
        source=file,
        format=fmt,
        time_s=time_s,
        output_v=output,
        output_info=info(asg.output),
        input_v=inp,
        input_info=None if asg.input is None else info(asg.input),
        role_hint=asg.role_hint,
        extra=extra,
        warnings=tuple(notes),
        stamp_resolution_s=resolution,
        count_step=counts.step,
        count_over_stamps=counts.over_stamps,
        count_hold=counts.hold,
        # a speed counted over the interval its own clock measured (no sampled reading is whole counts
        # so) is read as counted on every path that reads it: each value the mean over its interval
        sample_window_s=(float(np.median(np.diff(time_s))) if counts.over_stamps and role in (None, "velocity")
                         and asg.role_hint in (None, "velocity") else 0.0),
    )

"""Front-panel settings sent to a TDS1000/2000/TBS1000 before an acquisition (``acquire --apply-advice``).

The settings come from the advice JSON's ``combined.settings`` (``motorid advise --json``): volts/div
of each channel (keyed by what the channel measures), time/div, the trigger position and Average
mode.  The commands are the TDS1000/TDS2000 Programmer Manual's: ``CH<x>:SCAle``,
``HORizontal:MAIn:SCAle``, ``HORizontal:MAIn:POSition`` (the time from the trigger point to the
centre of the screen: a trigger at ``p`` of the 10 divisions is ``(0.5 − p)·10·time/div`` from the
centre), ``ACQuire:MODe SAMple|AVErage`` and ``ACQuire:NUMAVg``.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from motorid.errors import ModelFormatError, OptionError
from motorid.io.jsonfile import read_json

__all__ = ["AVERAGE_COUNTS", "ScopeSetup", "apply_setup", "read_advice_setup"]

#: ``ACQuire:NUMAVg`` values of the TDS1000/2000 (1: Sample mode).
AVERAGE_COUNTS: tuple[int, ...] = (1, 4, 16, 64, 128)


def _scpi_number(value: float) -> str:
    return f"{float(value):.6g}"


@dataclass(frozen=True, slots=True)
class ScopeSetup:
    """Settings to send to the scope.

    Attributes
    ----------
    volts_per_div : Mapping[int, float]
        Vertical scale by channel number.
    time_per_div_s : float or None
        Horizontal scale (``None``: leave it).
    trigger_position_pct : float or None
        Part of the record before the trigger point, % (``None``: leave it).
    averages : int or None
        1 for Sample mode, 4–128 for Average mode (``None``: leave it).
    """

    volts_per_div: Mapping[int, float] = field(default_factory=dict)
    time_per_div_s: float | None = None
    trigger_position_pct: float | None = None
    averages: int | None = None

    def __post_init__(self) -> None:
        if any(not (isinstance(v, (int, float)) and v > 0) for v in self.volts_per_div.values()):
            raise OptionError(f"volts/div must be > 0, got {dict(self.volts_per_div)!r}")
        if self.time_per_div_s is not None and not self.time_per_div_s > 0:
            raise OptionError(f"time/div must be > 0, got {self.time_per_div_s!r}")
        if self.trigger_position_pct is not None and not 0.0 <= self.trigger_position_pct < 100.0:
            raise OptionError(f"trigger position must be within 0 and 100 %, got {self.trigger_position_pct!r}")
        if self.averages is not None and self.averages not in AVERAGE_COUNTS:
            raise OptionError(f"averages must be one of {', '.join(map(str, AVERAGE_COUNTS))}, got {self.averages!r}")

    def commands(self) -> tuple[str, ...]:
        """The SCPI commands, in the order they are sent (horizontal first: the position is in its time).

        Returns
        -------
        tuple of str
            ``HORizontal:MAIn:SCAle``, ``HORizontal:MAIn:POSition``, ``CH<n>:SCAle``,
            ``ACQuire:MODe`` and ``ACQuire:NUMAVg`` as needed.
        """
        out: list[str] = []
        if self.time_per_div_s is not None:
            out.append(f"HORizontal:MAIn:SCAle {_scpi_number(self.time_per_div_s)}")
            if self.trigger_position_pct is not None:
                pos = (0.5 - self.trigger_position_pct / 100.0) * 10.0 * self.time_per_div_s
                out.append(f"HORizontal:MAIn:POSition {_scpi_number(pos)}")
        for n, v in sorted(self.volts_per_div.items()):
            out.append(f"CH{n}:SCAle {_scpi_number(v)}")
        if self.averages is not None:
            if self.averages == 1:
                out.append("ACQuire:MODe SAMple")
            else:
                out += ["ACQuire:MODe AVErage", f"ACQuire:NUMAVg {self.averages}"]
        return tuple(out)


def apply_setup(inst: Any, setup: ScopeSetup) -> tuple[str, ...]:
    """Send the settings to the scope.

    Parameters
    ----------
    inst : Instrument
        An open message-based resource.
    setup : ScopeSetup
        The settings.

    Returns
    -------
    tuple of str
        The commands sent.
    """
    commands = setup.commands()
    for command in commands:
        inst.write(command)
    return commands


def read_advice_setup(path: Path, channel_roles: Mapping[int, str]) -> tuple[ScopeSetup, dict[str, Any]]:
    """The combined settings of an advice JSON, on the channels that carry each role.

    Parameters
    ----------
    path : Path
        ``motorid advise --json``'s output.
    channel_roles : Mapping[int, str]
        What each acquired channel measures (``input``, ``velocity``…).

    Returns
    -------
    (ScopeSetup, dict)
        The settings by channel number, and the advice's ``combined.settings`` as read.

    Raises
    ------
    OptionError
        A missing file, a volts/div for a channel not acquired or not named by ``--role``.
    ModelFormatError
        Not an advice JSON.
    """
    doc = read_json(path, "advice")
    settings = (doc.get("combined") or {}).get("settings") if isinstance(doc, dict) else None
    if not isinstance(settings, dict) or not isinstance(settings.get("volts_per_div"), dict):
        raise ModelFormatError("not an advice JSON (motorid advise --json): no combined.settings.volts_per_div",
                               file=str(path))
    by_role = {role: n for n, role in channel_roles.items()}
    vpd: dict[int, float] = {}
    for role, value in settings["volts_per_div"].items():
        if role not in by_role:
            raise OptionError(f"the advice sets the {role} channel's volts/div, but no acquired channel is {role}: "
                              f"give --role CH<n>={role}", file=str(path))
        vpd[by_role[role]] = _number(value, f"volts_per_div.{role}", path)
    try:
        setup = ScopeSetup(
            volts_per_div=vpd,
            time_per_div_s=_number(settings["time_per_div_s"], "time_per_div_s", path)
            if "time_per_div_s" in settings else None,
            trigger_position_pct=_number(settings["trigger_position_pct"], "trigger_position_pct", path)
            if "trigger_position_pct" in settings else None,
            averages=int(_number(settings["averages"], "averages", path)) if "averages" in settings else None,
        )
    except OptionError as exc:
        raise OptionError(exc.message, file=str(path)) from None
    return setup, settings


def _number(value: object, key: str, path: Path) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ModelFormatError(f"combined.settings.{key} must be a number, got {value!r}", file=str(path))
    return float(value)

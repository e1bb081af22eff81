"""Physical units of a model's channels: what the volts mean.

A scope records volts; a plain-CSV log may record rpm (``speed_rpm``), rad/s or amperes. The
model stays in the units of the data (volts in, data units out: docs/formats.md's model), and
carries two things beside it:

- ``units``: the unit of each channel's data (``{"velocity": "rpm"}``), from the column name
  or ``--units velocity=rpm``; the DC gain then reads ``245.8 rpm/V``, not ``245.8 V/V``;
- ``scales``: a sensor constant that turns a channel's volts into a physical quantity
  (``--scale velocity=0.1504V/(rad/s)``: a tachogenerator; ``current=0.47ohm``: a shunt;
  ``position=20V/rev``: a potentiometer span), so that the gain is also given per physical
  unit (``6.02 (rad/s)/V``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from motorid.errors import OptionError

__all__ = [
    "UNIT_GRAMMAR",
    "ChannelScale",
    "channel_unit",
    "check_unit",
    "dc_gain_unit",
    "parse_scales",
    "parse_units",
    "physical_gain",
    "units_of",
]

CHANNELS = ("position", "velocity", "current")
#: Shunt: ``0.47ohm`` means 0.47 V per A.
_OHM = re.compile(r"^\s*([-+0-9.eE]+)\s*(?:ohm|Ω)\s*$", re.IGNORECASE)
#: ``0.1504V/(rad/s)``, ``20V/rev``, ``2.5 V/krpm``.
_PER = re.compile(r"^\s*([-+0-9.eE]+)\s*V\s*/\s*\(?\s*([^()]+?)\s*\)?\s*$")


@dataclass(frozen=True, slots=True)
class ChannelScale:
    """A sensor constant: volts per physical unit of one channel.

    Attributes
    ----------
    volts_per_unit : float
        Sensor volts per physical unit (tacho V/(rad/s), shunt V/A = Ω, pot V/rev).
    unit : str
        The physical unit (``rad/s``, ``A``, ``rev``).
    """

    volts_per_unit: float
    unit: str

    def to_json(self) -> dict[str, object]:
        """The model JSON's ``scales`` entry.

        Returns
        -------
        dict
            ``volts_per_unit`` and ``unit``.
        """
        return {"volts_per_unit": self.volts_per_unit, "unit": self.unit}


def _pairs(texts: Iterable[str], option: str, channels: tuple[str, ...] = CHANNELS) -> list[tuple[str, str]]:
    out = []
    for text in texts:
        for part in str(text).split(","):
            if not part.strip():
                continue
            if "=" not in part:
                raise OptionError(f"{option} {part!r}: write CHANNEL=VALUE, e.g. {option} velocity=rpm")
            name, value = (s.strip() for s in part.split("=", 1))
            if name not in channels:
                raise OptionError(f"{option} {part!r}: unknown channel {name!r}; use {', '.join(channels)}")
            out.append((name, value))
    return out


#: One unit word with an optional power (``rpm``, ``rad``, ``s^2``, ``m²``, ``µA``, ``Ω``, ``°``, ``%``).
_FACTOR = r"[A-Za-zµΩ°%]+(?:\^-?\d+|[²³])?"
#: A unit: words joined by ``/``, ``*`` or ``·``, one level of parentheses (``V/(rad/s)``).
UNIT_GRAMMAR = re.compile(
    rf"^(?:{_FACTOR}|\({_FACTOR}(?:[*/·]{_FACTOR})*\))(?:\s*[*/·]\s*(?:{_FACTOR}|\({_FACTOR}(?:[*/·]{_FACTOR})*\)))*$")
#: Longest unit text accepted.
UNIT_MAX_CHARS = 24


def check_unit(text: str, option: str, channel: str) -> str:
    """``text`` if it reads as a unit (:data:`UNIT_GRAMMAR`), else a one-line refusal.

    Parameters
    ----------
    text : str
        The unit as given (``rpm``, ``rad/s``, ``V/(rad/s)``, ``counts``).
    option : str
        The option that gave it, for the message.
    channel : str
        The channel it is for.

    Returns
    -------
    str
        ``text``, stripped.

    Raises
    ------
    OptionError
        When ``text`` is not a unit (markup, spaces between words, symbols).
    """
    unit = text.strip()
    if len(unit) > UNIT_MAX_CHARS or not UNIT_GRAMMAR.match(unit):
        raise OptionError(f"{option} {channel}={text!r}: not a unit; write one such as rpm, rad/s, deg, counts, "
                          "V, mA (words joined by / or *, one level of parentheses)")
    return unit


def parse_units(texts: Iterable[str] | None) -> dict[str, str]:
    """``--units velocity=rpm,current=A``: the unit of each channel's data (``input=pwm`` for the command).

    Parameters
    ----------
    texts : iterable of str or None
        The option's values (repeatable, comma-separable).

    Returns
    -------
    dict of str to str

    Raises
    ------
    OptionError
        On a malformed entry or an unknown channel.
    """
    out = {}
    for name, value in _pairs(texts or (), "--units", (*CHANNELS, "input")):
        if not value:
            raise OptionError(f"--units {name}=: give a unit, e.g. {name}=rpm")
        out[name] = check_unit(value, "--units", name)
    return out


def parse_scales(texts: Iterable[str] | None) -> dict[str, ChannelScale]:
    """``--scale velocity=0.1504V/(rad/s)``, ``current=0.47ohm``, ``position=20V/rev``.

    Parameters
    ----------
    texts : iterable of str or None
        The option's values (repeatable; entries separated by ``;`` or repeated options, as a
        unit may contain a comma-free ``/``).

    Returns
    -------
    dict of str to ChannelScale

    Raises
    ------
    OptionError
        On a malformed constant, a zero or non-finite value, or an unknown channel.
    """
    out = {}
    for name, value in _pairs(texts or (), "--scale"):
        m = _OHM.match(value)
        if m:
            v, unit = float(m.group(1)), "A"
        else:
            m = _PER.match(value)
            if not m:
                raise OptionError(f"--scale {name}={value}: write volts per unit, e.g. velocity=0.1504V/(rad/s), "
                                  "current=0.47ohm, position=20V/rev")
            v, unit = float(m.group(1)), m.group(2)
        if not (math.isfinite(v) and v != 0):
            raise OptionError(f"--scale {name}={value}: the constant must be a non-zero number")
        out[name] = ChannelScale(v, unit)
    return out


def channel_unit(units: Mapping[str, str], channel: str) -> str:
    """The unit a channel's values are in: the data's (``rpm``), else the scope's volts.

    Parameters
    ----------
    units : Mapping[str, str]
        A model's or capture's units by channel.
    channel : str
        ``position``, ``velocity``, ``current``, or ``input`` for the command.

    Returns
    -------
    str
        The unit (``"V"`` when the data did not name one).
    """
    return units.get(channel) or "V"


def _grouped(unit: str) -> str:
    """A rate is one unit in a quotient: ``(rad/s)``, not ``rad/s``; other units as they are."""
    return f"({unit})" if "/" in unit else unit


def dc_gain_unit(units: Mapping[str, str], channel: str = "velocity") -> str:
    """Unit of the DC gain: the channel's data unit per input unit (``rpm/V``; ``V/V`` by default).

    Parameters
    ----------
    units : Mapping
        Channel units (``input`` for the input channel); missing ones are volts.
    channel : str
        The output channel.

    Returns
    -------
    str
    """
    # a rate is one unit: (rad/s)/V, not rad/s/V
    return f"{_grouped(channel_unit(units, channel))}/{_grouped(channel_unit(units, 'input'))}"


def physical_gain(dc_gain: float, units: Mapping[str, str], scales: Mapping[str, ChannelScale],
                  channel: str = "velocity") -> tuple[float, str] | None:
    """The DC gain per physical unit, when a sensor constant is known for a volts channel.

    Parameters
    ----------
    dc_gain : float
        The gain in data units (channel volts per input volt).
    units : Mapping
        Channel units (a channel already in physical units needs no scale).
    scales : Mapping
        Sensor constants by channel.
    channel : str
        The output channel.

    Returns
    -------
    tuple of (float, str) or None
        ``(gain, "rad/s/V")``-style pair, or ``None`` without a scale for that channel.
    """
    sc = scales.get(channel)
    if sc is None or channel_unit(units, channel) != "V":
        return None
    return dc_gain / sc.volts_per_unit, f"{_grouped(sc.unit)}/{channel_unit(units, 'input')}"


def with_velocity_of_position(units: Mapping[str, str], roles: Iterable[str]) -> dict[str, str]:
    """``units`` with the velocity's unit derived from the position's when only a position was captured.

    A position-only experiment's velocity channel is the position's derivative: a log in encoder
    counts gives counts/s, one in degrees deg/s, a potentiometer's volts V/s, so its gain reads
    ``(counts/s)/V`` and not ``V/V``.  A velocity unit given (``--units velocity=…``) is kept.

    Parameters
    ----------
    units : Mapping[str, str]
        The channels' units so far (missing: volts).
    roles : iterable of str
        The roles of the experiment's captures.

    Returns
    -------
    dict of str to str
    """
    out = dict(units)
    present = set(roles)
    if "position" in present and "velocity" not in present and not out.get("velocity"):
        out["velocity"] = f"{_grouped(channel_unit(out, 'position'))}/s"
    return out


def units_of(captures: Mapping[str, object], declared: Mapping[str, str] | None = None) -> dict[str, str]:
    """The data unit of each role's capture (volts are left out: they are the default).

    Parameters
    ----------
    captures : Mapping[str, Capture]
        Captures by role; each channel's unit comes from its ``ChannelInfo.units`` (a plain CSV
        column named ``speed_rpm`` is in rpm).
    declared : Mapping, optional
        ``--units``: overrides what the files say.

    Returns
    -------
    dict of str to str
        ``{"velocity": "rpm", "input": "V", ...}`` for channels not in volts (``input`` is kept
        whenever another channel has a unit, so the gain's unit is explicit).
    """
    out: dict[str, str] = {}
    for role, cap in captures.items():
        info = getattr(cap, "output_info", None)
        unit = getattr(info, "units", "") or ""
        if unit and unit != "V":
            out[role] = unit
        inp = getattr(getattr(cap, "input_info", None), "units", "") or ""
        if inp and inp != "V":
            out["input"] = inp
    out.update({k: v for k, v in (declared or {}).items() if v})
    return out


"""Form fields and JSON bodies → the front door's keyword options, one parser per kind of value.

The option names are the front door's own parameter names (:func:`motorid.read_experiment`,
:func:`motorid.identify`, :func:`motorid.design`, :func:`motorid.simulate`), so a message from
the library names the same field the client sent.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from motorid import options
from motorid.errors import OptionError
from motorid.options import names

__all__ = [
    "DESIGN_OPTIONS",
    "DESIGN_PID_OPTIONS",
    "IDENTIFY_OPTIONS",
    "READ_OPTIONS",
    "SIMULATE_OPTIONS",
    "design_options",
    "design_pid_options",
    "identify_options",
    "simulate_options",
]

#: Form fields of ``POST /api/identify`` that go to :func:`motorid.read_experiment`.
READ_OPTIONS: tuple[str, ...] = names(options.READ)
#: Form fields of ``POST /api/identify`` that go to :func:`motorid.identify`.
IDENTIFY_OPTIONS: tuple[str, ...] = names(options.IDENTIFY)
#: Keys of the ``POST /api/design`` body besides ``model``.
DESIGN_OPTIONS: tuple[str, ...] = names(options.DESIGN)
#: Keys of a ``POST /api/design`` body with ``"pid": true`` besides ``model`` and ``pid``.
DESIGN_PID_OPTIONS: tuple[str, ...] = names(options.DESIGN_PID)
#: Keys of the ``POST /api/simulate`` body besides ``model`` and ``design``.
SIMULATE_OPTIONS: tuple[str, ...] = names(options.SIMULATE)


def _unknown(given: Mapping[str, Any], allowed: tuple[str, ...], where: str) -> None:
    extra = sorted(set(given) - set(allowed))
    if extra:
        raise OptionError(f"{where}: unknown field {extra[0]!r}; use {', '.join(allowed)}")


def _text_number(name: str, text: str, kind: type = float) -> float | int | None:
    text = text.strip()
    if not text:
        return None
    try:
        value = kind(text)
    except ValueError:
        raise OptionError(f"{name}={text!r}: give {'a whole number' if kind is int else 'a number'}") from None
    if not math.isfinite(value):
        raise OptionError(f"{name}={text!r}: give a finite number")
    return value


def _flag(name: str, text: str, *, auto: bool = False) -> bool | None:
    word = text.strip().lower()
    if word in ("1", "true", "yes", "on"):
        return True
    if word in ("0", "false", "no", "off"):
        return False
    if auto and word in ("", "auto", "none"):
        return None
    raise OptionError(f"{name}={text!r}: give true or false{' (or auto)' if auto else ''}")


def identify_options(fields: Mapping[str, tuple[str, ...]], *, ignore: tuple[str, ...] = ()
                     ) -> tuple[dict[str, Any], dict[str, Any]]:
    """Form fields → ``(read_experiment kwargs, identify kwargs)``.

    Parameters
    ----------
    fields : Mapping[str, tuple of str]
        The plain form fields (each may repeat; an option may not).
    ignore : tuple of str
        Fields the caller handles itself.

    Returns
    -------
    (dict, dict)
        Keyword options for :func:`motorid.read_experiment` and :func:`motorid.identify`.

    Raises
    ------
    OptionError
        An unknown field, a repeated option or a value of the wrong kind (named).
    """
    given = {k: v for k, v in fields.items() if k not in ignore}
    _unknown(given, READ_OPTIONS + IDENTIFY_OPTIONS, "identify")
    one = {}
    for name, values in given.items():
        if len(values) != 1:
            raise OptionError(f"{name} given {len(values)} times: give it once")
        one[name] = values[0]
    read: dict[str, Any] = {}
    ident: dict[str, Any] = {}
    for name in ("step_volts", "t0"):
        if name in one and (v := _text_number(name, one[name])) is not None:
            read[name] = v
    for name in ("force_role", "counted_velocity"):
        if name in one:
            read[name] = bool(_flag(name, one[name]))
    if one.get("columns", "").strip():
        read["columns"] = one["columns"]  # read_experiment parses it (one parser for every front end)
    for name in ("units", "scale"):
        if one.get(name, "").strip():
            read[name] = _pairs(name, one[name])
    if "segment" in one and (v := _text_number("segment", one["segment"], int)) is not None:
        read["segment"] = v
    if one.get("time_unit", "").strip():
        read["time_unit"] = one["time_unit"].strip()
    for name in ("method", "markov_basis", "reduction", "derivative", "structure", "sync"):
        if one.get(name, "").strip():
            ident[name] = one[name].strip()
    if one.get("order", "").strip():
        word = one["order"].strip()
        ident["order"] = word if word == "auto" else _text_number("order", word, int)
    if one.get("sample_interval", "").strip():
        word = one["sample_interval"].strip()
        ident["sample_interval"] = word if word == "auto" else _text_number("sample_interval", word)
    if "delay" in one:
        ident["delay"] = _flag("delay", one["delay"], auto=True)
    for name, kind in (("markov_params", int), ("ratio", int), ("markov_window_s", float), ("record_length_s", float)):
        if name in one and (v := _text_number(name, one[name], kind)) is not None:
            ident[name] = v
    return read, ident


def _pairs(name: str, text: str) -> dict[str, str]:
    """``velocity=rpm,current=A`` (``;`` also separates) → ``{"velocity": "rpm", "current": "A"}``."""
    out = {}
    for part in text.replace(";", ",").split(","):
        key, sep, value = part.partition("=")
        if not sep or not key.strip() or not value.strip():
            raise OptionError(f"{name}: {part!r} is not CHANNEL=VALUE (e.g. velocity=rpm)")
        out[key.strip()] = value.strip()
    return out


def _json_number(name: str, value: Any, *, optional: bool = True) -> float | None:
    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise OptionError(f"{name}={value!r}: give a finite number")
    return float(value)


def _json_complex_list(name: str, value: Any) -> list[complex] | None:
    """``[-3, "-4+2j", [-4, -2]]`` or ``"-3+2j,-3-2j"`` → complex numbers."""
    if value is None:
        return None
    if isinstance(value, str):
        from motorid.control.feedback import parse_poles

        return [complex(p) for p in parse_poles(value, name)]
    if not isinstance(value, list):
        raise OptionError(f"{name}: give a list of poles, e.g. [-3, -4] or [\"-3+2j\", \"-3-2j\"]")
    out = []
    for item in value:
        if isinstance(item, str):
            try:
                out.append(complex(item.replace(" ", "").replace("i", "j")))
            except ValueError:
                raise OptionError(f"{name}: cannot read {item!r} as a pole; write it like -3+2j") from None
        elif isinstance(item, list) and len(item) == 2:
            out.append(complex(_json_number(name, item[0], optional=False) or 0.0,
                               _json_number(name, item[1], optional=False) or 0.0))
        else:
            out.append(complex(_json_number(name, item, optional=False) or 0.0))
    return out


def design_options(body: Mapping[str, Any]) -> dict[str, Any]:
    """``POST /api/design`` body (without ``model``) → :func:`motorid.design` keyword options.

    Parameters
    ----------
    body : Mapping
        The decoded JSON object.

    Returns
    -------
    dict
        Keyword options.

    Raises
    ------
    OptionError
        An unknown key or a value of the wrong kind (named).
    """
    _unknown(body, DESIGN_OPTIONS, "design")
    out: dict[str, Any] = {}
    for name in ("damping", "wn", "k2", "settling_time", "overshoot", "ki", "robust_fraction"):
        if name in body:
            out[name] = _json_number(name, body[name])
    for name in ("poles", "observer_poles"):
        if name in body:
            out[name] = _json_complex_list(name, body[name])
    if body.get("integral_pole") is not None:
        poles = _json_complex_list("integral_pole", [body["integral_pole"]])
        out["integral_pole"] = poles[0] if poles else None
    if "integral" in body:
        if not isinstance(body["integral"], bool):
            raise OptionError(f"integral={body['integral']!r}: give true or false")
        out["integral"] = body["integral"]
    if body.get("output") is not None:
        if not isinstance(body["output"], str):
            raise OptionError(f"output={body['output']!r}: give position, velocity or current")
        out["output"] = body["output"]
    if body.get("sensors") is not None:
        sensors = body["sensors"]
        if not isinstance(sensors, list) or not all(isinstance(x, str) for x in sensors):
            raise OptionError(f"sensors={sensors!r}: give a list of channels, e.g. [\"position\", \"velocity\"]")
        out["sensors"] = sensors
    if "robust_samples" in body:
        n = body["robust_samples"]
        if isinstance(n, bool) or not isinstance(n, int):
            raise OptionError(f"robust_samples={n!r}: give a whole number (0: no check)")
        out["robust_samples"] = n
    return out


def design_pid_options(body: Mapping[str, Any]) -> dict[str, Any]:
    """``POST /api/design`` body with ``"pid": true`` (without ``model``, ``pid``) → :func:`motorid.design_pid` options.

    Parameters
    ----------
    body : Mapping
        The decoded JSON object.

    Returns
    -------
    dict
        Keyword options.

    Raises
    ------
    OptionError
        A state-feedback key, an unknown key or a value of the wrong kind (named).
    """
    clash = next((k for k in DESIGN_OPTIONS if k in body and k not in DESIGN_PID_OPTIONS), None)
    if clash is not None:
        raise OptionError(f"pid and {clash} do not go together: {clash} is for state feedback by pole placement")
    _unknown(body, DESIGN_PID_OPTIONS, "design (pid)")
    out: dict[str, Any] = {}
    for name in ("tau_c", "derivative_filter", "damping", "wn"):
        if body.get(name) is not None:
            out[name] = _json_number(name, body[name])
    for name in ("loop", "rule"):
        if body.get(name) is not None:
            if not isinstance(body[name], str):
                raise OptionError(f"{name}={body[name]!r}: give a word")
            out[name] = body[name]
    if "integral" in body:
        if not isinstance(body["integral"], bool):
            raise OptionError(f"integral={body['integral']!r}: give true or false")
        out["integral"] = body["integral"]
    return out


def simulate_options(body: Mapping[str, Any]) -> dict[str, Any]:
    """``POST /api/simulate`` body (without ``model``, ``design``) → :func:`motorid.simulate` options.

    Parameters
    ----------
    body : Mapping
        The decoded JSON object.

    Returns
    -------
    dict
        Keyword options.

    Raises
    ------
    OptionError
        An unknown key or a value of the wrong kind (named).
    """
    _unknown(body, SIMULATE_OPTIONS, "simulate")
    out: dict[str, Any] = {}
    for name in ("duration_s", "level_v", "saturation", "disturbance", "disturbance_start_s", "dt_s", "z0"):
        if name in body:
            value = _json_number(name, body[name], optional=name in ("saturation", "disturbance", "dt_s", "level_v"))
            if value is not None:
                out[name] = value
    if "duration_s" in out and not 0 < out["duration_s"] <= 600:
        raise OptionError(f"duration_s={out['duration_s']:g}: give 0 < duration_s <= 600 s")
    for name in ("reference", "plant", "trainer_preset"):
        if name in body:
            if not isinstance(body[name], str):
                raise OptionError(f"{name}={body[name]!r}: give a name")
            out[name] = body[name]
    for name in ("x0", "xhat0"):
        if body.get(name) is not None:
            if not isinstance(body[name], list):
                raise OptionError(f"{name}: give a list of numbers")
            out[name] = [_json_number(name, v, optional=False) for v in body[name]]
    if body.get("anti_windup") is not None:
        if not isinstance(body["anti_windup"], bool):
            raise OptionError(f"anti_windup={body['anti_windup']!r}: give true, false or null")
        out["anti_windup"] = body["anti_windup"]
    if "compensate_dead_zone" in body:
        if not isinstance(body["compensate_dead_zone"], bool):
            raise OptionError(f"compensate_dead_zone={body['compensate_dead_zone']!r}: give true or false")
        out["compensate_dead_zone"] = body["compensate_dead_zone"]
    return out

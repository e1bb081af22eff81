"""Serialising a :class:`~motorid.model.motor.MotorModel`.

The docs/formats.md model JSON (both ways) and the Octave/MATLAB script.  JSON is a serialisation at the
edge: the model itself holds numpy arrays and python-control objects.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from pathlib import Path

from motorid.errors import ModelFormatError
from motorid.io.jsonfile import read_json
from motorid.model.nonlinearity import StaticNonlinearity
from motorid.model.units import ChannelScale, channel_unit
from motorid.model.simplify import _normalise_tf, _roots
from motorid.model.uncertainty import Uncertainty

if TYPE_CHECKING:
    from motorid.model.motor import MotorModel

SCHEMA = "motorid.model/1"


def _jsonable(value: Any) -> Any:
    """Convert numpy scalars/arrays, tuples and mappings to plain JSON types."""
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.floating, float)):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _jsonable(dataclasses.asdict(value))
    return value


def _complex_pairs(values: np.ndarray) -> list[list[float]]:
    order = np.lexsort((np.imag(values), np.real(values)))
    return [[float(np.real(values[i])), float(np.imag(values[i]))] for i in order]



def model_to_dict(model: MotorModel) -> dict[str, Any]:
    """``model`` as the docs/formats.md "Model JSON" dict (schema ``motorid.model/1``).

    ``state_space.C``/``D`` are the velocity row (the paper's ``C = [0 1 0]``); every
    output row is kept in ``state_space.outputs``.  Extra keys: ``outputs``,
    ``current_tf``, ``first_order.k``/``p``, ``settings``, ``extras``.

    Parameters
    ----------
    model : MotorModel
        The model.

    Returns
    -------
    dict
        JSON-able.
    """
    cv, dv = model._row("velocity")
    vnum, vden = model._row_tf("velocity")
    pnum, pden = _normalise_tf(*model.tf_coefficients("position"))
    fo = model.first_order()
    data: dict[str, Any] = {
        "schema": SCHEMA,
        "method": model.method,
        "order": model.order,
        "step_volts": model.step_volts,
        "sample_interval": model.sample_interval_s,
        "states": list(model.states),
        "outputs": list(model.outputs),
        "state_space": {
            "A": model.A.tolist(),
            "B": model.B.tolist(),
            "C": cv.tolist(),
            "D": dv.tolist(),
            "outputs": {name: {"C": model.C[i].tolist(), "D": float(model.D[i, 0])}
                        for i, name in enumerate(model.outputs)},
        },
        "velocity_tf": {"num": vnum.tolist(), "den": vden.tolist()},
        "position_tf": {"num": pnum.tolist(), "den": pden.tolist()},
        "first_order": {"dc_gain": fo.dc_gain, "time_constant": fo.time_constant_s,
                        "k": fo.k, "p": fo.p, "t63_s": model.t63_s(), "residence_time_s": model.residence_time_s()},
        "poles": _complex_pairs(_roots(vden)),
        "zeros": _complex_pairs(_roots(vnum)),
        "fit": dict(model.fit),
        "warnings": list(model.warnings),
        "settings": dict(model.settings),
        "extras": dict(model.extras),
    }
    cur = model.tf_coefficients("current")
    if cur is not None:
        cnum, cden = _normalise_tf(*cur)
        data["current_tf"] = {"num": cnum.tolist(), "den": cden.tolist()}
    if model.uncertainty is not None:
        unc = model.uncertainty.to_dict()
        # each channel's step instant and fitted shift: its own top-level key
        timing = unc.pop("timing", None)
        data["uncertainty"] = unc
        if timing:
            data["timing"] = timing
    if model.stages:
        data["stages"] = [st.to_dict() if hasattr(st, "to_dict") else dict(st) for st in model.stages]
    if model.delay_s > 0:
        data["delay_s"] = model.delay_s
    if model.static_nonlinearity is not None:
        data["static_nonlinearity"] = model.static_nonlinearity.to_json()
    data["dc_gain_unit"] = model.dc_gain_unit
    if model.units:
        data["units"] = dict(model.units)
    if model.scales:
        data["scales"] = {k: v.to_json() for k, v in model.scales.items()}
    return _jsonable(data)


def model_from_dict(cls: type[MotorModel], data: Mapping[str, Any]) -> MotorModel:
    """Build ``cls`` from the fields of a decoded model JSON object (schema and shapes checked).

    Parameters
    ----------
    data : Mapping[str, Any]
        The decoded JSON object.

    Returns
    -------
    MotorModel
        An instance of ``cls``.
    """
    if not isinstance(data, Mapping):
        raise ModelFormatError("expected a JSON object")
    schema = data.get("schema")
    if schema != SCHEMA:
        raise ModelFormatError(f"schema is {schema!r}, expected {SCHEMA!r}")
    for key in ("method", "states", "state_space"):
        if key not in data:
            raise ModelFormatError(f"missing key {key!r}")
    ss = data["state_space"]
    if not isinstance(ss, Mapping):
        raise ModelFormatError("state_space must be an object")
    for key in ("A", "B", "C", "D"):
        if key not in ss:
            raise ModelFormatError(f"missing key 'state_space.{key}'")
    rows = ss.get("outputs")
    c: Any  # raw JSON rows: MotorModel checks and converts them
    d: Any
    if rows:
        outputs = tuple(rows)
        c = [rows[o]["C"] for o in outputs]
        d = [[rows[o]["D"]] for o in outputs]
    else:
        outputs, c, d = ("velocity",), ss["C"], ss["D"]
    fit = data.get("fit") or {}
    return cls(
        A=ss["A"], B=ss["B"], C=c, D=d,
        states=tuple(data["states"]),
        outputs=outputs,
        step_volts=data.get("step_volts"),
        method=data["method"],
        settings=data.get("settings") or {},
        sample_interval_s=data.get("sample_interval"),
        fit={k: (float("nan") if v is None else v) for k, v in fit.items()},
        warnings=tuple(data.get("warnings") or ()),
        extras=data.get("extras") or {},
        uncertainty=_uncertainty(data),
        stages=tuple(data.get("stages") or ()),
        delay_s=data.get("delay_s") or 0.0,
        static_nonlinearity=(None if data.get("static_nonlinearity") is None
                             else StaticNonlinearity.from_json(data["static_nonlinearity"])),
        units={str(k): str(v) for k, v in (data.get("units") or {}).items()},
        scales={str(k): ChannelScale(float(v["volts_per_unit"]), str(v["unit"]))
                for k, v in (data.get("scales") or {}).items()},
    )


def _uncertainty(data: Mapping[str, Any]) -> Uncertainty | None:
    """The typed ``uncertainty`` (with the top-level ``timing``) of a decoded model JSON; None without one."""
    unc, timing = data.get("uncertainty"), data.get("timing")
    if unc is not None and not isinstance(unc, Mapping):
        raise ModelFormatError("uncertainty must be an object")
    if timing is not None and not isinstance(timing, Mapping):
        raise ModelFormatError("timing must be an object")
    merged = {**(unc or {}), **({"timing": timing} if timing else {})}
    if not merged:
        return None
    try:
        return Uncertainty.from_dict(merged)
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelFormatError(f"uncertainty: {exc}") from None


def model_to_matlab(model: MotorModel, name: str = "motor") -> str:
    """An Octave/MATLAB script for ``model`` defining ``A, B, C, D``, ``sys = ss(A,B,C,D)`` and TFs.

    ``C``/``D`` are the velocity row (the paper's convention, eq. 8); every output row
    is also given as ``C_<channel>``/``D_<channel>``.

    Parameters
    ----------
    model : MotorModel
        The model.
    name : str
        Prefix of the script's comments (default ``motor``).

    Returns
    -------
    str
        The script.
    """

    def mat(m: np.ndarray) -> str:
        return "[" + "; ".join(" ".join(f"{v:.17g}" for v in row) for row in m) + "]"

    def vec(v: np.ndarray) -> str:
        return "[" + " ".join(f"{x:.17g}" for x in v) + "]"

    cv, dv = model._row("velocity")
    vnum, vden = model._row_tf("velocity")
    pnum, pden = _normalise_tf(*model.tf_coefficients("position"))
    fo = model.first_order()
    in_unit = model.input_unit
    lines = [
        f"% {name}: DC servo-motor model identified by motorid (method: {model.method})",
        f"% states x = [{', '.join(model.states)}]; input u = "
        + ("amplifier volts" if in_unit == "V" else f"the logged command ({in_unit})")
        + ("" if model.step_volts is None else f" (step {model.step_volts:g} {in_unit})"),
        "% outputs: " + ", ".join(f"{ch} ({channel_unit(model.units, ch)})" for ch in model.outputs)
        + "; C, D give the velocity channel",
        f"A = {mat(model.A)};",
        f"B = {mat(model.B)};",
        f"C = {mat(cv)};",
        f"D = {mat(dv)};",
    ]
    for i, ch in enumerate(model.outputs):
        lines.append(f"C_{ch} = {mat(model.C[i:i + 1])};")
        lines.append(f"D_{ch} = {mat(model.D[i:i + 1])};")
    lines += [
        "sys = ss(A, B, C, D);",
        *([f"sys.InputDelay = {model.delay_s:.17g};  % dead time, s"] if model.delay_s > 0 else []),
        f"Hv = tf({vec(vnum)}, {vec(vden)});  % velocity TF",
        f"Hp = tf({vec(pnum)}, {vec(pden)});  % position TF",
        f"% first-order approximation: dc_gain = {fo.dc_gain:.6g}, tau = {fo.time_constant_s:.6g} s"
        f" (k = {fo.k:.6g}, p = {fo.p:.6g})",
    ]
    for w in model.warnings:
        lines.append(f"% warning: {w}")
    return "\n".join(lines) + "\n"


def load_model(path: Path) -> MotorModel:
    """Read a ``motorid.model/1`` JSON file.

    Parameters
    ----------
    path : Path
        The model JSON file.

    Returns
    -------
    MotorModel

    Raises
    ------
    ModelFormatError, OptionError
        One-line errors naming the file.
    """
    from motorid.model.motor import MotorModel

    data = read_json(path, "model")
    if not isinstance(data, Mapping):  # what from_json would say, for the type checker
        raise ModelFormatError("not a motorid model: expected a JSON object", file=str(path))
    try:
        return MotorModel.from_json(data, file=str(path))
    except (RecursionError, OverflowError, ZeroDivisionError, FloatingPointError) as exc:
        raise ModelFormatError(f"not a motorid model: bad entry ({exc.__class__.__name__})", file=str(path)) from None

"""Measurable coordinates: re-express an identified model in states a student can wire.

Identification methods return realisations with abstract states (``x1, x2, …``: companion
or output-error coordinates).  A state-feedback row on those states cannot be built from a
potentiometer and a tachogenerator.  This module finds the similarity transform ``z = T x``
whose states are the measured channels — ``position``, ``velocity``, ``current`` when the
model has such outputs — completed, when the model has more states than channels, by
derivatives of the velocity channel (``acceleration = C_v A x``, ``jerk = C_v A² x``), and
returns the same model in those coordinates.  Poles, transfer functions and any closed loop
designed on it are unchanged (``eig(T A T⁻¹) = eig(A)``); a gain row ``K_z`` on the new states
is ``K_z T`` on the old ones.

Rows are chosen greedily in the order position, velocity, current, acceleration, jerk, …; a
row is kept when it adds a direction to the ones kept so far (measured on the balanced
realisation, so the test does not depend on the units of the states).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from motorid.model import MotorModel
from motorid.model.units import channel_unit

__all__ = [
    "CONDITION_MAX",
    "INDEPENDENCE_MIN",
    "SENSORS",
    "SENSOR_UNITS",
    "MeasurableRealisation",
    "measurable_realisation",
    "realise_in",
    "sensor_transform",
    "sensor_unit",
]

#: A candidate row is kept when the part of it outside the span of the rows already kept is
#: at least this fraction of its norm (balanced coordinates).  Below it the new state would be
#: a near-copy of the others: the transform would be close to singular and the gain on that
#: sensor would be amplified noise.  1e-6 leaves every genuinely independent row of a
#: double-precision model (round-off ~1e-13) and refuses a current channel that is the
#: velocity channel times a constant (a model whose electrical pole was not identified).
INDEPENDENCE_MIN = 1e-6
#: Largest acceptable 2-norm condition number of the balanced, row-normalised transform.
#: Beyond it the re-expressed matrices lose more than half of double precision's digits;
#: the design then stays on the model's own states, with a warning.
CONDITION_MAX = 1e8

#: The sensor behind each measurable state, for printing gains per sensor.
SENSORS: dict[str, tuple[str, str, int]] = {  # state: (channel, sensor, derivative order)
    "position": ("position", "the potentiometer", 0),
    "velocity": ("velocity", "the tacho", 0),
    "current": ("current", "the current shunt", 0),
    "acceleration": ("velocity", "the tacho's derivative", 1),
    "jerk": ("velocity", "the tacho's second derivative", 2),
}
def _per_seconds(unit: str, order: int) -> str:
    """``unit`` divided by seconds ``order`` times: ``V/s``, ``rpm/s²``, and ``deg/s²`` for ``deg/s`` once."""
    base, power = (unit[:-2], 1) if unit.endswith("/s") else (unit, 0)
    power += order
    return base + ("", "/s", "/s²", "/s³")[power] if power <= 3 else f"{base}/s^{power}"


def _sensor_of(sensor: str, unit: str) -> str:
    """The sensor a channel's unit speaks of: an encoder's counts are no potentiometer, nor its rate a tacho."""
    counted = any(word in unit for word in ("counts", "ticks"))
    if sensor == "the potentiometer" and (counted or unit in ("deg", "rad", "rev")):
        return "the encoder" if counted else "the angle sensor"
    if sensor.startswith("the tacho") and (counted or "deg" in unit or "rev" in unit or unit == "V/s"):
        return sensor.replace("the tacho", "the measured velocity")
    return sensor


def sensor_unit(state: str, units: Mapping[str, str] | None = None) -> str:
    """How a gain on ``state`` is read (``per V of the tacho``, ``per rpm of the tacho``).

    Parameters
    ----------
    state : str
        A state name (``position``, ``velocity``, ``current``, ...).
    units : Mapping[str, str], optional
        The model's channel units (default: scope volts).

    Returns
    -------
    str
        The unit phrase, e.g. ``per V of the tacho``, ``per rpm/s of the tacho's derivative``.
    """
    units = units or {}
    # a command that is not volts (a PWM register, a duty cycle) says so: "pwm per rpm of the tacho"
    command = "" if channel_unit(units, "input") == "V" else f"{channel_unit(units, 'input')} "
    if state in SENSORS:
        channel, sensor, order = SENSORS[state]
        unit = channel_unit(units, channel)
        return f"{command}per {_per_seconds(unit, order)} of {_sensor_of(sensor, unit)}"
    if state.startswith("velocity_d"):
        unit = channel_unit(units, "velocity")
        return (f"{command}per {unit}/s^{state[len('velocity_d'):]} of {_sensor_of('the tacho', unit)}'s "
                "derivative of that order")
    return f"{command}per unit of the model state {state}"


#: The phrases for scope volts (what :func:`sensor_unit` says without units).
SENSOR_UNITS: dict[str, str] = {state: sensor_unit(state) for state in SENSORS}


@dataclass(frozen=True, slots=True)
class MeasurableRealisation:
    """A model re-expressed in measurable coordinates ``z = T x``.

    Attributes
    ----------
    model : MotorModel
        The same system with states ``states`` (``A = T A₀ T⁻¹``, ``B = T B₀``, ``C = C₀ T⁻¹``).
    transform : ndarray, shape (n, n)
        ``T``; a gain row ``K`` on ``model``'s states is ``K @ T`` on the original states.
    source_states : tuple of str
        The original model's state names (the columns of ``T``).
    condition : float
        Condition number of the balanced, row-normalised ``T`` (1 for the identity).
    warnings : tuple of str
        Why the original states were kept, when they were.
    """

    model: MotorModel
    transform: np.ndarray
    source_states: tuple[str, ...]
    condition: float
    warnings: tuple[str, ...] = ()

    @property
    def states(self) -> tuple[str, ...]:
        """The measurable state names (the order of a designed ``K``)."""
        return tuple(self.model.states)

    @property
    def changed(self) -> bool:
        """Whether the coordinates differ from the model's own."""
        return self.states != self.source_states or not np.allclose(self.transform, np.eye(self.transform.shape[0]))


def _state_scaling(a: np.ndarray) -> np.ndarray:
    """Diagonal ``s`` with ``x = diag(s) x_b`` balancing ``A`` (scipy's LAPACK gebal, no permutation)."""
    _, (scale, _) = scipy.linalg.matrix_balance(a, permute=False, separate=True)
    return np.asarray(scale, dtype=float)


def _candidates(model: MotorModel) -> list[tuple[str, np.ndarray]]:
    a = model.A
    rows: list[tuple[str, np.ndarray]] = []
    # a channel with a direct feed-through (D ≠ 0) is not a function of the state alone
    out = {name: model.C[i].copy() for i, name in enumerate(model.outputs) if model.D[i, 0] == 0.0}
    if "position" in out:
        rows.append(("position", out["position"]))
    rows.append(("velocity", out["velocity"]))
    if "current" in out:
        rows.append(("current", out["current"]))
    r = out["velocity"]
    for k in range(1, a.shape[0]):
        r = r @ a
        rows.append((_derivative_name(k), r.copy()))
    return rows


def _derivative_name(k: int) -> str:
    """The coordinate that is the velocity's ``k``-th derivative."""
    return {1: "acceleration", 2: "jerk"}.get(k, f"velocity_d{k}")


def sensor_transform(a: np.ndarray, c: np.ndarray, outputs: tuple[str, ...], states: tuple[str, ...]
                     ) -> np.ndarray | None:
    """``T`` of ``z = T x`` for the named measurable coordinates, for many models at once.

    The rows :func:`measurable_realisation` chooses from: a channel's output row, or the velocity
    row times ``A^k`` for its ``k``-th derivative (``acceleration``, ``jerk``, ``velocity_d<k>``).

    Parameters
    ----------
    a : ndarray, shape (..., n, n)
        State matrices (stacked on leading axes).
    c : ndarray, shape (..., outputs, n)
        Output matrices, rows in the order of ``outputs``.
    outputs : tuple of str
        The output channels' names.
    states : tuple of str
        The coordinates wanted (a design's ``states``).

    Returns
    -------
    ndarray, shape (..., n, n), or None
        None when a name is no measurable coordinate of these models.
    """
    derivative = {_derivative_name(k): k for k in range(1, a.shape[-1])}
    rows = []
    for name in states:
        if name in outputs:
            rows.append(c[..., outputs.index(name), :])
        elif name in derivative and "velocity" in outputs:
            r = c[..., outputs.index("velocity"), :]
            for _ in range(derivative[name]):
                r = np.einsum("...i,...ij->...j", r, a)
            rows.append(r)
        else:
            return None
    return np.stack(rows, axis=-2)


def _select_rows(
    model: MotorModel, scale: np.ndarray, skip: tuple[str, ...] = ()
) -> tuple[list[str], list[np.ndarray]]:
    n = model.A.shape[0]
    names: list[str] = []
    kept: list[np.ndarray] = []
    basis = np.zeros((0, n))
    for name, row in _candidates(model):
        if len(kept) == n or name in skip:
            continue
        rb = row * scale
        norm = float(np.linalg.norm(rb))
        if norm == 0.0 or not np.isfinite(norm):
            continue
        resid = rb - (basis.T @ (basis @ rb)) if basis.size else rb
        if float(np.linalg.norm(resid)) < INDEPENDENCE_MIN * norm:
            continue
        # Gram–Schmidt twice for an orthonormal basis that stays orthonormal in round-off
        q = resid - (basis.T @ (basis @ resid)) if basis.size else resid
        basis = np.vstack([basis, q / np.linalg.norm(q)])
        names.append(name)
        kept.append(row)
    return names, kept


def realise_in(model: MotorModel, transform: np.ndarray, states: tuple[str, ...]) -> MotorModel:
    """``model`` in the coordinates ``z = T x`` with state names ``states``.

    Output rows that are exactly one of the new states (a measured channel chosen as a
    coordinate) are set to that unit row, so round-off does not leak into ``C``.

    Parameters
    ----------
    model : MotorModel
        The model to re-express.
    transform : ndarray, shape (n, n)
        ``T`` in ``z = T x``.
    states : tuple of str
        Names of the new states ``z``.

    Returns
    -------
    MotorModel
        The same input/output behaviour on the states ``z``.

    Raises
    ------
    ModelFormatError
        When ``T`` does not fit the model (wrong shape, singular).
    """
    from motorid.model import ModelFormatError

    t = np.asarray(transform, dtype=float)
    n = model.A.shape[0]
    if t.shape != (n, n) or len(states) != n or not np.all(np.isfinite(t)):
        raise ModelFormatError(f"a coordinate transform of shape {t.shape} does not fit a {n}-state model")
    scale = _state_scaling(model.A)
    tb = t * scale[None, :]
    try:
        tb_inv = np.linalg.inv(tb)
    except np.linalg.LinAlgError:
        raise ModelFormatError("the coordinate transform is singular") from None
    t_inv = scale[:, None] * tb_inv
    a = t @ model.A @ t_inv
    b = t @ model.B
    c = model.C @ t_inv
    for i, name in enumerate(model.outputs):
        if name in states:
            c[i] = 0.0
            c[i, states.index(name)] = 1.0
    return model.replace(A=a, B=b, C=c, D=np.array(model.D, dtype=float), states=tuple(states))


def measurable_realisation(model: MotorModel) -> MeasurableRealisation:
    """Re-express ``model`` in measurable states (position, velocity, current/acceleration…).

    Parameters
    ----------
    model : MotorModel

    Returns
    -------
    MeasurableRealisation
        ``[position, velocity]`` for a 2-state position model; ``[position, velocity,
        current]`` when a current output is independent of the other two, else
        ``[position, velocity, acceleration]``; more states get the next velocity derivatives
        (``acceleration``, ``jerk``).  Velocity-only models (no position output) start from
        ``velocity``.  The model's own states are kept (with a warning) when a channel has a
        direct feed-through, or the channels and their derivatives do not span the state
        (a non-minimal realisation), or the transform is ill-conditioned.  A current channel
        with a direct feed-through is not used as a coordinate.
    """
    a = model.A
    n = a.shape[0]
    source = tuple(model.states)
    ident = MeasurableRealisation(model, np.eye(n), source, 1.0)
    used = [i for i, o in enumerate(model.outputs) if o in ("position", "velocity")]
    if any(model.D[i, 0] != 0.0 for i in used):
        return MeasurableRealisation(model, np.eye(n), source, 1.0, (
            "the position or velocity channel has a direct feed-through (D ≠ 0), so it is not a state; "
            f"the design uses the model's own states {list(source)}",))
    scale = _state_scaling(a)
    for skip in ((), ("current",)):
        names, rows = _select_rows(model, scale, skip)
        if len(rows) < n:
            continue
        t = np.vstack(rows)
        tb = t * scale[None, :]
        tb = tb / np.linalg.norm(tb, axis=1, keepdims=True)
        cond = float(np.linalg.cond(tb))
        if not np.isfinite(cond) or cond > CONDITION_MAX:
            continue
        if tuple(names) == source and np.allclose(t, np.eye(n), rtol=0.0, atol=1e-12):
            return ident
        return MeasurableRealisation(realise_in(model, t, tuple(names)), t, source, cond)
    return MeasurableRealisation(model, np.eye(n), source, 1.0, (
        "the measured channels and the velocity derivatives do not span this model's states "
        f"well (non-minimal or ill-conditioned realisation); the design uses its own states {list(source)}",))

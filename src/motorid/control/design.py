"""One controller design on a :class:`~motorid.model.MotorModel`: the ``motorid design`` job.

Combines state feedback (:mod:`.feedback`), integral action (:mod:`.integral`) and an observer
(:mod:`.observer`) into a frozen :class:`Design` written as docs/formats.md "Design JSON".  The
design is done in measurable coordinates (:mod:`.coordinates`), so ``K`` has one gain per
sensor; the row on the identified model's own states is kept as ``K_model``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any, cast

import numpy as np

from motorid._threads import single_blas_thread
from motorid.control.coordinates import measurable_realisation, realise_in, sensor_unit
from motorid.control.feedback import (
    ControlDesignError,
    check_controllable,
    check_pole_range,
    check_gains,
    check_poles,
    k1_for_damping,
    place_gains,
    poles_from_damping,
    poles_from_specs,
    reference_gain,
)
from motorid.control.integral import integral_gains, integral_poly, routh_violations
from motorid.control.margins import LoopMargins, loop_margins
from motorid.control.observer import observer_gain, output_feedback_matrix
from motorid.control.reduced_observer import ReducedObserver, default_poles, reduced_loop_matrix, reduced_observer
from motorid.control.robust import RobustCheck, RobustCheckUnavailable, RobustSpec, robust_check
from motorid.control.routh import affine_char_poly, routh_conditions
from motorid.errors import OptionError
from motorid.model import MotorModel
from motorid.model.units import channel_unit

__all__ = ["LARGE_GAIN", "SCHEMA", "Design", "DesignSettings", "default_output", "design_controller", "design_model",
           "output_row"]

SCHEMA = "motorid.design/1"
#: A state-feedback gain above this (volts of input per volt of a sensor) gets a warning: it
#: turns a 1 mV sensor error into 10 V at the amplifier and the sampled loop needs control
#: intervals far below the 1 ms of the simulation.  The lab report's gains are 5–20.
LARGE_GAIN = 1e4


@dataclass(frozen=True, slots=True)
class DesignSettings:
    """How the poles are specified (exactly one of the first four ways).

    Attributes
    ----------
    poles : tuple of complex, optional
        Closed-loop poles (``n``, or ``n + 1`` with integral action).
    damping : float, optional
        ζ, with ``k2`` (the report's way, eqs. 32–36) or ``wn``.
    k2 : float, optional
        Velocity gain for the report's design.
    wn : float, optional
        Natural frequency, rad/s.
    settling_time_s, overshoot_pct : float, optional
        2 % settling time and percent overshoot.
    integral : bool
        Add ``ż = y − r`` and ``u = −K x − ki z`` (report §3).
    ki : float, optional
        Given integral gain (Routh-checked).
    integral_pole : complex, optional
        The extra pole placed with the state poles.
    observer_poles : tuple of complex, optional
        Luenberger observer poles (report §4).
    output : str, optional
        Measured channel ``y`` (default: position if the model has it, else velocity).
    robust_samples : int
        Plausible motors the design is checked on (:mod:`.robust`); 0 (the default here): no
        check.  The command line and :func:`motorid.design` check
        :data:`~motorid.control.robust.DEFAULT_SAMPLES`.
    sensors : tuple of str, optional
        What the rig measures (``position``, ``velocity``, ``current``); default: the channels
        the model was identified from.  States that are not measured (an acceleration) are
        estimated by a reduced-order observer (:mod:`.reduced_observer`), never differentiated.
    robust_fraction : float, optional
        Tune for robustness: the design's own settling time and overshoot are tightened until
        this fraction of the plausible motors meets the ``settling_time_s``/``overshoot_pct``
        asked for (:func:`design_controller` says how far it went).
    """

    poles: tuple[complex, ...] | None = None
    damping: float | None = None
    k2: float | None = None
    wn: float | None = None
    settling_time_s: float | None = None
    overshoot_pct: float | None = None
    integral: bool = False
    ki: float | None = None
    integral_pole: complex | None = None
    observer_poles: tuple[complex, ...] | None = None
    output: str | None = None
    robust_samples: int = 0
    sensors: tuple[str, ...] | None = None
    robust_fraction: float | None = None

    def __post_init__(self) -> None:
        for name, option in (("damping", "--damping"), ("wn", "--wn"), ("settling_time_s", "--settling-time")):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise OptionError(f"{option} must be a finite number > 0, got {v!r}")
        for name, option in (("k2", "--k2"), ("ki", "--ki"), ("overshoot_pct", "--overshoot")):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise OptionError(f"{option} must be a finite number, got {v!r}")
        if self.overshoot_pct is not None and not 0 <= self.overshoot_pct < 100:
            raise OptionError(f"--overshoot must be a percentage in [0, 100), got {self.overshoot_pct!r}")
        for name, option in (("poles", "--poles"), ("observer_poles", "--observer-poles")):
            v = getattr(self, name)
            if v is not None and (len(v) == 0 or not np.all(np.isfinite(np.asarray(v, dtype=complex)))):
                raise OptionError(f"{option} must be finite numbers, got {list(v)}")
        if self.integral_pole is not None:
            try:
                finite = bool(np.isfinite(complex(self.integral_pole)))
            except (TypeError, ValueError):
                finite = False
            if not finite or isinstance(self.integral_pole, bool):
                raise OptionError(f"--integral-pole must be a finite number, got {self.integral_pole!r}")
        ways = [self.poles is not None, self.damping is not None,
                self.settling_time_s is not None or self.overshoot_pct is not None]
        if sum(ways) != 1:
            raise OptionError("give exactly one of --poles, --damping (with --k2 or --wn), "
                              "or --settling-time with --overshoot")
        if self.damping is not None and (self.k2 is None) == (self.wn is None):
            raise OptionError("--damping needs exactly one of --k2 (the report's design) or --wn")
        if self.damping is None and (self.k2 is not None or self.wn is not None):
            raise OptionError("--k2 and --wn go with --damping")
        if ways[2] and (self.settling_time_s is None or self.overshoot_pct is None):
            raise OptionError("--settling-time and --overshoot go together")
        if self.ki is not None and self.integral_pole is not None:
            raise OptionError("give --ki or --integral-pole, not both")
        if (self.ki is not None or self.integral_pole is not None) and not self.integral:
            raise OptionError("--ki and --integral-pole need --integral")
        if self.output is not None and self.output not in ("position", "velocity", "current"):
            raise OptionError(f"--output {self.output!r}: use position, velocity or current")
        if self.sensors is not None:
            bad = [x for x in self.sensors if x not in ("position", "velocity", "current")]
            if bad or not self.sensors or len(set(self.sensors)) != len(self.sensors):
                raise OptionError(f"--sensors {','.join(map(str, self.sensors))}: give distinct channels among "
                                  "position, velocity and current (what the rig measures; derivatives are estimated)")
        if self.robust_fraction is not None:
            f = self.robust_fraction
            if isinstance(f, bool) or not isinstance(f, (int, float)) or not 0 < f < 1:
                raise OptionError(f"--robust must be a fraction in (0, 1), e.g. 0.95, got {f!r}")
            if self.settling_time_s is None:
                raise OptionError("--robust tunes against a spec: give --settling-time and --overshoot")
        n = self.robust_samples
        if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not (n == 0 or 10 <= n <= 1_000_000):
            raise OptionError(f"--robust-samples must be 0 (no check) or a whole number from 10 to 1000000, got {n!r}")


def _pairs(values: np.ndarray | None) -> list[list[float]] | None:
    if values is None:
        return None
    v = np.asarray(values, dtype=complex)
    # a repeated pole of a defective matrix comes out of eig split by ~1e-8·|p|: print it as real
    v = np.where(np.abs(v.imag) < 1e-6 * np.maximum(1.0, np.abs(v)), v.real + 0j, v)
    order = np.lexsort((-v.imag, v.real))
    return [[float(v[i].real), float(v[i].imag)] for i in order]


@dataclass(frozen=True, slots=True)
class Design:
    """A designed controller (docs/formats.md "Design JSON").

    Attributes
    ----------
    states : tuple of str
        The states ``K`` acts on, in order: measured quantities (``position``, ``velocity``,
        ``current``, ``acceleration``, …; :mod:`.coordinates`) for identified models.
    output : str
        The measured channel ``y`` (integrator and observer input).
    K : ndarray, shape (n,)
        State-feedback row of ``u = −K x + kr r`` (``u = −K x − ki z`` with integral action).
    kr : float or None
        Reference gain (eq. 37); None with integral action.
    ki : float or None
        Integral gain.
    L : ndarray, shape (n,) or None
        Observer gain column.
    closed_loop_poles : ndarray
        Eigenvalues of the state-feedback loop (augmented with ``z`` under integral action).
    observer_poles : ndarray or None
        ``eig(A − L C)``.
    output_feedback_poles : ndarray or None
        Eigenvalues of plant + observer + feedback of the estimate: the union of the two sets
        above (separation principle), computed from the full matrix, not assumed.
    routh : tuple of str
        Routh–Hurwitz conditions on the gains for this model (eqs. 43–47).
    warnings : tuple of str
    model_states : tuple of str or None
        The identified model's own state names when the design was done in measurable
        coordinates (:mod:`.coordinates`); None when ``states`` are the model's.
    transform : ndarray, shape (n, n), or None
        ``T`` of ``states = T · model_states``; ``K @ T`` is the gain row on the model's states.
    dead_zone_v : float or None
        The model's dead-zone (a Hammerstein model from several step levels), offered for
        compensation by inverse dead-zone feed-forward (``u + u₀·sign(u)``).
    units : Mapping[str, str]
        The model's channel units (``{"velocity": "rpm"}``): a gain on the velocity is per rpm.
    margins : LoopMargins or None
        Gain, phase and delay margins, sensitivity peak and bandwidth of the loop on the model
        it was designed for (:mod:`.margins`); None for a design read from a JSON without them.
    robust : RobustCheck or None
        The design on the motors the model's uncertainty allows (:mod:`.robust`); None when
        not checked (a warning says why, when it was asked for).
    sensors : tuple of str or None
        The channels the controller reads (None: every state, the older designs' assumption).
    reduced : ReducedObserver or None
        The reduced-order observer of the states the sensors do not measure:
        ``u = −K_m z_m − K_u ẑ_u (+ kr r | − ki z)``.
    """

    states: tuple[str, ...]
    output: str
    K: np.ndarray
    kr: float | None
    ki: float | None
    L: np.ndarray | None
    closed_loop_poles: np.ndarray
    observer_poles: np.ndarray | None
    output_feedback_poles: np.ndarray | None
    routh: tuple[str, ...]
    warnings: tuple[str, ...] = field(default=())
    model_states: tuple[str, ...] | None = None
    transform: np.ndarray | None = None
    dead_zone_v: float | None = None
    units: Mapping[str, str] = field(default_factory=dict)
    margins: LoopMargins | None = None
    robust: RobustCheck | None = None
    sensors: tuple[str, ...] | None = None
    reduced: ReducedObserver | None = None

    @property
    def K_model(self) -> np.ndarray:
        """The gain row on the identified model's own states (``K T``; ``K`` without a transform)."""
        return self.K if self.transform is None else self.K @ self.transform

    @property
    def L_model(self) -> np.ndarray | None:
        """The observer gain on the model's own states (``T⁻¹ L``)."""
        if self.L is None or self.transform is None:
            return self.L
        return np.linalg.solve(self.transform, self.L)

    def sensor_gains(self) -> list[tuple[str, float, str]]:
        """``(state, gain, unit)`` per measured quantity, e.g. ``("velocity", 8.5, "per V of the tacho")``.

        Returns
        -------
        list of (str, float, str)
            One ``(state, gain, unit)`` per state of ``K``.
        """
        return [(name, float(k), sensor_unit(name, self.units)) for name, k in zip(self.states, self.K, strict=False)]

    def reference_units(self) -> tuple[str, str]:
        """The units of ``kr`` and ``ki``: command per unit of the reference, per unit·s of the error.

        Returns
        -------
        tuple of (str, str)
            E.g. ``("V per rpm of the reference", "V per (rpm·s) of the integrated error")``.
        """
        command, out = channel_unit(self.units, "input"), channel_unit(self.units, self.output)
        return f"{command} per {out} of the reference", f"{command} per ({out}·s) of the integrated error"

    def to_dict(self) -> dict[str, Any]:
        """The design JSON as a dict (:meth:`to_json` is the older name of the same).

        Returns
        -------
        dict
            JSON-able.
        """
        return self.to_json()

    def to_json(self) -> dict[str, Any]:
        """The docs/formats.md "Design JSON" dict (schema ``motorid.design/1``) plus extras.

        The extras: ``output``, ``output_feedback_poles``, ``gains`` (per sensor) and, for a design
        in measurable coordinates, ``model_states``, ``transform``, ``K_model`` and ``L_model``.

        Returns
        -------
        dict
            JSON-able; complex poles as ``[re, im]`` pairs.
        """
        extra: dict[str, Any] = {
            "gains": [{"state": n, "gain": g, "unit": u} for n, g, u in self.sensor_gains()],
        }
        if self.transform is not None and self.model_states is not None:
            extra["model_states"] = list(self.model_states)
            extra["transform"] = [[float(v) for v in row] for row in self.transform]
            extra["K_model"] = [float(v) for v in self.K_model]
            lm = self.L_model
            extra["L_model"] = None if lm is None else [float(v) for v in lm]
        return extra | {
            "schema": SCHEMA,
            "states": list(self.states),
            "output": self.output,
            "K": [float(v) for v in self.K],
            "kr": self.kr,
            "ki": self.ki,
            "L": None if self.L is None else [float(v) for v in self.L],
            "closed_loop_poles": _pairs(self.closed_loop_poles),
            "observer_poles": _pairs(self.observer_poles),
            "output_feedback_poles": _pairs(self.output_feedback_poles),
            "routh": list(self.routh),
            "warnings": list(self.warnings),
        } | ({} if self.dead_zone_v is None else {"dead_zone": self.dead_zone_info()}) | (
            {"units": dict(self.units)} if self.units else {}) | (
            {} if self.margins is None else {"margins": self.margins.to_json()}) | (
            {} if self.robust is None else {"robust": self.robust.to_json()}) | (
            {} if self.sensors is None else {"sensors": list(self.sensors)}) | (
            {} if self.reduced is None else {"reduced_observer": self.reduced.to_json()})

    def dead_zone_info(self) -> dict[str, Any]:
        """The dead-zone and the steady-state error it leaves, with and without compensation.

        A position loop without integral action stops wherever the command ``|K x|`` falls
        inside the dead-zone, so a position step can end anywhere within
        ``±u₀ / |k_position|`` of the reference; the inverse dead-zone feed-forward adds
        ``u₀·sign(u)`` to the command and removes that band (up to the model's error in u₀).

        Returns
        -------
        dict
            ``value`` (u₀, V), ``steady_state_error_bound_v`` (None without a position gain or
            with integral action) and ``compensation`` (what to add to the command).
        """
        u0 = float(self.dead_zone_v or 0.0)
        bound = None
        if "position" in self.states and self.ki is None:
            kp = abs(float(self.K[self.states.index("position")]))
            bound = u0 / kp if kp > 0 else None
        return {"value": u0, "steady_state_error_bound_v": bound,
                "compensation": "inverse dead-zone feed-forward: u + u0·sign(u) (simulate --compensate-dead-zone)"}

    def to_json_text(self) -> str:
        """:meth:`to_json` as indented text.

        Returns
        -------
        str
            The JSON text.
        """
        return json.dumps(self.to_json(), indent=2)

    @classmethod
    def from_json(cls, data: Any, *, file: str | None = None) -> Design:
        """Rebuild a design from :meth:`to_json` output, checking every entry's type and shape.

        Raises
        ------
        OptionError
            On a wrong schema or a malformed entry (the message names the key).
        """
        try:
            return cls._from_json(data)
        except OptionError as exc:
            raise (exc.with_file(file) if file else exc) from None
        except (KeyError, TypeError, ValueError, AttributeError, IndexError, RecursionError) as exc:
            raise OptionError(f"not a motorid design: bad or missing entry ({exc!s})", file=file) from None

    @classmethod
    def _from_json(cls, data: Any) -> Design:
        if not isinstance(data, dict) or data.get("schema") != SCHEMA:
            got = data.get("schema") if isinstance(data, dict) else type(data).__name__
            raise OptionError(f"not a motorid design: schema is {got!r}, expected {SCHEMA!r}")

        def bad(key: str, what: str) -> OptionError:
            return OptionError(f"not a motorid design: key {key!r} {what}")

        def names(key: str) -> tuple[str, ...]:
            v = data.get(key)
            if not isinstance(v, list) or not v or not all(isinstance(x, str) and x for x in v) \
                    or len(set(v)) != len(v):
                raise bad(key, "must be a non-empty list of distinct state names")
            return tuple(v)

        def vector(key: str, n: int | None) -> np.ndarray:
            v = data.get(key)
            if not isinstance(v, list) or not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
                raise bad(key, "must be a list of numbers")
            arr = np.array(v, dtype=float)
            if n is not None and arr.size != n:
                raise bad(key, f"has {arr.size} entries, expected {n} (one per state)")
            if not np.all(np.isfinite(arr)):
                raise bad(key, "must hold finite numbers")
            return arr

        def number(key: str) -> float | None:
            v = data.get(key)
            if v is None:
                return None
            if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(float(v)):
                raise bad(key, "must be a finite number or null")
            return float(v)

        def poles(key: str) -> np.ndarray | None:
            v = data.get(key)
            if v is None:
                return None
            if not isinstance(v, list) or not all(
                    isinstance(p, list) and len(p) == 2 and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                                for x in p) for p in v):
                raise bad(key, "must be a list of [re, im] pairs")
            arr = np.array([complex(a, b) for a, b in v], dtype=complex)
            if not np.all(np.isfinite(arr)):
                raise bad(key, "must hold finite numbers")
            return arr

        def strings(key: str) -> tuple[str, ...]:
            v = data.get(key) or []
            if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
                raise bad(key, "must be a list of strings")
            return tuple(v)

        states = names("states")
        n = len(states)
        k = vector("K", n)
        out = data.get("output", "position")
        if not isinstance(out, str):
            raise bad("output", "must be a channel name")
        model_states = transform = None
        if data.get("transform") is not None or data.get("model_states") is not None:
            model_states = names("model_states")
            t = data.get("transform")
            if not isinstance(t, list) or len(t) != n or len(model_states) != n:
                raise bad("transform", f"must be a {n}×{n} matrix (states × model_states)")
            transform = np.vstack([_matrix_row(row, "transform", n) for row in t])
        kr, ki = number("kr"), number("ki")
        l_vec = None if data.get("L") is None else vector("L", n)
        cl_poles = poles("closed_loop_poles")
        return cls(states, out, k, kr, ki, l_vec,
                   cl_poles if cl_poles is not None else np.zeros(0, complex),
                   poles("observer_poles"), poles("output_feedback_poles"), strings("routh"), strings("warnings"),
                   model_states, transform, number_of(data.get("dead_zone")), _units(data.get("units")),
                   _margins(data.get("margins")), _robust(data.get("robust")),
                   None if data.get("sensors") is None else strings("sensors"),
                   None if data.get("reduced_observer") is None
                   else ReducedObserver.from_json(data["reduced_observer"], states))


def _robust(entry: Any) -> RobustCheck | None:
    if entry is None:
        return None
    if not isinstance(entry, dict):
        raise OptionError("not a motorid design: key 'robust' must be an object")
    try:
        return RobustCheck.from_json(entry)
    except ValueError as exc:
        raise OptionError(f"not a motorid design: {exc}") from None


def _margins(entry: Any) -> LoopMargins | None:
    if entry is None:
        return None
    if not isinstance(entry, dict):
        raise OptionError("not a motorid design: key 'margins' must be an object")
    try:
        return LoopMargins.from_json(entry)
    except ValueError as exc:
        raise OptionError(f"not a motorid design: {exc}") from None


def _units(entry: Any) -> dict[str, str]:
    """A design JSON's ``units`` (channel → unit); an absent or malformed entry is scope volts."""
    if not isinstance(entry, dict):
        return {}
    return {str(k): str(v) for k, v in entry.items() if isinstance(v, str) and v}


def number_of(entry: Any) -> float | None:
    """The ``value`` of a design JSON's ``dead_zone`` entry, or None when absent or malformed.

    Parameters
    ----------
    entry : Any
        The decoded ``dead_zone`` object.

    Returns
    -------
    float or None
    """
    if not isinstance(entry, dict):
        return None
    v = entry.get("value")
    if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(float(v)) and v >= 0:
        return float(v)
    return None


def _matrix_row(row: Any, key: str, n: int) -> np.ndarray:
    """One row of a JSON matrix as ``n`` finite floats, or OptionError naming ``key``."""
    if not isinstance(row, list) or len(row) != n or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in row):
        raise OptionError(f"not a motorid design: key {key!r} must be a matrix of numbers with {n} columns")
    arr = np.array(row, dtype=float)
    if not np.all(np.isfinite(arr)):
        raise OptionError(f"not a motorid design: key {key!r} must hold finite numbers")
    return arr


def default_output(model: MotorModel) -> str:
    """The channel a design reads when none is named: the position if the model has it, else the velocity.

    Parameters
    ----------
    model : MotorModel

    Returns
    -------
    str
    """
    return "position" if "position" in model.outputs else "velocity"


def output_row(model: MotorModel, output: str | None) -> tuple[str, np.ndarray]:
    """The measured channel's name and ``C`` row (position by default, else velocity).

    Parameters
    ----------
    model : MotorModel
        The model the controller is designed for.
    output : str or None
        The measured channel; ``None``: position if the model has it, else velocity.

    Returns
    -------
    (str, ndarray)
        The channel's name and its ``C`` row, shape (1, n).

    Raises
    ------
    OptionError
        For a channel the model does not have, or a direct feed-through on it.
    """
    name = output or default_output(model)
    if name not in model.outputs:
        raise OptionError(f"--output {name!r}: the model's outputs are {list(model.outputs)}")
    i = model.outputs.index(name)
    if model.D[i, 0] != 0.0:
        raise OptionError(f"the {name} output has a direct feed-through (D ≠ 0); state feedback here "
                          "assumes a strictly proper model")
    return name, model.C[i: i + 1]


def _gain_names(n: int) -> tuple[str, ...]:
    return tuple(f"k{i + 1}" for i in range(n))


def design_model(model: MotorModel, design: Design) -> MotorModel:
    """``model`` in the coordinates ``design`` was made in (its ``states``).

    Parameters
    ----------
    model : MotorModel
        The identified model (any realisation the design was made from).
    design : Design

    Returns
    -------
    MotorModel
        ``model`` itself when the design's states are its own; else the model re-expressed
        with the design's recorded ``transform`` (or, for a design without one, the
        measurable realisation of :mod:`.coordinates`).

    Raises
    ------
    OptionError
        When the design was made for a model with other states.
    """
    if tuple(design.states) == tuple(model.states) and design.transform is None:
        return model
    n = model.A.shape[0]
    if design.transform is not None and design.model_states is not None:
        if tuple(design.model_states) == tuple(model.states) and design.transform.shape == (n, n):
            return realise_in(model, design.transform, tuple(design.states))
    else:
        mr = measurable_realisation(model)
        if mr.states == tuple(design.states):
            return mr.model
    raise OptionError(f"the design is for states {list(design.model_states or design.states)}, "
                      f"the model has {list(model.states)}; design on this model first")


def _check_placed(placed: np.ndarray, wanted: np.ndarray) -> list[str]:
    """A warning when the eigenvalues reached differ from the poles asked for."""
    got = list(np.asarray(placed, dtype=complex))
    scale = max(1.0, float(np.max(np.abs(wanted))))
    worst = 0.0
    for w in np.asarray(wanted, dtype=complex):
        j = int(np.argmin([abs(g - w) for g in got]))
        worst = max(worst, abs(got.pop(j) - w))
    # repeated poles of a defective loop come out of eig split by ~eps^(1/m); 1e-4 leaves triples
    if worst > 1e-4 * scale:
        return [f"the closed-loop poles reached differ from the ones asked for by up to {worst:.3g} "
                "(ill-conditioned placement); check the poles printed"]
    return []


def _dead_time_warnings(delay_s: float, margins: LoopMargins) -> list[str]:
    """What the model's dead time does to the loop, in the numbers of its margins.

    Pole placement works on the delay-free state-space model; the margins are those of the loop
    with the dead time in it (:mod:`.margins`), so the warning and the margins line agree.
    """
    if not delay_s > 0:
        return []
    ms = 1e3 * delay_s
    pm, wc, extra = margins.phase_deg, margins.crossover_rad_s, margins.delay_s
    if not (math.isfinite(pm) and math.isfinite(wc)):
        return [f"the model has a {ms:.3g} ms dead time that pole placement ignores (the loop gain never crosses "
                "1, so it cannot destabilise it); simulate applies it"]
    if pm <= 0 or extra <= 0:
        return [f"UNSTABLE with the model's dead time: with its {ms:.3g} ms in the loop the phase margin is "
                f"{pm:.3g}° at {wc:.3g} rad/s; ask for slower closed-loop poles"]
    return [f"the model's {ms:.3g} ms dead time is not in the pole placement: with it in the loop the phase margin "
            f"is {pm:.3g}° at {wc:.3g} rad/s and {1e3 * extra:.3g} ms more delay is tolerated, so the closed loop "
            "is less damped than the poles say; simulate applies the dead time"]


#: ``--robust``: each step asks the nominal design for this fraction of the previous step's
#: settling time and overshoot, at most :data:`ROBUST_STEPS` times.
ROBUST_TIGHTEN = 0.85
ROBUST_STEPS = 12
#: Plausible motors each tuning step is checked on (the final design on ``robust_samples``).
ROBUST_SEARCH_SAMPLES = 400


def _robust_tuned(model: MotorModel, s: DesignSettings) -> Design:
    """The design whose own targets are tightened until ``s.robust_fraction`` of the motors meet ``s``'s spec."""
    spec_ts, spec_os = cast(float, s.settling_time_s), cast(float, s.overshoot_pct)
    spec = RobustSpec(spec_os, spec_ts)
    ts, os_pct = spec_ts, spec_os
    tried: list[tuple[float, float, float]] = []
    for _ in range(ROBUST_STEPS):
        trial = replace(s, settling_time_s=ts, overshoot_pct=os_pct, robust_fraction=None, robust_samples=0)
        design = design_controller(model, trial)
        check = robust_check(model, design, samples=ROBUST_SEARCH_SAMPLES, spec=spec)
        tried.append((ts, os_pct, cast(float, check.spec_fraction)))
        if cast(float, check.spec_fraction) >= cast(float, s.robust_fraction):
            break
        ts, os_pct = ts * ROBUST_TIGHTEN, os_pct * ROBUST_TIGHTEN
    best_ts, best_os, _ = max(tried, key=lambda x: x[2])
    final = design_controller(model, replace(s, settling_time_s=best_ts, overshoot_pct=best_os, robust_fraction=None,
                                             robust_samples=0))
    final = replace(final, robust=robust_check(model, final, samples=max(s.robust_samples, ROBUST_SEARCH_SAMPLES),
                                               spec=spec))
    got = cast(float, cast(RobustCheck, final.robust).spec_fraction)
    from motorid.numfmt import sig

    how = (f"--robust {sig(cast(float, s.robust_fraction))}: designed for settling {sig(best_ts)} s and overshoot "
           f"{sig(best_os)} % so that {100 * got:.1f} % of the plausible motors meet settling ≤ {sig(spec_ts)} s, "
           f"overshoot ≤ {sig(spec_os)} % (the nominal design for the spec itself: "
           f"{100 * tried[0][2]:.1f} %)")
    if got < cast(float, s.robust_fraction):
        how += f"; {len(tried)} tightenings did not reach the fraction: ask for a looser spec or identify again"
    return replace(final, warnings=(*final.warnings, how))


@single_blas_thread
def design_controller(model: MotorModel, settings: DesignSettings) -> Design:
    """Design state feedback (with optional integral action and observer) for ``model``.

    The design is done in measurable coordinates (:func:`.coordinates.measurable_realisation`:
    position, velocity, current or acceleration), so ``K`` holds one gain per sensor; the
    row on the model's own states is :attr:`Design.K_model`.

    Parameters
    ----------
    model : MotorModel
    settings : DesignSettings

    Returns
    -------
    Design

    Raises
    ------
    OptionError
        Conflicting or missing pole specifications, bad poles (count, conjugates, finiteness,
        magnitude, unstable observer poles), non-finite gains, a pole pair asked of a
        one-state model.
    ControlDesignError
        Uncontrollable or unobservable model, no stabilising ``k1`` for the given ``k2``.

    References
    ----------
    Tsiolakis 2022, eqs. 30–58.
    """
    s = settings  # validated on construction (DesignSettings.__post_init__)
    if s.robust_fraction is not None:
        try:
            return _robust_tuned(model, s)
        except RobustCheckUnavailable as exc:
            raise OptionError(f"--robust needs the model's uncertainty: {exc}") from None
    mr = measurable_realisation(model)
    work = mr.model
    a, b = work.A, work.B
    n = a.shape[0]
    out_name, c = output_row(work, s.output)
    # a pole pair (damping/ωn, settling time/overshoot) on the loop with the integrator when the
    # integrator's pole is not given otherwise
    pair_with_integrator = s.integral and s.ki is None and s.integral_pole is None and s.poles is None
    n_pair = n + 1 if pair_with_integrator else n
    if (s.settling_time_s is not None or s.overshoot_pct is not None or s.wn is not None) and n_pair < 2:
        which = "--damping/--wn" if s.wn is not None else "--settling-time/--overshoot"
        raise OptionError(f"{which} place a pole pair, but this model has one state ({work.states[0]}): "
                          "give one real pole with --poles (e.g. --poles -5), or add --integral to place "
                          "the pair with the integrator")
    check_controllable(a, b)
    if s.observer_poles is not None:
        from motorid.control.observer import check_observable

        check_observable(a, c, out_name)
    warnings: list[str] = list(mr.warnings)
    k, poles = _requested_poles(s, a, b, n, n_pair, warnings)
    ki: float | None
    kr: float | None
    if s.integral:
        k, ki, kr, routh, cl = _integral_loop(s, a, b, c, k, poles, warnings)
    else:
        k, ki, kr, routh, cl = _state_feedback_loop(a, b, c, k, poles, warnings)
    k_row = k.ravel()
    if not np.all(np.isfinite(k_row)) or (ki is not None and not math.isfinite(ki)):
        raise ControlDesignError("the placement gave non-finite gains; choose other poles")
    big = float(np.max(np.abs(k_row)))
    if big > LARGE_GAIN:
        i = int(np.argmax(np.abs(k_row)))
        warnings.append(f"the gain on {work.states[i]} is {k_row[i]:.3g}: far beyond what a sensor and an "
                        "amplifier can use (noise × that gain; a sampled loop needs a much shorter interval); "
                        "check the model's open-loop poles or ask for slower closed-loop poles")
    l_col = obs = ofb = None
    reduced = None
    sensors = _sensors(s, model, tuple(work.states))
    unmeasured = 0 if sensors is None else n - len(sensors)
    if s.observer_poles is not None and (len(s.observer_poles) == n or unmeasured == 0):
        l_col, obs, ofb = _observer(s, a, b, c, k, ki, cl, out_name, warnings)
        sensors = (out_name,)
    elif sensors is not None and set(sensors) != set(work.states):
        if s.observer_poles is not None and len(s.observer_poles) != unmeasured:
            raise OptionError(f"--observer-poles: give {n} poles (a full observer from {out_name}) or "
                              f"{unmeasured}, one per state the sensors do not measure (a reduced-order observer of "
                              f"{', '.join(x for x in work.states if x not in sensors)})")
        if s.integral and out_name not in sensors:
            raise OptionError(f"integral action integrates the measured {out_name}: add it to --sensors "
                              f"(given: {','.join(sensors)})")
        if s.observer_poles is None:
            reduced = _default_reduced_observer(a, b, c, k, ki, cl, tuple(work.states), sensors, warnings)
        else:
            reduced = reduced_observer(a, b, tuple(work.states), sensors, np.asarray(s.observer_poles, dtype=complex))
        obs = reduced.poles
        ofb = np.linalg.eigvals(reduced_loop_matrix(a, b, c, k, ki, reduced, tuple(work.states)))
    elif s.observer_poles is not None:
        raise OptionError(f"--observer-poles: give {n} poles (a full observer from {out_name}) or one per "
                          "state the sensors do not measure (a reduced-order observer)")
    changed = mr.changed
    nl = model.static_nonlinearity
    design = Design(tuple(work.states), out_name, k_row, kr, ki, l_col, cl, obs, ofb, tuple(routh),
                    tuple(warnings), mr.source_states if changed else None, mr.transform if changed else None,
                    None if nl is None else nl.dead_zone_v, dict(model.units), sensors=sensors, reduced=reduced)
    margins = loop_margins(model, design)
    design = replace(design, margins=margins,
                     warnings=(*design.warnings, *_dead_time_warnings(model.delay_s, margins)))
    if s.robust_samples:
        spec = RobustSpec(s.overshoot_pct, s.settling_time_s)
        try:
            design = replace(design, robust=robust_check(model, design, samples=s.robust_samples, spec=spec))
        except RobustCheckUnavailable as exc:
            design = replace(design, warnings=(*design.warnings, f"robustness not checked: {exc}"))
        else:
            design = replace(design, warnings=(*design.warnings, *_spec_missed(cast(RobustCheck, design.robust))))
    return design


def _spec_missed(check: RobustCheck) -> list[str]:
    """Why the model's own loop misses the ``--settling-time``/``--overshoot`` it was designed for, and what to do."""
    missed = check.nominal_misses()
    if not missed:
        return []
    return [f"the designed loop misses the spec on the model itself: {missed}. --settling-time and --overshoot "
            "place the dominant pair by the textbook rules: ζ from the overshoot (exact for a lone pair) and "
            "ωn = 4/(ζ·Ts) (when the pair's 2 % envelope has settled; the step itself may leave the band later), "
            "and the loop's other poles, zeros and observer move the step further. Ask for a shorter settling time "
            "or a smaller overshoot, or let --robust F tune the design until a fraction F of the plausible motors "
            "meets the spec"]


def _sensors(s: DesignSettings, model: MotorModel, states: tuple[str, ...]) -> tuple[str, ...] | None:
    """The states the rig measures, in the design's state order (None: the states are not sensors)."""
    physical = ("position", "velocity", "current", "acceleration", "jerk")
    if not all(x in physical or x.startswith("velocity_d") for x in states):
        if s.sensors is not None:
            raise OptionError(f"--sensors: this model's states ({', '.join(states)}) are not quantities a sensor "
                              "measures (its realisation could not be re-expressed in them)")
        return None
    wanted = s.sensors if s.sensors is not None else tuple(o for o in model.outputs
                                                            if o in ("position", "velocity", "current"))
    missing = [x for x in wanted if x not in states]
    if missing and s.sensors is not None:
        raise OptionError(f"--sensors {','.join(s.sensors)}: the model has no {' or '.join(missing)} state "
                          f"(its states: {', '.join(states)})")
    measured = tuple(x for x in states if x in wanted)
    return measured or None


#: The default reduced observer is made faster (×2 each time, up to :data:`OBSERVER_SPEED_MAX`
#: times the controller's fastest pole) until the loop's sensitivity peak is at most this
#: (Skogestad's upper limit for a robust loop): an estimate fed back with a large gain (a
#: model whose velocity follows the command at once) costs phase a slow observer cannot give.
OBSERVER_MS_MAX = 2.0
OBSERVER_SPEED_MAX = 64.0


def _default_reduced_observer(a: np.ndarray, b: np.ndarray, c: np.ndarray, k: np.ndarray, ki: float | None,
                              cl: np.ndarray, states: tuple[str, ...], sensors: tuple[str, ...],
                              warnings: list[str]) -> ReducedObserver:
    """The reduced observer with default poles, fast enough that the loop keeps Ms ≤ :data:`OBSERVER_MS_MAX`."""
    from motorid.control.margins import sensitivity_peak
    from motorid.control.reduced_observer import OBSERVER_SPEED, reduced_loop

    speed, best = OBSERVER_SPEED, None
    while True:
        obs = reduced_observer(a, b, states, sensors, default_poles(cl, len(states) - len(sensors), speed))
        ms = sensitivity_peak(*reduced_loop(a, b, c, k, ki, obs, states))
        if best is None or ms < best[0]:
            best = (ms, speed, obs)
        if ms <= OBSERVER_MS_MAX or speed >= OBSERVER_SPEED_MAX:
            break
        speed *= 2.0
    ms, speed, obs = best
    if speed > OBSERVER_SPEED or ms > OBSERVER_MS_MAX:
        warnings.append(f"the observer's poles are {speed:g}× the controller's fastest, where the loop's sensitivity "
                        f"peak is {ms:.3g}" + (
                            f" ≤ {OBSERVER_MS_MAX:g}" if ms <= OBSERVER_MS_MAX else
                            f", still above {OBSERVER_MS_MAX:g}: the estimate is fed back with a large gain; "
                            "ask for slower closed-loop poles or measure that state"))
    return obs


def _requested_poles(s: DesignSettings, a: np.ndarray, b: np.ndarray, n: int, n_pair: int,
                     warnings: list[str]) -> tuple[np.ndarray | None, np.ndarray | None]:
    """The poles asked for (explicit, ζ/ωn or specs), or the gains of the report's k2 → k1 design."""
    if s.poles is not None:
        raw = np.asarray(s.poles, dtype=complex)
        want = n + 1 if (s.integral and raw.size == n + 1 and s.ki is None and s.integral_pole is None) else n
        poles = check_poles(raw, want, option="--poles")
        check_pole_range(poles, a)
        return None, poles
    if s.damping is not None:
        if s.k2 is not None:
            k2 = float(check_gains([s.k2], "--k2")[0])
            k1, _ = k1_for_damping(a, b, k2, float(s.damping))
            return np.array([[k1, k2]]), None
        wn = cast(float, s.wn)  # DesignSettings: --damping without --k2 comes with --wn
        poles, w = poles_from_damping(float(s.damping), float(wn), n_pair)
        check_pole_range(poles, a, option="--wn")
        warnings += w
        return None, poles
    # DesignSettings: neither --poles nor --damping means --settling-time with --overshoot
    ts, os_pct = cast(float, s.settling_time_s), cast(float, s.overshoot_pct)
    poles, w = poles_from_specs(float(ts), float(os_pct), n_pair)
    check_pole_range(poles, a, option="--settling-time")
    warnings += w
    return None, poles


def _integral_loop(s: DesignSettings, a: np.ndarray, b: np.ndarray, c: np.ndarray, k: np.ndarray | None,
                   poles: np.ndarray | None, warnings: list[str],
                   ) -> tuple[np.ndarray, float, None, list[str], np.ndarray]:
    """Gains with integral action ``ż = y − r`` and its Routh–Hurwitz check (report §3)."""
    n = a.shape[0]
    poly = integral_poly(a, b, c, _gain_names(n))
    if poles is not None and poles.size == n + 1:
        k, ki = integral_gains(a, b, c, poles)
    elif s.integral_pole is not None:
        ip = check_poles([s.integral_pole], 1, "integral", "--integral-pole")
        if ip[0].imag != 0:
            raise OptionError("--integral-pole must be real (a lone complex pole has no conjugate)")
        check_pole_range(ip, a, "integral", "--integral-pole")
        state_poles = poles if poles is not None else np.linalg.eigvals(a - b @ cast(np.ndarray, k))
        k, ki = integral_gains(a, b, c, np.concatenate([state_poles, ip]))
    elif s.ki is not None:
        ki = float(check_gains([s.ki], "--ki")[0])
        if k is None:  # no --k2: the branches above placed poles
            k = place_gains(a, b, cast(np.ndarray, poles))
    else:
        raise OptionError("--integral needs --ki, --integral-pole, or n + 1 values in --poles")
    gains = np.concatenate([k.ravel(), [ki]])
    routh = routh_conditions(poly)
    bad = routh_violations(poly, gains)
    if bad:
        warnings.append("the gains violate the Routh–Hurwitz condition(s): " + "; ".join(bad)
                        + " — the closed loop is unstable")
    from motorid.control.integral import augment_integral

    aa, ba = augment_integral(a, b, c)
    cl = np.linalg.eigvals(aa - ba @ gains.reshape(1, -1))
    if poles is not None and poles.size == n + 1:
        warnings += _check_placed(cl, poles)
    return k, ki, None, list(routh), cl


def _state_feedback_loop(a: np.ndarray, b: np.ndarray, c: np.ndarray, k: np.ndarray | None,
                         poles: np.ndarray | None, warnings: list[str],
                         ) -> tuple[np.ndarray, None, float, list[str], np.ndarray]:
    """Gains of plain state feedback with the reference gain ``kr`` (report §2)."""
    n = a.shape[0]
    if k is None:  # no --k2: the branches above placed poles
        k = place_gains(a, b, cast(np.ndarray, poles))
    poly = affine_char_poly(a, b, _gain_names(n))
    routh = routh_conditions(poly)
    cl = np.linalg.eigvals(a - b @ k)
    if poles is not None:
        warnings += _check_placed(cl, poles)
    if np.any(cl.real >= 0):
        warnings.append("the state-feedback loop is unstable; kr is not meaningful")
    return k, None, reference_gain(a, b, c, k), list(routh), cl


def _observer(s: DesignSettings, a: np.ndarray, b: np.ndarray, c: np.ndarray, k: np.ndarray, ki: float | None,
              cl: np.ndarray, out_name: str, warnings: list[str]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Luenberger observer gain, its poles and the output-feedback poles (report §4)."""
    n = a.shape[0]
    op = check_poles(np.asarray(s.observer_poles, dtype=complex), n, "observer", "--observer-poles",
                     require_stable=True)
    check_pole_range(op, a, "observer", "--observer-poles")
    l_col = observer_gain(a, c, op, out_name)
    if not np.all(np.isfinite(l_col)):
        raise ControlDesignError("the observer placement gave non-finite gains; choose other observer poles")
    obs = np.linalg.eigvals(a - l_col @ c)
    ofb = np.linalg.eigvals(output_feedback_matrix(a, b, c, k, l_col, ki))
    slow_obs = float(np.max(obs.real))
    if slow_obs > float(np.max(cl.real)) / 2:
        warnings.append("the observer is not clearly faster than the controller (its slowest pole "
                        f"{slow_obs:.3g} vs {float(np.max(cl.real)):.3g}); estimates will lag")
    return l_col.ravel(), obs, ofb

"""One controller design on a :class:`~motorid.model.MotorModel`: the ``motorid design`` job.

Combines state feedback (:mod:`.feedback`), integral action (:mod:`.integral`) and an observer
(:mod:`.observer`) into a frozen :class:`Design` written as CONTRACT.md "Design JSON".
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from motorid.control.feedback import (
    ControlDesignError,
    check_controllable,
    check_gains,
    check_poles,
    k1_for_damping,
    place_gains,
    poles_from_damping,
    poles_from_specs,
    reference_gain,
)
from motorid.control.integral import integral_gains, integral_poly, routh_violations
from motorid.control.observer import observer_gain, output_feedback_matrix
from motorid.control.routh import affine_char_poly, routh_conditions
from motorid.errors import OptionError
from motorid.model import MotorModel

__all__ = ["SCHEMA", "DesignSettings", "Design", "design_controller", "output_row"]

SCHEMA = "motorid.design/1"


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
    """A designed controller (CONTRACT.md "Design JSON").

    Attributes
    ----------
    states : tuple of str
        The model's state names (the order of ``K``).
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

    def to_json(self) -> dict[str, Any]:
        """The CONTRACT.md "Design JSON" dict (schema ``motorid.design/1``), plus ``output`` and
        ``output_feedback_poles``."""
        return {
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
        }

    def to_json_text(self) -> str:
        """:meth:`to_json` as indented text."""
        return json.dumps(self.to_json(), indent=2)

    @classmethod
    def from_json(cls, data: Any, *, file: str | None = None) -> "Design":
        """Rebuild a design from :meth:`to_json` output.

        Raises
        ------
        OptionError
            On a wrong schema or malformed entries.
        """
        try:
            if not isinstance(data, dict) or data.get("schema") != SCHEMA:
                got = data.get("schema") if isinstance(data, dict) else type(data).__name__
                raise OptionError(f"not a motorid design: schema is {got!r}, expected {SCHEMA!r}", file=file)
            c = lambda p: None if p is None else np.array([complex(a, b) for a, b in p])  # noqa: E731
            K = check_gains(data["K"], "design K")
            L = None if data.get("L") is None else check_gains(data["L"], "design L")
            return cls(tuple(data["states"]), str(data.get("output", "position")), K,
                       None if data.get("kr") is None else float(data["kr"]),
                       None if data.get("ki") is None else float(data["ki"]), L,
                       c(data.get("closed_loop_poles") or []), c(data.get("observer_poles")),
                       c(data.get("output_feedback_poles")), tuple(data.get("routh") or ()),
                       tuple(data.get("warnings") or ()))
        except OptionError as exc:
            raise exc.with_file(file) if file else exc from None
        except (KeyError, TypeError, ValueError) as exc:
            raise OptionError(f"not a motorid design: bad or missing entry ({exc!s})", file=file) from None


def output_row(model: MotorModel, output: str | None) -> tuple[str, np.ndarray]:
    """The measured channel's name and ``C`` row (position by default, else velocity).

    Raises
    ------
    OptionError
        For a channel the model does not have, or a direct feed-through on it.
    """
    name = output or ("position" if "position" in model.outputs else "velocity")
    if name not in model.outputs:
        raise OptionError(f"--output {name!r}: the model's outputs are {list(model.outputs)}")
    i = model.outputs.index(name)
    if model.D[i, 0] != 0.0:
        raise OptionError(f"the {name} output has a direct feed-through (D ≠ 0); state feedback here "
                          "assumes a strictly proper model")
    return name, model.C[i: i + 1]


def _gain_names(n: int) -> tuple[str, ...]:
    return tuple(f"k{i + 1}" for i in range(n))


def design_controller(model: MotorModel, settings: DesignSettings) -> Design:
    """Design state feedback (with optional integral action and observer) for ``model``.

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
        unstable observer poles), non-finite gains.
    ControlDesignError
        Uncontrollable or unobservable model, no stabilising ``k1`` for the given ``k2``.

    References
    ----------
    Tsiolakis 2022, eqs. 30–58.
    """
    s = settings
    a, b = model.A, model.B
    n = a.shape[0]
    out_name, c = output_row(model, s.output)
    names = _gain_names(n)
    ways = [s.poles is not None, s.damping is not None, s.settling_time_s is not None or s.overshoot_pct is not None]
    if sum(ways) != 1:
        raise OptionError("give exactly one of --poles, --damping (with --k2 or --wn), "
                          "or --settling-time with --overshoot")
    if s.ki is not None and s.integral_pole is not None:
        raise OptionError("give --ki or --integral-pole, not both")
    if (s.ki is not None or s.integral_pole is not None) and not s.integral:
        raise OptionError("--ki and --integral-pole need --integral")
    check_controllable(a, b)
    if s.observer_poles is not None:
        from motorid.control.observer import check_observable

        check_observable(a, c, out_name)
    warnings: list[str] = []
    k: np.ndarray | None = None
    poles: np.ndarray | None = None
    if s.poles is not None:
        raw = np.asarray(s.poles, dtype=complex)
        want = n + 1 if (s.integral and raw.size == n + 1 and s.ki is None and s.integral_pole is None) else n
        poles = check_poles(raw, want, option="--poles")
    elif s.damping is not None:
        if (s.k2 is None) == (s.wn is None):
            raise OptionError("--damping needs exactly one of --k2 (the report's design) or --wn")
        if s.k2 is not None:
            k2 = float(check_gains([s.k2], "--k2")[0])
            k1, _ = k1_for_damping(a, b, k2, float(s.damping))
            k = np.array([[k1, k2]])
        else:
            poles, w = poles_from_damping(float(s.damping), float(s.wn), n)
            warnings += w
    else:
        if s.settling_time_s is None or s.overshoot_pct is None:
            raise OptionError("--settling-time and --overshoot go together")
        poles, w = poles_from_specs(float(s.settling_time_s), float(s.overshoot_pct), n)
        warnings += w

    ki: float | None = None
    kr: float | None = None
    if s.integral:
        poly = integral_poly(a, b, c, names)
        if poles is not None and poles.size == n + 1:
            k, ki = integral_gains(a, b, c, poles)
        elif s.integral_pole is not None:
            ip = check_poles([s.integral_pole], 1, "integral", "--integral-pole")
            if ip[0].imag != 0:
                raise OptionError("--integral-pole must be real (a lone complex pole has no conjugate)")
            state_poles = poles if poles is not None else np.linalg.eigvals(a - b @ k)
            k, ki = integral_gains(a, b, c, np.concatenate([state_poles, ip]))
        elif s.ki is not None:
            ki = float(check_gains([s.ki], "--ki")[0])
            if k is None:
                k = place_gains(a, b, poles)
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
    else:
        if k is None:
            k = place_gains(a, b, poles)
        poly = affine_char_poly(a, b, names)
        routh = routh_conditions(poly)
        cl = np.linalg.eigvals(a - b @ k)
        if np.any(cl.real >= 0):
            warnings.append("the state-feedback loop is unstable; kr is not meaningful")
        kr = reference_gain(a, b, c, k)

    k_row = k.ravel()
    if not np.all(np.isfinite(k_row)) or (ki is not None and not math.isfinite(ki)):
        raise ControlDesignError("the placement gave non-finite gains; choose other poles")

    l_col = obs = ofb = None
    if s.observer_poles is not None:
        op = check_poles(np.asarray(s.observer_poles, dtype=complex), n, "observer", "--observer-poles",
                         require_stable=True)
        l_col = observer_gain(a, c, op, out_name)
        obs = np.linalg.eigvals(a - l_col @ c)
        ofb = np.linalg.eigvals(output_feedback_matrix(a, b, c, k, l_col, ki))
        slow_obs = float(np.max(obs.real))
        if slow_obs > float(np.max(cl.real)) / 2:
            warnings.append("the observer is not clearly faster than the controller (its slowest pole "
                            f"{slow_obs:.3g} vs {float(np.max(cl.real)):.3g}); estimates will lag")
        l_col = l_col.ravel()
    return Design(tuple(model.states), out_name, k_row, kr, ki, l_col, cl, obs, ofb, tuple(routh),
                  tuple(warnings))

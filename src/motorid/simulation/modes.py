"""Modes of operation of a saturated position servo over the (Kp, Kv) gain plane.

The loop is the paper's Fig. 4 / Fig. 12: ``u = sat(Kp·(r − θ) − Kv·v)`` drives a position
model (θ: position output, v: velocity output), for a 2nd-order model (first-order velocity)
and a 3rd-order one side by side.  A map simulates every grid point's step response *together*:
the state of all ``Nkp × Nkv`` loops is one ``(n, N)`` array advanced by a fixed-step RK4 in
numpy (the plant is the same for every point, only the gains differ), and each response is
reduced on the fly to a few window statistics, so no trajectories are stored.

Classification criteria (:class:`ModeCriteria`; ``e = θ − r``, step size ``R = |r|``; the
record is split into quarters; "amplitude" is half the peak-to-peak of ``e`` in a window):

1. ``unstable``: ``e`` becomes non-finite; or the last-quarter amplitude is at least
   ``unstable_amplitude·R`` (the shaft swings away from the reference by a large fraction of
   the commanded move); or an oscillation is still *growing* (last-quarter amplitude more than
   ``growth_ratio`` × the third quarter's and above the settling band).
2. Sustained oscillation: last-quarter amplitude above ``settle_band·R``, at least
   ``min_reversals`` reversals of the direction of motion in the last quarter, and amplitude
   not decaying (last quarter ≥ ``sustained_ratio`` × third quarter).  Then ``chattering`` if the
   amplitude is below ``chatter_amplitude·R`` (high-frequency, low-amplitude), else
   ``oscillatory`` (limit cycle).
3. Otherwise the response settles (or creeps monotonically): ``underdamped`` if the peak
   overshoot exceeds ``overshoot_pct`` % of R; else ``critically_damped`` when the linearised
   loop's dominant damping ``ζ_eq ≤ critical_zeta_max`` (complex pair: its ζ; two real poles
   ``p1, p2``: ``(p1 + p2)/(2√(p1 p2))``) and the response has settled into the band; else
   ``overdamped``.

References
----------
Masoud 2019, section II, Figs. 4, 5, 11–13.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from motorid._threads import single_blas_thread
from motorid.errors import OptionError
from motorid.model import MotorModel

__all__ = [
    "MODES",
    "ModeCriteria",
    "ModeMap",
    "ServoPlant",
    "classify_grid",
    "mode_map",
    "modes_json",
    "parse_range",
    "plot_mode_maps",
    "servo_plants",
    "simulate_servo_grid",
]

MODES: tuple[str, ...] = ("unstable", "overdamped", "critically_damped", "underdamped", "oscillatory", "chattering")


@dataclass(frozen=True, slots=True)
class ModeCriteria:
    """Thresholds of the mode classification (see the module docstring) and the test conditions.

    Attributes
    ----------
    step_v : float
        Reference step R (position volts); the loop starts at rest at θ = 0.
    saturation_v : float
        Actuator rails ±V (the saturation of Fig. 12).
    duration_s : float or None
        Record length; default 20 × the slowest open-loop mechanical time constant.
    overshoot_pct, critical_zeta_max, settle_band, chatter_amplitude, unstable_amplitude,
    sustained_ratio, growth_ratio, min_reversals :
        The thresholds of the criteria.
    steps_per_time_constant : float
        RK4 steps per fastest linearised time constant ``1/max|λ|``.
    max_steps : int
        Cap on RK4 steps.
    """

    step_v: float = 1.0
    saturation_v: float = 10.0
    duration_s: float | None = None
    overshoot_pct: float = 2.0
    critical_zeta_max: float = 1.1
    settle_band: float = 0.02
    chatter_amplitude: float = 0.1
    unstable_amplitude: float = 0.5
    sustained_ratio: float = 0.7
    growth_ratio: float = 1.2
    min_reversals: int = 4
    steps_per_time_constant: float = 4.0
    max_steps: int = 20000

    def __post_init__(self) -> None:
        for name in ("step_v", "saturation_v", "overshoot_pct", "critical_zeta_max", "settle_band",
                     "chatter_amplitude", "unstable_amplitude", "sustained_ratio", "growth_ratio"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v > 0):
                raise OptionError(f"mode criterion {name} must be a finite number > 0, got {v!r}")
        if self.duration_s is not None and not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise OptionError(f"--duration must be > 0 s, got {self.duration_s!r}")


@dataclass(frozen=True, slots=True)
class ServoPlant:
    """A position model for the Fig. 4 loop: ``ẋ = A x + B u``, ``θ = cp x``, ``v = cv x``.

    ``tau_s`` is the mechanical time constant that sets the default record length (the model's
    first-order approximation; None: the slowest non-zero open-loop pole).  ``dead_zone_v``
    (``dead_zone_negative_v``) is the model's dead-zone in front of the plant (a Hammerstein
    model): the loop drives the plant with ``u − u₀·sign(u)`` outside it, 0 inside.
    """

    name: str
    A: np.ndarray
    B: np.ndarray
    cp: np.ndarray
    cv: np.ndarray
    tau_s: float | None = None
    dead_zone_v: float = 0.0
    dead_zone_negative_v: float | None = None

    @property
    def order(self) -> int:
        """Number of states."""
        return self.A.shape[0]

    def time_constant_s(self) -> float:
        """Mechanical time constant (``tau_s``, else the slowest non-zero open-loop pole's).

        Returns
        -------
        float
            The time constant in s.
        """
        if self.tau_s is not None:
            return float(self.tau_s)
        p = np.linalg.eigvals(self.A)
        mags = np.abs(p.real[np.abs(p) > 1e-9])
        return float(1.0 / mags.min()) if mags.size else 1.0


def parse_range(text: str, option: str) -> np.ndarray:
    """Parse ``A:B:N`` into ``numpy.linspace(A, B, N)``.

    Parameters
    ----------
    text : str
        ``A:B:N``.
    option : str
        The option it came from, named in the error.

    Returns
    -------
    ndarray
        ``N`` values from ``A`` to ``B``.

    Raises
    ------
    OptionError
        Malformed text, ``N < 1``, ``N > 1000``, non-finite or negative bounds (the paper's gains
        are non-negative).
    """
    parts = str(text).split(":")
    try:
        if len(parts) != 3:
            raise ValueError
        lo, hi, num = float(parts[0]), float(parts[1]), int(parts[2])
    except ValueError:
        raise OptionError(f"{option} must be START:STOP:COUNT, e.g. 0:50:200, got {text!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo < 0 or hi < lo:
        raise OptionError(f"{option}: need 0 <= START <= STOP (non-negative gains), got {text!r}")
    if not 1 <= num <= 1000:
        raise OptionError(f"{option}: COUNT must be 1..1000, got {num}")
    return np.linspace(lo, hi, num)


def _channel_rows(model: MotorModel) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """A, B, position row, velocity row; a position state is appended when the model has none."""
    a, b = model.A, model.B
    iv = model.outputs.index("velocity")
    if "position" in model.outputs:
        ip = model.outputs.index("position")
        if model.D[ip, 0] != 0 or model.D[iv, 0] != 0:
            raise OptionError("the modes map needs a strictly proper model (D = 0)")
        return a, b, model.C[ip].copy(), model.C[iv].copy()
    if model.D[iv, 0] != 0:
        raise OptionError("the modes map needs a strictly proper model (D = 0)")
    n = a.shape[0]
    # position = ∫ velocity (velocity-channel volts·s), as model_from_velocity_tf(with_position=True)
    a2 = np.zeros((n + 1, n + 1))
    a2[0, 1:] = model.C[iv]
    a2[1:, 1:] = a
    b2 = np.vstack([[[0.0]], b])
    cp = np.zeros(n + 1)
    cp[0] = 1.0
    cv = np.concatenate([[0.0], model.C[iv]])
    return a2, b2, cp, cv


def servo_plants(model: MotorModel, extra_pole: float | None = None) -> tuple[ServoPlant, ServoPlant]:
    """The 2nd- and 3rd-order position models compared in the paper's section II.

    Parameters
    ----------
    model : MotorModel
    extra_pole : float, optional
        For a model with a first-order velocity TF: the pole (rad/s) of the actuator lag added
        in series to make the 3rd-order model (default ``10/τm``).  Ignored otherwise.

    Returns
    -------
    (ServoPlant, ServoPlant)
        2nd order: the first-order velocity approximation ``dc/(τ s + 1)`` with the model's
        position scale; 3rd order: the model itself when its velocity TF is of order ≥ 2,
        else the model with an actuator lag ``p/(s + p)``.

    Raises
    ------
    OptionError
        For a non-positive ``extra_pole`` or a model whose velocity does not settle.
    """
    a, b, cp, cv = _channel_rows(model)
    vden = np.asarray(model.velocity_tf.den[0][0], dtype=float)
    vorder = int(np.trim_zeros(vden, "f").size - 1)
    fo = model.first_order()
    tau, dc = fo.time_constant_s, fo.dc_gain
    if not (math.isfinite(tau) and tau > 0 and math.isfinite(dc)):
        raise OptionError("the model's velocity has no stable first-order approximation; cannot map modes")
    # position per velocity-volt·s: θ̇ = scale·v, measured at low frequency from the model rows
    w0 = 1e-3 / tau
    sI = 1j * w0 * np.eye(a.shape[0]) - a
    g = np.linalg.solve(sI, b[:, 0])
    scale = float(np.real(1j * w0 * (cp @ g) / (cv @ g)))
    a2 = np.array([[0.0, scale], [0.0, -1.0 / tau]])
    b2 = np.array([[0.0], [dc / tau]])
    nl = model.static_nonlinearity
    dz = {} if nl is None else {"dead_zone_v": nl.dead_zone_v, "dead_zone_negative_v": nl.negative_dead_zone_v}
    second = ServoPlant("2nd order", a2, b2, np.array([1.0, 0.0]), np.array([0.0, 1.0]), tau, **dz)
    if vorder >= 2:
        third = ServoPlant(f"{a.shape[0]}-state model", a, b, cp, cv, tau, **dz)
        return second, third
    p = 10.0 / tau if extra_pole is None else float(extra_pole)
    if not (math.isfinite(p) and p > 0):
        raise OptionError(f"--extra-pole must be > 0 rad/s, got {extra_pole!r}")
    n = a.shape[0]
    a3 = np.zeros((n + 1, n + 1))
    a3[:n, :n] = a
    a3[:n, n] = b[:, 0]
    a3[n, n] = -p
    b3 = np.zeros((n + 1, 1))
    b3[n, 0] = p
    third = ServoPlant(f"3rd order (lag at {p:.3g} rad/s)", a3, b3, np.append(cp, 0.0), np.append(cv, 0.0), tau,
                       **dz)
    return second, third


@dataclass(frozen=True, slots=True)
class _GridStats:
    finite: np.ndarray
    amp_mid: np.ndarray
    amp_tail: np.ndarray
    reversals: np.ndarray
    overshoot: np.ndarray
    final_err: np.ndarray
    theta: np.ndarray | None = None


def _linearised_poles(plant: ServoPlant, kp: np.ndarray, kv: np.ndarray) -> np.ndarray:
    """Eigenvalues of ``A − B (Kp cp + Kv cv)`` for every grid point, shape (N, n) (batched eig)."""
    k = kp[:, None] * plant.cp[None, :] + kv[:, None] * plant.cv[None, :]
    acl = plant.A[None, :, :] - plant.B[None, :, :] * k[:, None, :]
    return np.linalg.eigvals(acl)


def simulate_servo_grid(plant: ServoPlant, kp: np.ndarray, kv: np.ndarray, criteria: ModeCriteria,
                        poles: np.ndarray | None = None, *, record: bool = False) -> tuple[_GridStats, float, int]:
    """Step responses of the saturated loop for every (kp[i], kv[i]) pair, all at once.

    Fixed-step classical RK4 on the ``(n, N)`` state array — written by hand because the point is
    to step all N systems together (python-control's ``input_output_response`` simulates one
    system per call; see ``bench/modes_speed.py``).  The step is ``1/(steps_per_time_constant·max|λ|)``
    over the linearised loops (RK4 is stable to ``|λ h| ≈ 2.8``; the default ``|λ h| = 0.25``
    keeps the error at the saturation corners, where RK4 drops to low order, near 1 % of the
    step over a limit cycle), at least 400 steps per record.  ``record=True`` also keeps θ at
    every step (``stats.theta``, shape (steps + 1, N); for tests and small grids).

    Parameters
    ----------
    plant : ServoPlant
        The servo model.
    kp : ndarray
        Position gains, one per system.
    kv : ndarray
        Velocity gains, one per system.
    criteria : ModeCriteria
        Step level, saturation and record length.
    poles : ndarray, optional
        Linearised closed-loop poles per system (computed when not given).
    record : bool
        Keep θ at every step (default False).

    Returns
    -------
    (stats, dt_s, steps)
    """
    kp = np.asarray(kp, dtype=float).ravel()
    kv = np.asarray(kv, dtype=float).ravel()
    if poles is None:
        poles = _linearised_poles(plant, kp, kv)
    fast = float(np.max(np.abs(poles))) if poles.size else 1.0
    duration = criteria.duration_s or 20.0 * plant.time_constant_s()
    steps = int(min(criteria.max_steps, max(400, math.ceil(criteria.steps_per_time_constant * duration * fast))))
    steps += (-steps) % 4  # whole quarters
    h = duration / steps
    r = float(criteria.step_v)
    sat = float(criteria.saturation_v)
    a, bcol = plant.A, plant.B[:, 0][:, None]
    cp, cv = plant.cp, plant.cv
    x = np.zeros((plant.order, kp.size))

    dz_pos = float(plant.dead_zone_v)
    dz_neg = dz_pos if plant.dead_zone_negative_v is None else float(plant.dead_zone_negative_v)

    def f(xx: np.ndarray) -> np.ndarray:
        u = kp * (r - cp @ xx) - kv * (cv @ xx)
        np.clip(u, -sat, sat, out=u)
        if dz_pos or dz_neg:  # the dead-zone after the rails: what the amplifier passes on
            u = np.where(u > dz_pos, u - dz_pos, np.where(u < -dz_neg, u + dz_neg, 0.0))
        return a @ xx + bcol * u

    q = steps // 4
    mx = {2: np.full(kp.size, -np.inf), 3: np.full(kp.size, -np.inf)}
    mn = {2: np.full(kp.size, np.inf), 3: np.full(kp.size, np.inf)}
    reversals = np.zeros(kp.size, dtype=np.int64)
    peak = np.full(kp.size, -np.inf)
    theta_prev = cp @ x
    dir_prev = np.zeros(kp.size)
    tiny = 1e-9 * abs(r)
    sign = 1.0 if r >= 0 else -1.0
    traj = np.empty((steps + 1, kp.size)) if record else None
    if traj is not None:
        traj[0] = theta_prev
    with np.errstate(over="ignore", invalid="ignore"):
        for k in range(steps):
            k1 = f(x)
            k2 = f(x + 0.5 * h * k1)
            k3 = f(x + 0.5 * h * k2)
            k4 = f(x + h * k3)
            x = x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            theta = cp @ x
            if traj is not None:
                traj[k + 1] = theta
            np.maximum(peak, sign * (theta - r), out=peak)
            quarter = min(3, k // q)
            if quarter >= 2:
                np.maximum(mx[quarter], theta, out=mx[quarter])
                np.minimum(mn[quarter], theta, out=mn[quarter])
            d = theta - theta_prev
            moving = np.abs(d) > tiny
            cur = np.where(moving, np.sign(d), dir_prev)
            if quarter == 3:
                reversals += (moving & (cur != dir_prev) & (dir_prev != 0)).astype(np.int64)
            dir_prev = cur
            theta_prev = theta
    finite = np.all(np.isfinite(x), axis=0)
    stats = _GridStats(finite, (mx[2] - mn[2]) / 2, (mx[3] - mn[3]) / 2, reversals, peak / abs(r) * 100.0,
                       np.abs(cp @ x - r), traj)
    return stats, h, steps


def _zeta_eq(poles: np.ndarray) -> np.ndarray:
    """Dominant damping of each row of linearised poles (see the module docstring)."""
    order = np.argsort(np.abs(poles.real) + 1e-12 * np.abs(poles.imag), axis=1)
    p = np.take_along_axis(poles, order, axis=1)
    p1 = p[:, 0]
    p2 = p[:, 1] if p.shape[1] > 1 else p1
    with np.errstate(divide="ignore", invalid="ignore"):
        complex_pair = np.abs(p1.imag) > 1e-9 * np.maximum(1.0, np.abs(p1))
        zc = -p1.real / np.abs(p1)
        a1, a2 = np.abs(p1.real), np.abs(p2.real)
        zr = (a1 + a2) / (2.0 * np.sqrt(a1 * a2))
    return np.where(complex_pair, zc, zr)


def classify_grid(stats: _GridStats, poles: np.ndarray, criteria: ModeCriteria) -> np.ndarray:
    """Labels (indices into :data:`MODES`) for each grid point from its window statistics.

    Parameters
    ----------
    stats : _GridStats
        Window statistics of every grid point (:func:`simulate_servo_grid`).
    poles : ndarray
        Linearised closed-loop poles, one row per grid point.
    criteria : ModeCriteria
        The classification thresholds.

    Returns
    -------
    ndarray of int
        One label per grid point.
    """
    c = criteria
    r = abs(c.step_v)
    band = c.settle_band * r
    labels = np.full(stats.finite.size, MODES.index("overdamped"), dtype=np.int8)
    with np.errstate(invalid="ignore"):
        growing = (stats.amp_tail > c.growth_ratio * stats.amp_mid) & (stats.amp_tail > band) & \
            (stats.reversals >= c.min_reversals)
        unstable = ~stats.finite | ~np.isfinite(stats.amp_tail) | (stats.amp_tail >= c.unstable_amplitude * r) | growing
        sustained = ~unstable & (stats.amp_tail > band) & (stats.reversals >= c.min_reversals) & \
            (stats.amp_tail >= c.sustained_ratio * stats.amp_mid)
        settled_like = ~unstable & ~sustained
        under = settled_like & (stats.overshoot > c.overshoot_pct)
        zeta = _zeta_eq(poles)
        critical = settled_like & ~under & (zeta <= c.critical_zeta_max) & (stats.final_err <= band)
    labels[sustained & (stats.amp_tail < c.chatter_amplitude * r)] = MODES.index("chattering")
    labels[sustained & (stats.amp_tail >= c.chatter_amplitude * r)] = MODES.index("oscillatory")
    labels[under] = MODES.index("underdamped")
    labels[critical] = MODES.index("critically_damped")
    labels[unstable] = MODES.index("unstable")
    return labels


@dataclass(frozen=True, slots=True)
class ModeMap:
    """Modes over a (Kp, Kv) grid for one plant.

    Attributes
    ----------
    plant : str
    kp, kv : ndarray
        Grid axes.
    labels : ndarray of int8, shape (len(kv), len(kp))
        Indices into :data:`MODES`; row i is ``kv[i]``, column j is ``kp[j]``.
    dt_s : float
    steps : int
    """

    plant: str
    kp: np.ndarray
    kv: np.ndarray
    labels: np.ndarray
    dt_s: float
    steps: int

    def modes(self) -> list[list[str]]:
        """Rows of mode names (row = one Kv value).

        Returns
        -------
        list of list of str
            One row per Kv value, one name per Kp value.
        """
        return [[MODES[i] for i in row] for row in self.labels]

    def counts(self) -> dict[str, int]:
        """How many grid points show each mode.

        Returns
        -------
        dict of str to int
            Count per mode name.
        """
        return {m: int(np.sum(self.labels == i)) for i, m in enumerate(MODES)}


@single_blas_thread
def mode_map(plant: ServoPlant, kp: np.ndarray, kv: np.ndarray, criteria: ModeCriteria = ModeCriteria()) -> ModeMap:
    """Classify the saturated Fig. 4 loop at every (Kp, Kv) of the grid.

    Parameters
    ----------
    plant : ServoPlant
    kp, kv : ndarray
        Grid axes (non-negative gains).
    criteria : ModeCriteria

    Returns
    -------
    ModeMap

    References
    ----------
    Masoud 2019, Figs. 4, 12, 13.
    """
    kp = np.asarray(kp, dtype=float).ravel()
    kv = np.asarray(kv, dtype=float).ravel()
    if kp.size == 0 or kv.size == 0 or not (np.all(np.isfinite(kp)) and np.all(np.isfinite(kv))):
        raise OptionError("the gain grid must be non-empty and finite")
    gp, gv = np.meshgrid(kp, kv)
    fp, fv = gp.ravel(), gv.ravel()
    poles = _linearised_poles(plant, fp, fv)
    stats, h, steps = simulate_servo_grid(plant, fp, fv, criteria, poles)
    labels = classify_grid(stats, poles, criteria).reshape(gp.shape)
    return ModeMap(plant.name, kp, kv, labels, h, steps)


def modes_json(maps: tuple[ModeMap, ...], criteria: ModeCriteria) -> dict[str, Any]:
    """docs/formats.md "Modes JSON".

    ``kp``, ``kv``, ``modes`` (of the first map: the 2nd-order one), ``criteria``, plus ``maps``
    with every plant's modes and counts.

    Parameters
    ----------
    maps : tuple of ModeMap
        The maps (the first is the 2nd-order model's).
    criteria : ModeCriteria
        The thresholds used.

    Returns
    -------
    dict
        JSON-able.
    """
    crit = asdict(criteria)
    crit["definitions"] = __doc__.split("Classification criteria")[1].split("References")[0].strip()
    first = maps[0]
    return {
        "schema": "motorid.modes/1",
        "kp": first.kp.tolist(),
        "kv": first.kv.tolist(),
        "modes": first.modes(),
        "criteria": crit,
        "maps": [{"plant": m.plant, "modes": m.modes(), "counts": m.counts(), "dt": m.dt_s, "steps": m.steps}
                 for m in maps],
    }


def plot_mode_maps(maps: tuple[ModeMap, ...], path: str | Path) -> None:
    """Write the maps side by side as a PNG (one colour per mode).

    Parameters
    ----------
    maps : tuple of ModeMap
        The maps to draw.
    path : str or Path
        The PNG file to write.
    """
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure
    from matplotlib.patches import Patch

    colours = ["#d62728", "#1f77b4", "#2ca02c", "#bcbd22", "#ff7f0e", "#9467bd"]
    cmap = ListedColormap(colours)
    # a Figure of its own, not pyplot's: no backend switch in the caller's session
    fig = Figure(figsize=(5.5 * len(maps), 5))
    axes = fig.subplots(1, len(maps), squeeze=False)
    for ax, m in zip(axes[0], maps, strict=False):
        ext = [m.kp[0], m.kp[-1], m.kv[0], m.kv[-1]]
        ax.imshow(m.labels, origin="lower", aspect="auto", extent=ext, cmap=cmap, vmin=-0.5,
                  vmax=len(MODES) - 0.5, interpolation="nearest")
        ax.set_title(m.plant)
        ax.set_xlabel("Kp (V/V)")
        ax.set_ylabel("Kv (V/(V/s))")
    fig.legend(handles=[Patch(color=c, label=name) for c, name in zip(colours, MODES, strict=False)],
               loc="lower center", ncol=len(MODES), fontsize="small")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(str(path), dpi=100)


def write_modes_json(maps: tuple[ModeMap, ...], criteria: ModeCriteria, path: str | Path) -> None:
    """Write :func:`modes_json` to ``path``."""
    Path(path).write_text(json.dumps(modes_json(maps, criteria), indent=1))

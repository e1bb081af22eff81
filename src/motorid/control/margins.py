"""Frequency-domain checks of a design: gain, phase and delay margins, sensitivity peak, bandwidth.

The loop is broken at the motor's input (the amplifier's command), where a dead time, an
amplifier's gain error or the unmodelled lag of a driver act: ``L(s)`` is the transfer from a
signal injected there, through the motor and the controller (state feedback, its integrator,
the observer when there is one), back to the same point. The model's dead time is part of the
loop (a Padé approximant for the margins, exact for the bandwidth's frequency response).

python-control computes the margins (:func:`control.stability_margins`) and the bandwidth
(:func:`control.bandwidth`); this module only builds the loop the controller makes.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
import scipy.signal

if TYPE_CHECKING:
    from motorid.control.design import Design
    from motorid.model import MotorModel

__all__ = [
    "PADE_ORDER",
    "LoopMargins",
    "closed_loop_bandwidth",
    "dead_time_pade",
    "loop_frequency_response",
    "loop_margins",
    "open_loop_margins",
]

#: Order of the Padé approximant of the model's dead time in the loop.
PADE_ORDER = 8


def _number(x: float) -> float | None:
    """JSON's view of a margin: ``None`` for an infinite one (the phase never reaches −180°)."""
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass(frozen=True, slots=True)
class LoopMargins:
    """Stability margins of a design's loop, broken at the motor's input.

    Attributes
    ----------
    gain_db : float
        Gain margin in dB (``inf`` when the loop's phase never reaches −180°).
    phase_deg : float
        Phase margin in degrees (``inf`` when the loop gain never crosses 1).
    delay_s : float
        Delay margin: the extra dead time at the motor's input the loop tolerates
        (phase margin / gain crossover frequency), on top of the model's own.
    crossover_rad_s : float
        Gain crossover frequency (rad/s), where ``|L| = 1`` (NaN without one).
    ms : float
        Sensitivity peak ``max |1/(1 + L(jω))|`` (1.2–2 is the usual design range).
    bandwidth_rad_s : float
        −3 dB bandwidth of the reference-to-output closed loop (state feedback; NaN when the
        closed loop has no finite DC gain).
    dead_time_s : float
        The model's dead time included in the loop.
    """

    gain_db: float
    phase_deg: float
    delay_s: float
    crossover_rad_s: float
    ms: float
    bandwidth_rad_s: float
    dead_time_s: float = 0.0

    def to_json(self) -> dict[str, Any]:
        """The design JSON's ``margins`` object (infinite margins as ``null``).

        Returns
        -------
        dict
            ``gain_db``, ``phase_deg``, ``delay_s``, ``crossover_rad_s``, ``ms``,
            ``bandwidth_rad_s``, ``dead_time_s``.
        """
        return {"gain_db": _number(self.gain_db), "phase_deg": _number(self.phase_deg),
                "delay_s": _number(self.delay_s), "crossover_rad_s": _number(self.crossover_rad_s),
                "ms": _number(self.ms), "bandwidth_rad_s": _number(self.bandwidth_rad_s),
                "dead_time_s": float(self.dead_time_s)}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> LoopMargins:
        """Rebuild from :meth:`to_json` (``null`` back to ``inf`` or NaN).

        Parameters
        ----------
        data : Mapping
            The ``margins`` object.

        Returns
        -------
        LoopMargins
        """
        def get(key: str, missing: float) -> float:
            v = data.get(key)
            if v is None:
                return missing
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ValueError(f"margins.{key} must be a number or null")
            return float(v)

        return cls(get("gain_db", math.inf), get("phase_deg", math.inf), get("delay_s", math.inf),
                   get("crossover_rad_s", math.nan), get("ms", math.nan), get("bandwidth_rad_s", math.nan),
                   get("dead_time_s", 0.0))

    def text(self) -> str:
        """One line for a terminal: each margin with its unit.

        Returns
        -------
        str
            ``gain margin 14.2 dB, phase margin 61.3° at 8.2 rad/s, delay margin 0.13 s, Ms 1.31,
            bandwidth 9.9 rad/s``.
        """
        from motorid.numfmt import sig

        def fin(x: float, unit: str) -> str:
            return f"{sig(x)}{unit}" if math.isfinite(x) else "∞"

        phase = fin(self.phase_deg, "°")
        if math.isfinite(self.crossover_rad_s):
            phase += f" at {sig(self.crossover_rad_s)} rad/s"
        parts = [f"gain margin {fin(self.gain_db, ' dB')}", f"phase margin {phase}",
                 f"delay margin {fin(self.delay_s, ' s')}", f"Ms {fin(self.ms, '')}",
                 f"bandwidth {fin(self.bandwidth_rad_s, ' rad/s')}"]
        where = "loop broken at the motor's input"
        if self.dead_time_s > 0:
            where += f", the model's {sig(self.dead_time_s)} s dead time included"
        return ", ".join(parts) + f" ({where})"


def _loop_matrices(a: np.ndarray, b: np.ndarray, c: np.ndarray, design: Design, *, observer: bool
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)`` of ``L(s)``: from a signal added to the motor's input to minus the controller's command.

    States ``[x, x̂, z]``: the motor, the observer's estimate (with ``observer``; it is fed the
    controller's own command and the measured output) and the integrator ``ż = y`` (``r = 0``);
    with a reduced-order observer ``[x, w, z]`` (:func:`.reduced_observer.reduced_loop`).
    """
    n = a.shape[0]
    k = design.K.reshape(1, n)
    ki = design.ki
    if observer and design.reduced is not None:
        from motorid.control.reduced_observer import reduced_loop

        return reduced_loop(a, b, c, k, ki, design.reduced, tuple(design.states))
    if observer and design.L is not None:
        lc = design.L.reshape(n, 1) @ c
        blocks_a = [[a, np.zeros((n, n))], [lc, a - b @ k - lc]]
        blocks_c = [np.zeros((1, n)), k]
        blocks_b = [b, np.zeros((n, 1))]
    else:
        blocks_a, blocks_c, blocks_b = [[a]], [k], [b]
    size = sum(row[0].shape[0] for row in blocks_a)
    a_l = np.block(blocks_a)
    b_l = np.vstack(blocks_b)
    c_l = np.hstack(blocks_c)
    if ki is not None:
        # the integrator reads the measured output; the command subtracts ki·z (and −B·ki·z
        # enters the observer, which is fed the command)
        c_meas = np.hstack([c, np.zeros((1, size - n))])
        a_l = np.block([[a_l, np.zeros((size, 1))], [c_meas, np.zeros((1, 1))]])
        if observer and design.L is not None:
            a_l[n:2 * n, -1] = -b.ravel() * ki
        b_l = np.vstack([b_l, [[0.0]]])
        c_l = np.hstack([c_l, [[ki]]])
    return a_l, b_l, c_l


def loop_margins(model: MotorModel, design: Design) -> LoopMargins:
    """The margins of ``design`` on ``model`` (python-control's stability margins of the loop).

    Parameters
    ----------
    model : MotorModel
        The model the design was made for (any realisation; its dead time is in the loop).
    design : Design
        State feedback, with integral action and an observer when the design has them.

    Returns
    -------
    LoopMargins
    """
    import control

    a, b, c = _design_plant(model, design)
    a_l, b_l, c_l = _loop_matrices(a, b, c, design, observer=True)
    loop = control.ss(a_l, b_l, c_l, 0.0)
    pade = dead_time_pade(float(model.delay_s), _fastest(a_l))
    return open_loop_margins(loop, float(model.delay_s), _bandwidth(a, b, c, design, pade))


def dead_time_pade(delay_s: float, fastest_rad_s: float) -> Any:
    """The Padé approximant (order :data:`PADE_ORDER`) of a dead time in a loop, or None.

    Parameters
    ----------
    delay_s : float
        The dead time (s).
    fastest_rad_s : float
        The loop's fastest pole magnitude (rad/s).

    Returns
    -------
    control.StateSpace or None
        None when the dead time turns no phase at the loop's time scales (an identified
        1e-11 s), where its approximant would only put coefficients of 1e-88 into the polynomials.
    """
    import control

    if not delay_s * fastest_rad_s > 1e-6:
        return None
    return control.ss(control.tf(*control.pade(delay_s, PADE_ORDER)))


def open_loop_margins(loop: Any, delay_s: float, bandwidth_rad_s: float) -> LoopMargins:
    """The margins of an open loop ``L(s)`` (without its dead time) closed by negative feedback.

    The dead time is put in by :func:`dead_time_pade`; python-control computes the margins.

    Parameters
    ----------
    loop : control.StateSpace
        ``L(s)`` without the dead time, SISO.
    delay_s : float
        The dead time in the loop (s).
    bandwidth_rad_s : float
        The closed loop's −3 dB bandwidth (computed by the caller; NaN when undefined).

    Returns
    -------
    LoopMargins
    """
    import control

    loop = control.ss(loop)
    fastest = _fastest(np.asarray(loop.A, float))
    pade = dead_time_pade(delay_s, fastest)
    if pade is not None:
        loop = loop * pade
    try:
        # a loop with an open-loop pole at the origin twice over (an integrator with ki = 0) has
        # NaN crossing responses, which python-control compares with numpy's warning printed
        with np.errstate(invalid="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            gm, pm, sm, _wpc, wgc, _wms = control.stability_margins(loop)
    except (np.linalg.LinAlgError, ValueError, FloatingPointError):
        # the polynomial method failed numerically: python-control's frequency-response method
        omega = np.logspace(np.log10(fastest) - 6, np.log10(fastest) + 3, 20000)
        gm, pm, sm, _wpc, wgc, _wms = control.stability_margins(control.frd(loop, omega), method="frd")
    gain_db = 20 * math.log10(gm) if gm is not None and math.isfinite(gm) and gm > 0 else math.inf
    phase = float(pm) if pm is not None and math.isfinite(pm) else math.inf
    wgc = float(wgc) if wgc is not None and math.isfinite(wgc) and wgc > 0 else math.nan
    delay = math.radians(phase) / wgc if math.isfinite(phase) and math.isfinite(wgc) else math.inf
    # the sensitivity peak also on a grid: python-control finds the stationary points of |1 + L|,
    # and a loop whose |1 + L| only falls towards ω → 0 or ∞ has none
    grid_ms = _grid_sensitivity_peak(loop, fastest, 2000)
    ms = max(grid_ms, 1.0 / float(sm) if sm is not None and math.isfinite(sm) and float(sm) > 0 else 0.0)
    # |S| tends to 1/|1 + D| as ω → ∞ (1 for a strictly proper loop): the peak is at least that limit.
    # python-control's stationary points leave it out, and the grid reaches it or not by how far it
    # goes, so a design printed "Ms 0.897" — below what any strictly proper loop can have — or 1.0
    # from one run to the next
    d = float(np.asarray(loop.D, dtype=float).ravel()[0]) if np.size(loop.D) else 0.0
    if 1.0 + d != 0.0:
        ms = max(ms, 1.0 / abs(1.0 + d))
    used = delay_s if pade is not None else 0.0
    return LoopMargins(gain_db, phase, delay, wgc, ms, bandwidth_rad_s, used)


def sensitivity_peak(a_l: np.ndarray, b_l: np.ndarray, c_l: np.ndarray) -> float:
    """``max |1/(1 + L(jω))|`` of a loop ``(A, B, C)`` broken at the motor's input (without dead time).

    On a log grid over nine decades around the loop's fastest pole (at least 1: ``|S(j∞)| = 1``).

    Parameters
    ----------
    a_l, b_l, c_l : ndarray
        The loop's matrices (:func:`_loop_matrices`, :func:`.reduced_observer.reduced_loop`).

    Returns
    -------
    float
        The sensitivity peak Ms (``inf`` where ``1 + L`` vanishes on the grid).
    """
    import control

    return max(_grid_sensitivity_peak(control.ss(a_l, b_l, c_l, 0.0), _fastest(a_l), 1000), 1.0)


def _grid_sensitivity_peak(loop: Any, fastest: float, points: int) -> float:
    """``max |1/(1 + L(jω))|`` on ``points`` frequencies over nine decades around ``fastest``."""
    omega = np.logspace(np.log10(fastest) - 6, np.log10(fastest) + 3, points)
    with np.errstate(divide="ignore", invalid="ignore"):
        return float(np.nanmax(1.0 / np.abs(1.0 + _response(loop, omega))))


def loop_frequency_response(model: MotorModel, design: Design, points: int = 800) -> tuple[np.ndarray, np.ndarray]:
    """``L(jω)`` of the loop :func:`loop_margins` checks, the model's dead time exact (``e^{−jωτ}``).

    Parameters
    ----------
    model : MotorModel
        The model the design was made for.
    design : Design
        The controller.
    points : int
        Frequencies, log-spaced over five decades around the loop's fastest pole.

    Returns
    -------
    (ndarray, ndarray)
        ``ω`` (rad/s) and the complex ``L(jω)`` (NaN where a loop pole sits on the axis).
    """
    import control

    a, b, c = _design_plant(model, design)
    a_l, b_l, c_l = _loop_matrices(a, b, c, design, observer=True)
    fastest = _fastest(a_l)
    omega = np.logspace(np.log10(fastest) - 4, np.log10(fastest) + 1, points)
    resp = _response(control.ss(a_l, b_l, c_l, 0.0), omega)
    return omega, resp * np.exp(-1j * omega * float(model.delay_s))


def _design_plant(model: MotorModel, design: Design) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)`` of ``model`` in the design's coordinates, ``C`` the measured output's row."""
    from motorid.control.design import design_model, output_row

    work = design_model(model, design)
    c = np.asarray(output_row(work, design.output)[1], float).reshape(1, -1)
    return np.asarray(work.A, float), np.asarray(work.B, float).reshape(-1, 1), c


def _fastest(a_l: np.ndarray) -> float:
    """The loop's fastest pole magnitude (at least 1 rad/s): where its frequency grids are centred."""
    return max(float(np.max(np.abs(np.linalg.eigvals(a_l)), initial=0.0)), 1.0)


def _response(system: Any, omega: np.ndarray) -> np.ndarray:
    """A SISO system's ``G(jω)`` on ``omega``; NaN where a pole sits on the axis (an integrator).

    ``C (jωI − A)⁻¹ B + D`` for every frequency in one stacked solve: python-control's own
    evaluation (``system(jω)``, one Horner step per frequency) was 40 ms of every design's
    2000-point grid; the test of the margins compares with python-control.
    """
    import control

    ss = control.ss(system)
    a, b, c, d = (np.asarray(m, dtype=float) for m in (ss.A, ss.B, ss.C, ss.D))
    if a.size == 0:
        return np.full(omega.shape, complex(d[0, 0]))
    s = 1j * np.asarray(omega, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        m = s[:, None, None] * np.eye(a.shape[0]) - a
        try:
            x = np.linalg.solve(m, np.broadcast_to(b, (s.size, *b.shape)))
            return (c @ x)[:, 0, 0] + d[0, 0]
        except np.linalg.LinAlgError:  # a pole on the axis at a grid point: NaN there
            out = np.full(s.shape, np.nan + 0j)
            for i in range(s.size):
                with contextlib.suppress(np.linalg.LinAlgError):
                    out[i] = (c @ np.linalg.solve(m[i], b))[0, 0] + d[0, 0]
            return out


def _bandwidth(a: np.ndarray, b: np.ndarray, c: np.ndarray, design: Design, pade: Any) -> float:
    """−3 dB bandwidth of reference → output with state feedback (the observer's modes are not excited by ``r``)."""
    import control

    a_l, b_l, c_l = _loop_matrices(a, b, c, design, observer=False)
    loop = control.ss(a_l, b_l, c_l, 0.0)
    motor = control.ss(a, b, c, 0.0)
    delay = control.ss(pade) if pade is not None else control.ss([], [], [], 1.0)
    command = control.feedback(delay, loop)  # reference's command → motor's input
    if design.ki is not None:
        ref = control.tf([design.ki], [1.0, 0.0])
    else:
        ref = control.tf([design.kr if design.kr is not None else 1.0], [1.0])
    # as a transfer function: minreal of a state-space model needs slycot; the integrator of the
    # reference path cancels against the zero at s = 0 the loop's integrator puts in ``command``
    return closed_loop_bandwidth(control.tf(motor) * control.tf(command) * ref)


def closed_loop_bandwidth(closed: Any) -> float:
    """−3 dB bandwidth (rad/s) of a reference-to-output transfer function, after cancelling common factors.

    Parameters
    ----------
    closed : control.TransferFunction
        The closed loop, SISO (products leave pole-zero pairs that :func:`control.minreal` removes).

    Returns
    -------
    float
        python-control's :func:`control.bandwidth`; NaN when the closed loop has no finite DC gain.
    """
    import control

    with warnings.catch_warnings():
        # the conversion leaves numerator coefficients at rounding level, which scipy flags
        # (here and where python-control takes the poles of the result)
        warnings.simplefilter("ignore", scipy.signal.BadCoefficients)
        closed = control.minreal(control.tf(closed), verbose=False)
        try:
            bw = float(control.bandwidth(closed))
        except (ValueError, TypeError, ZeroDivisionError):  # no finite DC gain
            return math.nan
    return bw if math.isfinite(bw) else math.nan

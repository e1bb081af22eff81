"""Code for the microcontroller: a controller discretised and written as difference equations.

:func:`discretise` samples any continuous-time controller (a python-control ``StateSpace``
with named signals, e.g. :func:`.controller.controller_system`) at the interval ``TS`` with
python-control's :func:`control.c2d`; :func:`discretise_design` does so for a design and
checks the interval against the loop it closes.  :func:`emit_c`, :func:`emit_python` and
:func:`emit_matlab` write the same difference equations

    x[k+1] = Ad x[k] + Bd in[k],    u[k] = Cd x[k] + Dd in[k]

unrolled, every coefficient with ``%.17g`` (a double read back exactly), as a small C99
function with its state (ready for an Arduino loop), a Python module or a MATLAB function.

Actuator rails.  Given ``rails`` (``motorid design --discrete TS --saturation U``), the emitted
step clamps the command to ``±U`` and runs the rest of the controller as ``motorid simulate
--saturation U`` runs it: the observer is fed the command applied (the clamped one, not the one
asked for), and the integrator holds while the command is beyond a rail and its increment would
push it further (conditional integration).  Only the zero-order-hold form keeps the controller's
states apart for that (the integrator a state of its own, the observer's input column known).

Sample-rate limits.  The loop's fastest pole ``|p|`` (closed loop, observer, the controller's
own) sets them: an interval with ``TS·|p| > 0.2`` is warned about (Åström & Wittenmark,
*Computer-Controlled Systems*, 3rd ed., 1997: choose the sampling period so that ``ω h`` is
about 0.1–0.6 for the closed loop's natural frequency ``ω``; 0.2 keeps the sampled loop close
to the continuous design), an interval at or beyond the Nyquist limit ``π/|p|`` (the fastest
pole's frequency no longer below half the sampling rate) is refused, and so is one at which
the sampled loop — the motor held by a zero-order hold, read every ``TS``, and the discrete
controller; the model's dead time in it as the margins' Padé approximant — is unstable.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from motorid.control.controller import COMMAND, REFERENCE, controller_system, integrator_holds, signal_unit
from motorid.control.margins import PADE_ORDER
from motorid.errors import OptionError

if TYPE_CHECKING:
    import control

    from motorid.control.design import Design
    from motorid.control.pid import PidDesign
    from motorid.model import MotorModel

__all__ = [
    "LANGUAGES",
    "METHODS",
    "SAMPLING_RULE",
    "DiscreteController",
    "check_rails",
    "discretise",
    "discretise_design",
    "discretise_pid",
    "emit",
    "emit_c",
    "emit_matlab",
    "emit_python",
    "plant_system",
]

#: Discretisation methods (python-control's ``c2d``; ``tustin`` is the bilinear transform).
METHODS: tuple[str, ...] = ("zoh", "foh", "tustin", "euler", "backward_diff")
#: The emitters by language name.
LANGUAGES: tuple[str, ...] = ("c", "python", "matlab")
#: How a design's ``zoh`` controller with an observer is sampled (:func:`discretise_design`).
SAMPLED_OBSERVER = ("zoh: the command held between samples, the observer placed on the motor behind that hold "
                    "(its error decays at the design's observer poles at every sample, whatever the motor does), "
                    "the gains as designed")
#: Largest ``TS·|p|`` (fastest loop pole) without a warning.
SAMPLING_RULE = 0.2
#: Where the rule comes from, for the header and the warning.
RULE_SOURCE = "after Astrom & Wittenmark, Computer-Controlled Systems, 3rd ed. 1997: w*h ~ 0.1-0.6"


@dataclass(frozen=True, slots=True)
class DiscreteController:
    """A controller sampled at ``ts_s``: ``x[k+1] = Ad x[k] + Bd in[k]``, ``out[k] = Cd x[k] + Dd in[k]``.

    Attributes
    ----------
    system : control.StateSpace
        The discrete-time system (``dt = ts_s``), with the continuous one's signal names.
    ts_s : float
        Sampling interval, s.
    method : str
        How it was discretised (one of :data:`METHODS`).
    units : Mapping[str, str]
        Unit of each input and output (``{"r": "V", "velocity": "rpm", "u": "V"}``).
    fastest_pole_rad_s : float or None
        ``|p|`` of the loop's fastest pole (closed loop, observer, controller); None when the
        loop is unknown (a controller discretised on its own).
    ts_max_s : float or None
        The Nyquist limit ``π / |p|``: intervals at or above it are refused.
    loop_spectral_radius : float or None
        Largest ``|z|`` of the sampled loop (motor with a zero-order hold + this controller; the
        model's dead time in it as a Padé approximant).
    notes : tuple of str
        What the controller is (model, design, signals), for the emitted code's header.
    warnings : tuple of str
    how : str
        How it was sampled, in words (default: ``method`` by python-control's ``c2d``;
        :func:`discretise_design` says so when it placed the observer on the sampled motor).
    rails : float or None
        The actuator rails ``±rails`` the emitted step clamps the command to (None: none).
    command_column : ndarray or None
        How the command enters the next state (the observer's input column, shape
        ``(nstates,)``): with rails the emitted step feeds it the clamped command.  None: the
        command enters no state (no observer).
    integrator : int or None
        The index of the integrator's state, held against the rails (None: none).
    """

    system: Any
    ts_s: float
    method: str
    units: Mapping[str, str] = field(default_factory=dict)
    fastest_pole_rad_s: float | None = None
    ts_max_s: float | None = None
    loop_spectral_radius: float | None = None
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    how: str = ""
    rails: float | None = None
    command_column: np.ndarray | None = field(default=None, compare=False)
    integrator: int | None = None

    def description(self) -> str:
        """How it was sampled, in words: :attr:`how`, else ``"<method> (python-control c2d)"``.

        Returns
        -------
        str
        """
        return self.how or f"{self.method} (python-control c2d)"

    @property
    def Ad(self) -> np.ndarray:
        """State matrix of the difference equations."""
        return np.asarray(self.system.A, dtype=float).reshape(self.system.nstates, self.system.nstates)

    @property
    def Bd(self) -> np.ndarray:
        """Input matrix (one column per input)."""
        return np.asarray(self.system.B, dtype=float).reshape(self.system.nstates, self.system.ninputs)

    @property
    def Cd(self) -> np.ndarray:
        """Output matrix."""
        return np.asarray(self.system.C, dtype=float).reshape(self.system.noutputs, self.system.nstates)

    @property
    def Dd(self) -> np.ndarray:
        """Feed-through matrix."""
        return np.asarray(self.system.D, dtype=float).reshape(self.system.noutputs, self.system.ninputs)

    @property
    def inputs(self) -> tuple[str, ...]:
        """Input names, in the order of ``Bd``'s columns (``r`` first)."""
        return tuple(self.system.input_labels)

    @property
    def outputs(self) -> tuple[str, ...]:
        """Output names (``u``)."""
        return tuple(self.system.output_labels)

    @property
    def states(self) -> tuple[str, ...]:
        """State names (``x̂_position``, …, ``z``)."""
        return tuple(self.system.state_labels)

    def to_json(self) -> dict[str, Any]:
        """The design JSON's ``discrete`` object.

        Returns
        -------
        dict
            ``ts_s``, ``method``, ``Ad``, ``Bd``, ``Cd``, ``Dd`` (lists of rows), ``inputs``,
            ``outputs``, ``states``, ``units``, ``fastest_pole_rad_s``, ``ts_max_s``,
            ``loop_spectral_radius``, ``rule``, ``warnings`` and, with rails, ``rails``,
            ``command_column`` and ``integrator``.
        """
        def rows(m: np.ndarray) -> list[list[float]]:
            return [[float(v) for v in row] for row in m]

        return {"ts_s": float(self.ts_s), "method": self.method, "Ad": rows(self.Ad), "Bd": rows(self.Bd),
                "Cd": rows(self.Cd), "Dd": rows(self.Dd), "inputs": list(self.inputs),
                "outputs": list(self.outputs), "states": list(self.states), "units": dict(self.units),
                "fastest_pole_rad_s": self.fastest_pole_rad_s, "ts_max_s": self.ts_max_s,
                "loop_spectral_radius": self.loop_spectral_radius,
                "rule": f"TS*|p| <= {SAMPLING_RULE} ({RULE_SOURCE})", "warnings": list(self.warnings),
                **({} if self.rails is None else {
                    "rails": float(self.rails), "command_column": [float(v) for v in self.applied_column()],
                    "integrator": self.integrator})}

    def applied_column(self) -> np.ndarray:
        """:attr:`command_column`, zeros when the command enters no state.

        Returns
        -------
        ndarray, shape (nstates,)
        """
        n = self.Ad.shape[0]
        return np.zeros(n) if self.command_column is None else np.asarray(self.command_column, dtype=float).ravel()

    def open_matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """``Ad − b_u Cd`` and ``Bd − b_u Dd``: the next state with the command as an input of its own.

        ``x[k+1] = A0 x[k] + B0 in[k] + b_u u_applied[k]``; with ``u_applied = u`` (no rails) it is
        :attr:`Ad`, :attr:`Bd`'s update.

        Returns
        -------
        (ndarray, ndarray)
        """
        bu = self.applied_column().reshape(-1, 1)
        return self.Ad - bu @ self.Cd, self.Bd - bu @ self.Dd

    def difference(self, inputs: np.ndarray, x0: np.ndarray | None = None) -> np.ndarray:
        """Run the difference equations on an input sequence (one row per sample), with the rails if any.

        Parameters
        ----------
        inputs : ndarray, shape (N, ninputs)
            ``in[k]``, columns in the order of :attr:`inputs`.
        x0 : ndarray, optional
            ``x[0]`` (zeros by default).

        Returns
        -------
        ndarray, shape (N, noutputs)
            ``out[k]``.
        """
        w = np.asarray(inputs, dtype=float).reshape(len(inputs), -1)
        x = np.zeros(self.Ad.shape[0]) if x0 is None else np.asarray(x0, dtype=float)
        out = np.empty((w.shape[0], self.Cd.shape[0]))
        if self.rails is None:
            for k, row in enumerate(w):
                out[k] = self.Cd @ x + self.Dd @ row
                x = self.Ad @ x + self.Bd @ row
            return out
        a0, b0 = self.open_matrices()
        bu, rail, iz = self.applied_column(), float(self.rails), self.integrator
        for k, row in enumerate(w):
            u_raw = float((self.Cd @ x + self.Dd @ row)[0])
            u = min(max(u_raw, -rail), rail)
            out[k] = u
            nxt = a0 @ x + b0 @ row + bu * u
            if iz is not None and integrator_holds(u_raw, rail, float(self.Cd[0, iz]) * (nxt[iz] - x[iz])):
                nxt[iz] = x[iz]
            x = nxt
        return out


def _check_ts(ts: float, method: str) -> None:
    if isinstance(ts, bool) or not isinstance(ts, (int, float)) or not math.isfinite(ts) or not ts > 0:
        raise OptionError(f"--discrete must be a sampling interval in seconds > 0, got {ts!r}")
    if method not in METHODS:
        raise OptionError(f"--discrete-method {method!r}: use one of {', '.join(METHODS)}")


def discretise(controller: control.StateSpace, ts: float, method: str = "zoh", *,
               units: Mapping[str, str] | None = None, notes: Sequence[str] = ()) -> DiscreteController:
    """Sample a continuous-time controller at ``ts`` (python-control's ``c2d``).

    Parameters
    ----------
    controller : control.StateSpace
        Continuous-time, with named inputs and outputs (any controller: state feedback, a PID
        in state-space form, …).
    ts : float
        Sampling interval, s.
    method : str
        One of :data:`METHODS` (``zoh``: inputs held between samples; ``tustin``: bilinear).
    units : Mapping[str, str], optional
        Unit of each signal, for the emitted code's header.
    notes : sequence of str
        Header lines describing the controller.

    Returns
    -------
    DiscreteController
        Without sample-rate limits (the loop is not known here; :func:`discretise_design`
        adds them).

    Raises
    ------
    OptionError
        ``ts`` not a number > 0, an unknown method, a controller that is not continuous-time
        or not finite.
    """
    import control

    _check_ts(ts, method)
    if control.isdtime(controller, strict=True):
        raise OptionError("the controller to discretise must be a continuous-time system")
    if not all(np.all(np.isfinite(np.asarray(m, dtype=float))) for m in
               (controller.A, controller.B, controller.C, controller.D)):
        raise OptionError("the controller to discretise has non-finite coefficients")
    dsys = control.c2d(controller, float(ts), method="bilinear" if method == "tustin" else method)
    return DiscreteController(dsys, float(ts), method, dict(units or {}), notes=tuple(notes))


def plant_system(model: MotorModel, design: Design) -> control.StateSpace:
    """The motor in the design's coordinates, its outputs the signals the design's controller reads.

    Parameters
    ----------
    model : MotorModel
        The model the design was made for.
    design : Design

    Returns
    -------
    control.StateSpace
        Input ``u``; outputs the measured channel (with an observer), the sensors (with a
        reduced-order observer) or every state of the design (without one).
    """
    import control

    from motorid.control.design import design_model, output_row

    work = design_model(model, design)
    n = work.A.shape[0]
    if design.reduced is not None:  # the sensors
        idx = [list(design.states).index(x) for x in design.reduced.measured]
        c, outputs = np.eye(n)[idx], list(design.reduced.measured)
    elif design.L is not None:
        c = np.asarray(output_row(work, design.output)[1], dtype=float).reshape(1, n)
        outputs = [design.output]
    else:
        c, outputs = np.eye(n), list(design.states)
    return control.ss(work.A, np.asarray(work.B, dtype=float).reshape(n, 1), c, np.zeros((c.shape[0], 1)),
                      inputs=[COMMAND], outputs=outputs, name="motor")


def discretise_design(model: MotorModel, design: Design, ts: float, method: str = "zoh", *,
                      rails: float | None = None) -> DiscreteController:
    """The controller of ``design`` sampled at ``ts``, checked against the loop it closes on ``model``.

    Parameters
    ----------
    model : MotorModel
        The model the design was made for.
    design : Design
    ts : float
        Sampling interval, s.
    method : str
        One of :data:`METHODS`.
    rails : float, optional
        Actuator rails ``±rails`` in the command's unit: the emitted step clamps the command,
        feeds the observer the clamped one and holds the integrator against them (``zoh`` only).

    Returns
    -------
    DiscreteController
        With the sample-rate limits and a warning when ``ts·|p| >`` :data:`SAMPLING_RULE`.

    Raises
    ------
    OptionError
        ``ts`` not > 0, at or beyond the Nyquist limit ``π/|p|`` of the loop's fastest pole, or
        making the sampled loop unstable; an unknown method; a design whose continuous loop is
        already unstable; rails not > 0, or with a method other than ``zoh``.

    References
    ----------
    Åström & Wittenmark, *Computer-Controlled Systems*, 3rd ed. (1997): the rule of thumb
    ``ω h ≈ 0.1–0.6`` for the sampling period.
    """
    _check_ts(ts, method)
    check_rails(rails, method)
    designed = design.output_feedback_poles if design.output_feedback_poles is not None else design.closed_loop_poles
    if designed is not None and np.size(designed) and float(np.max(np.real(designed))) >= 0:
        # sampling cannot make an unstable loop stable: the interval is not what is wrong
        raise OptionError("--discrete: the designed loop itself is unstable (a closed-loop pole at "
                          f"{float(np.max(np.real(designed))):.3g} rad/s in the right half-plane or on the axis); "
                          "fix the design before sampling it (see its warnings)")
    csys = controller_system(model, design)
    units = {name: signal_unit(name, design.units, output=design.output)
             for name in (*csys.input_labels, *csys.output_labels)}
    sampled = None
    column = None  # without an observer the command enters no state of the controller
    limiting: tuple[Any, ...] = (design.closed_loop_poles, design.observer_poles, design.output_feedback_poles,
                                 csys.poles())
    if method == "zoh" and (design.L is not None or design.reduced is not None):
        from motorid.control.sampled import sampled_controller_parts

        # the observer placed on the motor behind the hold, not c2d's hold of the measured signals: its
        # poles map to e^{p·TS} exactly, so only the state feedback's (held command) limit the interval
        sampled, column = sampled_controller_parts(model, design, ts)
        limiting = (design.closed_loop_poles,)
    poles = [np.asarray(p, dtype=complex).ravel() for p in limiting if p is not None]
    dc = _sampled(csys, plant_system(model, design), float(model.delay_s), poles, ts, method, units,
                  _design_notes(model, design), sampled=sampled)
    if rails is None:
        return dc
    states = list(dc.states)
    return replace(dc, rails=float(rails), command_column=column,
                   integrator=states.index("z") if design.ki is not None and "z" in states else None)


def discretise_pid(model: MotorModel, pid: PidDesign, ts: float, method: str = "zoh", *,
                   rails: float | None = None) -> DiscreteController:
    """A PID design sampled at ``ts``, checked as :func:`discretise_design` checks state feedback.

    The controller is :meth:`~motorid.control.pid.PidDesign.system` (inputs ``r`` and the channel).

    Parameters
    ----------
    model : MotorModel
        The model the PID was tuned for.
    pid : PidDesign
    ts : float
        Sampling interval, s.
    method : str
        One of :data:`METHODS`.
    rails : float, optional
        Actuator rails ``±rails`` in the command's unit: the emitted step clamps the command and
        holds the integrator against them (``zoh`` only), as :func:`discretise_design`.

    Returns
    -------
    DiscreteController

    Raises
    ------
    OptionError
        As :func:`discretise_design`.
    """
    import control

    from motorid.control.pid import channel_system
    from motorid.model.units import channel_unit

    _check_ts(ts, method)
    check_rails(rails, method)
    csys = pid.system()
    plant = channel_system(model, pid.loop)[0]
    # the loop's poles without the dead time's Padé poles (they are not the controller's business)
    closed = control.interconnect([control.ss(plant.A, plant.B, plant.C, plant.D, inputs=[COMMAND],
                                              outputs=[pid.output]), csys],
                                  inplist=[REFERENCE], outlist=[COMMAND], check_unused=False)
    designed = np.linalg.eigvals(np.asarray(closed.A, dtype=float)) if closed.nstates else np.zeros(0)
    if designed.size and float(np.max(designed.real)) >= 0:
        raise OptionError("--discrete: the PID loop itself is unstable without its dead time; fix the design "
                          "before sampling it")
    units = {REFERENCE: pid.output_unit, pid.output: pid.output_unit, COMMAND: channel_unit(model.units, "input")}
    motor = control.ss(plant.A, plant.B, plant.C, plant.D, inputs=[COMMAND], outputs=[pid.output], name="motor")
    notes = (f"Model: {model.method}, order {model.A.shape[0]}, outputs {', '.join(model.outputs)}",
             f"Design: {pid.kind} on the {pid.loop}, u = kp (r - y) + ki integral(r - y) - kd s/(tf s + 1) y; "
             f"y = {pid.output}",
             f"  kp = {pid.kp:.6g}, ki = {pid.ki:.6g}, kd = {pid.kd:.6g}, tf = {pid.tf_s:.6g} s")
    dc = _sampled(csys, motor, float(model.delay_s), [designed, csys.poles()], ts, method, units, notes)
    # zoh keeps the PID's states (e^{A·TS}): its integrator is still pid.matrices()'s
    return dc if rails is None else replace(dc, rails=float(rails), integrator=pid.matrices()[4])


def check_rails(rails: float | None, method: str) -> None:
    """Refuse rails that are no positive number, or with a sampling that mixes the controller's states.

    Parameters
    ----------
    rails : float or None
        The actuator rails ``±rails`` (None: none, nothing to check).
    method : str
        The discretisation method.

    Raises
    ------
    OptionError
        Rails not a finite number > 0, or a method other than ``zoh``.
    """
    if rails is None:
        return
    if isinstance(rails, bool) or not isinstance(rails, (int, float)) or not (math.isfinite(rails) and rails > 0):
        raise OptionError(f"--saturation must be the actuator's rails, a number > 0, got {rails!r}")
    if method != "zoh":
        raise OptionError(f"--saturation with --discrete-method {method}: the rails need the zero-order-hold form "
                          "(zoh, the default), whose integrator is a state of its own and whose observer is fed "
                          "the command applied")


def _sampled(csys: control.StateSpace, motor_c: control.StateSpace, tau: float, poles: list[np.ndarray],
             ts: float, method: str, units: dict[str, str], notes: tuple[str, ...], *,
             sampled: control.StateSpace | None = None) -> DiscreteController:
    """``csys`` discretised (or ``sampled``, already so), with the sample-rate limits of ``poles``, the loop checked."""
    import control

    fastest = float(np.max(np.abs(np.concatenate([np.asarray(p, dtype=complex).ravel() for p in poles])),
                           initial=0.0))
    ts_max = math.pi / fastest if fastest > 0 else None
    if ts_max is not None and ts >= ts_max:
        raise OptionError(f"--discrete {ts:g} s is at or beyond the Nyquist limit pi/|p| = {ts_max:.3g} s of the "
                          f"loop's fastest pole (|p| = {fastest:.3g} rad/s); sample faster, e.g. --discrete "
                          f"{SAMPLING_RULE / fastest:.2g}")
    dc = discretise(csys, ts, method, units=units) if sampled is None else \
        DiscreteController(sampled, float(ts), method, dict(units), how=SAMPLED_OBSERVER)
    # the sampled loop: the motor (its dead time as a Padé approximant, as in the margins) behind a
    # zero-order hold (the DAC), read every TS
    delayed = tau * max(fastest, 1.0) > 1e-6
    if delayed:
        with_delay = motor_c * control.ss(control.tf(*control.pade(tau, PADE_ORDER)))
        motor_c = control.ss(with_delay.A, with_delay.B, with_delay.C, with_delay.D, inputs=[COMMAND],
                             outputs=motor_c.output_labels, name="motor")
    motor = control.c2d(motor_c, float(ts), method="zoh")
    loop = control.interconnect([motor, dc.system], inplist=["r"], outlist=[COMMAND], check_unused=False)
    rho = float(np.max(np.abs(np.linalg.eigvals(np.asarray(loop.A, dtype=float))), initial=0.0))
    if not rho < 1.0:
        raise OptionError(f"--discrete {ts:g} s: the sampled loop is unstable (largest |z| = {rho:.4g} >= 1 with "
                          f"the {method} controller and the motor behind a zero-order hold); sample faster, e.g. "
                          f"--discrete {SAMPLING_RULE / max(fastest, 1e-12):.2g}")
    warnings: list[str] = []
    if fastest > 0 and ts * fastest > SAMPLING_RULE:
        warnings.append(f"TS*|p| = {ts * fastest:.2g} for the loop's fastest pole (|p| = {fastest:.3g} rad/s) is "
                        f"above {SAMPLING_RULE} (the rule of thumb, {RULE_SOURCE}): the sampled loop departs from "
                        f"the design; TS <= {SAMPLING_RULE / fastest:.2g} s keeps to it")
    return DiscreteController(dc.system, dc.ts_s, method, units, fastest if fastest > 0 else None, ts_max, rho,
                              notes, tuple(warnings), dc.how)


def _design_notes(model: MotorModel, design: Design) -> tuple[str, ...]:
    """The header lines naming the model and the design of an emitted controller."""
    from motorid.numfmt import roots_text

    unit_of = {name: signal_unit(name, design.units, output=design.output) for name in design.states}
    kr_unit, ki_unit = design.reference_units()
    how = "state feedback u = -K x + kr r"
    if design.ki is not None:
        how = "state feedback with integral action u = -K x - ki z, dz/dt = y - r"
    if design.L is not None:
        how += f", the states estimated by a Luenberger observer from {design.output} and u"
    if design.reduced is not None:
        red = design.reduced
        how += (f", {', '.join(red.estimated)} estimated by a reduced-order observer from "
                f"{', '.join(red.measured)} and u (dw/dt = F w + G z_m + H u, estimate = w + L z_m)")
    lines = [
        f"Model: {model.method}, order {model.A.shape[0]}, outputs {', '.join(model.outputs)}"
        + (f", identified at {model.sample_interval_s:g} s" if model.sample_interval_s else ""),
        f"Design: {how}; y = {design.output}",
        "  K = [" + ", ".join(f"{k:.6g}" for k in design.K) + "] on ["
        + ", ".join(f"{s} [{unit_of[s] or '-'}]" for s in design.states) + "]"
        + (f", kr = {design.kr:.6g} [{kr_unit}]" if design.kr is not None else "")
        + (f", ki = {design.ki:.6g} [{ki_unit}]" if design.ki is not None else ""),
        "  closed-loop poles: " + roots_text(design.closed_loop_poles) + " rad/s",
    ]
    if design.L is not None and design.observer_poles is not None:
        lines.append("  L = [" + ", ".join(f"{v:.6g}" for v in design.L) + "], observer poles: "
                     + roots_text(design.observer_poles) + " rad/s")
    if design.reduced is not None:
        lines.append("  reduced observer poles: " + roots_text(design.reduced.poles) + " rad/s")
    return tuple(lines)


# ---------------------------------------------------------------------------------------------
# the emitters

_C_KEYWORDS = frozenset((
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else", "enum", "extern",
    "float", "for", "goto", "if", "inline", "int", "long", "register", "restrict", "return", "short", "signed",
    "sizeof", "static", "struct", "switch", "typedef", "union", "unsigned", "void", "volatile", "while",
    # Python's and MATLAB's words that are no C keywords
    "and", "or", "not", "in", "is", "def", "lambda", "pass", "class", "end", "function"))

_ASCII = {"x̂": "xhat", "ż": "dz/dt", "ω": "w", "ζ": "zeta", "τ": "tau", "·": "*", "−": "-", "≈": "~",
          "≤": "<=", "≥": ">=", "²": "^2", "—": "-", "–": "-", "×": "x", "°": " deg", "…": "..."}


def _ascii(text: str) -> str:
    """``text`` in ASCII (C, MATLAB and Arduino editors see no surprises)."""
    for k, v in _ASCII.items():
        text = text.replace(k, v)
    return text.encode("ascii", "replace").decode("ascii")


def _identifier(name: str, taken: set[str]) -> str:
    """A C/Python/MATLAB identifier for a signal name, distinct from ``taken``."""
    ident = re.sub(r"\W", "_", _ascii(name)).strip("_") or "in"
    if ident[0].isdigit():
        ident = "in_" + ident
    while ident in taken or ident in _C_KEYWORDS:
        ident += "_in"
    taken.add(ident)
    return ident


def _number(v: float) -> str:
    """``%.17g``: the double read back exactly."""
    return format(v, ".17g")


def _sum(terms: Sequence[tuple[float, str]]) -> str:
    """``c0*v0 + c1*v1 - …`` without the zero coefficients (``0.0`` when none is left)."""
    out = ""
    for coef, var in terms:
        if coef == 0.0:
            continue
        mag = _number(abs(coef))
        if not out:
            out = f"{'-' if coef < 0 else ''}{mag}*{var}"
        else:
            out += f" {'-' if coef < 0 else '+'} {mag}*{var}"
    return out or "0.0"


@dataclass(frozen=True, slots=True)
class _Equations:
    """The unrolled difference equations, with the names each language uses."""

    inputs: tuple[str, ...]   # identifiers, in the order of Bd's columns
    states: tuple[str, ...]   # locals holding x[k]
    outputs: tuple[str, ...]  # identifiers
    output_rhs: tuple[str, ...]
    state_rhs: tuple[str, ...]
    # with rails: the command asked for (output_rhs), the states' update with the applied command
    # (state_rhs), the integrator's increment and how much of it reaches the command
    rails: float | None = None
    integrator: int | None = None
    increment_rhs: str = ""
    push: float = 0.0

    @property
    def raw(self) -> str:
        """The name of the command asked for, before the rails."""
        return f"{self.outputs[0]}_raw"


def _as_discrete(dc: Any) -> DiscreteController:
    """``dc`` itself, or a discrete-time python-control system wrapped as one (method ``given``)."""
    if isinstance(dc, DiscreteController):
        return dc
    dt = getattr(dc, "dt", None)
    if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not (math.isfinite(dt) and dt > 0):
        raise OptionError("the emitters write a discrete-time system with a sampling interval (dt > 0); "
                          "discretise a continuous-time controller first")
    return DiscreteController(dc, float(dt), "given")


def _equations(dc: DiscreteController) -> _Equations:
    if len(dc.outputs) != 1:
        raise OptionError(f"the emitters write a controller with one output (the command), this one has "
                          f"{len(dc.outputs)}")
    taken = {"s", "x", "xk", "ctl"}
    inputs = tuple(_identifier(n, taken) for n in dc.inputs)
    outputs = tuple(_identifier(n, taken) for n in dc.outputs)
    states = tuple(_identifier(f"xk{i}", taken) for i in range(len(dc.states)))
    ad, bd, cd, dd = dc.Ad, dc.Bd, dc.Cd, dc.Dd
    if not all(np.all(np.isfinite(m)) for m in (ad, bd, cd, dd)):
        raise OptionError("the discretised controller has non-finite coefficients")

    def row(a_row: np.ndarray, b_row: np.ndarray, extra: Sequence[tuple[float, str]] = ()) -> str:
        return _sum([*zip(a_row, states, strict=True), *zip(b_row, inputs, strict=True), *extra])

    outs = tuple(row(cd[i], dd[i]) for i in range(cd.shape[0]))
    if dc.rails is None:
        return _Equations(inputs, states, outputs, outs, tuple(row(ad[i], bd[i]) for i in range(ad.shape[0])))
    # the command enters the states as applied (clamped): x[k+1] = A0 x + B0 in + b_u u
    a0, b0 = dc.open_matrices()
    bu = dc.applied_column()
    rows = tuple(row(a0[i], b0[i], [(bu[i], outputs[0])]) for i in range(a0.shape[0]))
    iz = dc.integrator
    increment, push = "", 0.0
    if iz is not None:
        step = a0[iz].copy()
        step[iz] -= 1.0  # the increment: the update less the state itself
        increment, push = row(step, b0[iz], [(bu[iz], outputs[0])]), float(cd[0, iz])
    return _Equations(inputs, states, outputs, outs, rows, float(dc.rails), iz, increment, push)


def _header(dc: DiscreteController, name: str, source: str | None) -> list[str]:
    from motorid import __version__

    lines = [f"{name}: a controller as difference equations, generated by motorid {__version__}."]
    if source:
        lines.append(source)
    lines.append("")
    lines += list(dc.notes)
    how = f"discretised by {dc.description()}" if dc.method in METHODS else "a discrete-time system as given"
    lines.append(f"Sampling: TS = {dc.ts_s:g} s ({1 / dc.ts_s:.6g} Hz), {how}")
    lines.append("Signals: " + ", ".join(f"{n} [{dc.units.get(n) or '-'}]" for n in (*dc.inputs, *dc.outputs)))
    if dc.states:
        lines.append("State: " + ", ".join(dc.states))
    p, ts_max = dc.fastest_pole_rad_s, dc.ts_max_s
    if p is not None and ts_max is not None:
        lines.append(f"Sample-rate limits: fastest loop pole |p| = {p:.4g} rad/s; TS*|p| = {dc.ts_s * p:.3g} "
                     f"(rule of thumb TS*|p| <= {SAMPLING_RULE}, i.e. TS <= {SAMPLING_RULE / p:.3g} s, "
                     f"{RULE_SOURCE}); Nyquist limit TS < pi/|p| = {ts_max:.4g} s")
    if dc.loop_spectral_radius is not None:
        lines.append("Sampled loop (motor behind a zero-order hold, its dead time included, + this controller): "
                     f"largest |z| = {dc.loop_spectral_radius:.6g}")
    lines += [f"WARNING: {w}" for w in dc.warnings]
    if dc.rails is None:
        lines += ["", "x[k+1] = Ad x[k] + Bd in[k],  u[k] = Cd x[k] + Dd in[k],  in = ["
                  + ", ".join(dc.inputs) + "]; coefficients printed with %.17g."]
    else:
        unit = dc.units.get(COMMAND) or ""
        lines += [f"Rails: the command is clamped to +-{dc.rails:g} {unit}".rstrip()
                  + (", the observer fed the clamped command" if np.any(dc.applied_column()) else "")
                  + ("; the integrator holds while the command is beyond a rail and its increment would push it "
                     "further (conditional integration)" if dc.integrator is not None else "")
                  + f": as motorid simulate --saturation {dc.rails:g} runs it",
                  "", "u_raw[k] = Cd x[k] + Dd in[k],  u[k] = clamp(u_raw[k]),  x[k+1] = (Ad - b_u Cd) x[k] + "
                  "(Bd - b_u Dd) in[k] + b_u u[k],  in = [" + ", ".join(dc.inputs) + "]; coefficients printed "
                  "with %.17g."]
    return [_ascii(line) for line in lines]


def _wrap(text: str, prefix: str, width: int = 100) -> list[str]:
    import textwrap

    if not text:
        return [prefix.rstrip()]
    return textwrap.wrap(text, width, initial_indent=prefix, subsequent_indent=prefix + "  ",
                         break_long_words=False, break_on_hyphens=False) or [prefix.rstrip()]


def emit_c(dc: DiscreteController | control.StateSpace, *, name: str = "motor_controller",
           source: str | None = None) -> str:
    """The controller as a C99 source file: a state struct, an init function and a step function.

    Parameters
    ----------
    dc : DiscreteController or control.StateSpace
        From :func:`discretise` or :func:`discretise_design`, or any discrete-time system
        (``dt > 0``) with one output.
    name : str
        Prefix of the type and functions (``<name>_state``, ``<name>_init``, ``<name>_step``).
    source : str, optional
        One header line saying where the controller came from (the model and design files).

    Returns
    -------
    str
        C99 (``double`` arithmetic, no library calls): call ``<name>_init(&s)`` once, then
        ``u = <name>_step(&s, r, y…)`` once per sample, every ``TS`` seconds.

    Raises
    ------
    OptionError
        A controller with more than one output, a name that is no identifier.
    """
    dc = _as_discrete(dc)
    eq = _equations(dc)
    ident = _c_name(name)
    n = len(eq.states)
    upper = ident.upper()
    out = ["/*"]
    # nothing in the header may close (or nest) the comment
    header = [raw.replace("*/", "* /").replace("/*", "/ *") for raw in _header(dc, ident, source)]
    out += [f" * {line}".rstrip() for raw in header for line in _wrap(raw, "")]
    out += [" *",
            " * Use (e.g. an Arduino sketch):",
            f" *   static {ident}_state ctl;          in setup():  {ident}_init(&ctl);",
            f" *   every {dc.ts_s:g} s (a timer, or micros()):  read the sensors, then",
            f" *   double {eq.outputs[0]} = {ident}_step(&ctl, {', '.join(eq.inputs)});",
            " *   and write it to the amplifier.",
            *_amplifier_hint(dc.units.get(COMMAND) or "", eq.outputs[0]),
            " * On 8-bit AVR boards (Uno, Nano) double is 32 bits: the coefficients round to about 7 digits;",
            " * check the loop there, or use a board with a 64-bit double (32-bit ARM: Due, Teensy).",
            " */",
            "",
            f"#define {upper}_TS {_number(dc.ts_s)}",
            f"#define {upper}_NSTATES {n}",
            *([] if dc.rails is None else [f"#define {upper}_RAILS {_number(dc.rails)}"]),
            "",
            "typedef struct {",
            f"    double x[{max(n, 1)}];  /* "
            + (_ascii(", ".join(dc.states)) if n else "no state: a static gain (unused)") + " */",
            f"}} {ident}_state;",
            "",
            f"void {ident}_init({ident}_state *s)",
            "{"]
    out += [f"    s->x[{i}] = 0.0;" for i in range(max(n, 1))]
    out += ["}", "",
            f"double {ident}_step({ident}_state *s, " + ", ".join(f"double {v}" for v in eq.inputs) + ")",
            "{"]
    out += [f"    const double {v} = s->x[{i}];" for i, v in enumerate(eq.states)]
    out += _body(eq, _C, rails=f"{upper}_RAILS")
    if n == 0:
        out += ["    (void)s;"]
    out += [f"    return {eq.outputs[0]};", "}", ""]
    return "\n".join(out)


def emit_python(dc: DiscreteController | control.StateSpace, *, name: str = "motor_controller",
                source: str | None = None) -> str:
    """The controller as a Python module with the same difference equations as :func:`emit_c`.

    Parameters
    ----------
    dc : DiscreteController or control.StateSpace
        As for :func:`emit_c`.
    name : str
        Prefix of the functions (``<name>_init``, ``<name>_step``).
    source : str, optional
        One header line saying where the controller came from.

    Returns
    -------
    str
        Python (no imports): ``x = <name>_init()`` once, then ``u = <name>_step(x, r, y…)``
        once per sample (``x`` is updated in place).
    """
    dc = _as_discrete(dc)
    eq = _equations(dc)
    ident = _c_name(name)
    n = len(eq.states)
    lines = ['"""' + f"{ident}: a controller as difference equations (motorid)."]
    # nothing in the header may end the docstring or start an escape sequence
    header = [raw.replace("\\", "/").replace('"""', "'''") for raw in _header(dc, ident, source)[1:]]
    lines += [line for raw in header for line in _wrap(raw, "")]
    lines += ["", f"Use: x = {ident}_init(), then every TS seconds u = {ident}_step(x, {', '.join(eq.inputs)}).",
              '"""', "", f"TS = {_number(dc.ts_s)}", f"INPUTS = {tuple(dc.inputs)!r}",
              *([] if dc.rails is None else [f"RAILS = {_number(dc.rails)}"]), "", "",
              f"def {ident}_init():", '    """The state x[0]: zeros."""', f"    return [0.0] * {max(n, 1)}", "", "",
              f"def {ident}_step(x, {', '.join(eq.inputs)}):",
              '    """One sample: the command u[k]; x becomes x[k+1] in place."""']
    lines += [f"    {v} = x[{i}]" for i, v in enumerate(eq.states)]
    lines += _body(eq, _PYTHON, rails="RAILS")
    lines += [f"    return {eq.outputs[0]}", ""]
    return "\n".join(lines)


def emit_matlab(dc: DiscreteController | control.StateSpace, *, name: str = "motor_controller",
                source: str | None = None) -> str:
    """The controller as a MATLAB/Octave function with the same difference equations as :func:`emit_c`.

    Parameters
    ----------
    dc : DiscreteController or control.StateSpace
        As for :func:`emit_c`.
    name : str
        The function's name (save the file as ``<name>_step.m``).
    source : str, optional
        One header line saying where the controller came from.

    Returns
    -------
    str
        ``function [u, x] = <name>_step(x, r, y…)``: start with ``x = zeros(n, 1)``.
    """
    dc = _as_discrete(dc)
    eq = _equations(dc)
    ident = _c_name(name)
    n = len(eq.states)
    lines = [f"function [{eq.outputs[0]}, x] = {ident}_step(x, {', '.join(eq.inputs)})"]
    lines += [f"% {line}".rstrip() for raw in _header(dc, ident, source) for line in _wrap(raw, "")]
    lines += ["%", f"% Use: x = zeros({max(n, 1)}, 1); then every TS = {dc.ts_s:g} s "
                   f"[{eq.outputs[0]}, x] = {ident}_step(x, {', '.join(eq.inputs)});"]
    lines += [f"{v} = x({i + 1});" for i, v in enumerate(eq.states)]
    lines += _body(eq, _MATLAB, rails=_number(eq.rails) if eq.rails is not None else "")
    lines += ["end", ""]
    return "\n".join(lines)


@dataclass(frozen=True, slots=True)
class _Dialect:
    """How one language writes the step's statements (``{…}`` filled by :func:`_body`)."""

    let: str        # a local from an expression: {name}, {rhs}
    state: str      # the next state {i} (0-based) from {rhs}
    clamp: str      # {u} from {raw} within ±{rails}
    hold: str       # the flag from {raw}, {rails}, {push}
    held: str       # the integrator {i} from {x} (itself) and dz, unless held
    comment: str    # a comment line: {text}
    note: str       # a comment after a statement: {text}


_C = _Dialect(
    "    const double {name} = {rhs};", "    s->x[{i}] = {rhs};",
    "    const double {u} = {raw} > {rails} ? {rails} : ({raw} < -{rails} ? -{rails} : {raw});",
    "    const int hold = ({raw} > {rails} && {push}*dz > 0.0) || ({raw} < -{rails} && {push}*dz < 0.0);",
    "    s->x[{i}] = hold ? {x} : {x} + dz;", "    /* {text} */", "  /* {text} */")
_PYTHON = _Dialect(
    "    {name} = {rhs}", "    x[{i}] = {rhs}", "    {u} = min(max({raw}, -{rails}), {rails})",
    "    hold = ({raw} > {rails} and {push}*dz > 0.0) or ({raw} < -{rails} and {push}*dz < 0.0)",
    "    x[{i}] = {x} if hold else {x} + dz", "    # {text}", "  # {text}")
_MATLAB = _Dialect(
    "{name} = {rhs};", "x({i1}) = {rhs};", "{u} = min(max({raw}, -{rails}), {rails});",
    "hold = ({raw} > {rails} && {push}*dz > 0) || ({raw} < -{rails} && {push}*dz < 0);",
    "if hold, x({i1}) = {x}; else, x({i1}) = {x} + dz; end", "% {text}", "  % {text}")


def _body(eq: _Equations, d: _Dialect, *, rails: str) -> list[str]:
    """The step's statements: the command (clamped to the rails, if any) and the next state.

    One generator for the three languages (their syntax in ``d``), so that the C, Python and
    MATLAB controllers stay the same equations.
    """
    u = eq.outputs[0]
    if eq.rails is None:
        return [d.let.format(name=u, rhs=eq.output_rhs[0]),
                *(d.state.format(i=i, i1=i + 1, rhs=rhs) for i, rhs in enumerate(eq.state_rhs))]
    raw, push, iz = eq.raw, _number(eq.push), eq.integrator
    out = [d.let.format(name=raw, rhs=eq.output_rhs[0]),
           d.clamp.format(u=u, raw=raw, rails=rails) + d.note.format(text="the actuator's rails")]
    if iz is not None:
        out += [d.let.format(name="dz", rhs=eq.increment_rhs) + d.note.format(text="the integrator's increment"),
                d.comment.format(text="conditional integration: hold while the command is beyond a rail and dz "
                                      "would push it further"),
                d.hold.format(raw=raw, rails=rails, push=push)]
    out += [d.state.format(i=i, i1=i + 1, rhs=rhs) for i, rhs in enumerate(eq.state_rhs) if i != iz]
    if iz is not None:
        out.append(d.held.format(i=iz, i1=iz + 1, x=eq.states[iz]))
    return out


_EMITTERS: dict[str, Callable[..., str]] = {"c": emit_c, "python": emit_python, "matlab": emit_matlab}


def emit(dc: DiscreteController | control.StateSpace, language: str, *, name: str = "motor_controller",
         source: str | None = None) -> str:
    """The controller's code in ``language`` (one of :data:`LANGUAGES`).

    Parameters
    ----------
    dc : DiscreteController or control.StateSpace
        As for :func:`emit_c`.
    language : str
        ``c``, ``python`` or ``matlab``.
    name : str
        Prefix of the emitted functions.
    source : str, optional
        One header line saying where the controller came from.

    Returns
    -------
    str
        The source text.

    Raises
    ------
    OptionError
        An unknown language.
    """
    if language not in _EMITTERS:
        raise OptionError(f"--emit {language!r}: use one of {', '.join(LANGUAGES)}")
    return _EMITTERS[language](dc, name=name, source=source)


def _amplifier_hint(unit: str, u: str) -> list[str]:
    """How the command reaches an H-bridge on an Arduino, for the C header (its sign is the direction)."""
    if unit.lower() in ("pwm", "duty", "counts"):  # a duty in analogWrite's counts, as the model's input was logged
        return [" *   With an H-bridge (its magnitude the duty, 0..255: --saturation 255):",
                f" *     analogWrite(PWM_PIN, (int)fabs({u}));  digitalWrite(DIR_PIN, {u} >= 0.0);"]
    if unit == "V":  # volts across the motor, from a supply of VS volts
        return [f" *   With an H-bridge on a supply of VS volts (--saturation VS keeps |{u}| <= VS):",
                f" *     analogWrite(PWM_PIN, (int)(255.0 * fabs({u}) / VS));  digitalWrite(DIR_PIN, {u} >= 0.0);"]
    return []


def _c_name(name: str) -> str:
    if not re.fullmatch(r"[A-Za-z_]\w*", name) or name in _C_KEYWORDS:
        raise OptionError(f"the controller's name {name!r} must be an identifier (letters, digits, _)")
    return name

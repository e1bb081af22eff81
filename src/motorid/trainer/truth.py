"""Ground truth of the virtual trainer: exact transfer functions of the linearised plant."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import control
import numpy as np

from motorid.errors import OptionError
from motorid.trainer.plant import simulate_plant
from motorid.trainer.presets import TrainerConfig

__all__ = ["FirstOrder", "Truth", "step_residence_time", "truth_of"]

#: Integration step of :func:`step_residence_time` (s): the linear part is exact at any step,
#: this resolves the friction's stick and break-away.
RESIDENCE_STEP_S = 1e-4
#: :func:`step_residence_time` integrates over this many linear mean residence times.
RESIDENCE_SPAN = 40.0


@dataclass(frozen=True, slots=True)
class FirstOrder:
    """Dominant first-order approximation ``dc_gain / (time_constant_s·s + 1)`` of velocity.

    Attributes
    ----------
    dc_gain : float
        Input volts → tacho volts in steady state.
    time_constant_s : float
        Time constant, s (the paper's ``1/p`` of ``k/(s+p)``).
    """

    dc_gain: float
    time_constant_s: float


@dataclass(frozen=True, slots=True)
class Truth:
    """Linearised trainer: input volts → measured volts, per channel (python-control TFs).

    Attributes
    ----------
    velocity, position, current : control.TransferFunction
        Input V → tacho V, → unwrapped position V, → current-monitor V.
    dc_gain : float
        Velocity DC gain, V/V.
    time_constant_s : float
        Dominant first-order time constant of the velocity channel by the method of moments
        (mean residence time ``Σ1/p − Σ1/z``).
    equivalent_input_offset_v : float
        Dead-zone plus Coulomb friction and brake torque referred to the input (volts of step
        lost to them in steady state while the shaft turns; exact for a constant input).
    """

    velocity: control.TransferFunction
    position: control.TransferFunction
    current: control.TransferFunction
    dc_gain: float
    time_constant_s: float
    equivalent_input_offset_v: float

    @property
    def first_order(self) -> FirstOrder:
        """The velocity channel's first-order approximation (``dc_gain``, ``time_constant_s``)."""
        return FirstOrder(self.dc_gain, self.time_constant_s)

    def to_json(self) -> dict[str, Any]:
        """Numerators/denominators (highest power first, ``den[0] = 1``) and first order.

        Returns
        -------
        dict
            JSON-able.
        """
        def poly(tf: control.TransferFunction) -> dict[str, list[float]]:
            num = np.atleast_1d(np.squeeze(tf.num[0][0])).astype(float)
            den = np.atleast_1d(np.squeeze(tf.den[0][0])).astype(float)
            return {"num": (num / den[0]).tolist(), "den": (den / den[0]).tolist()}

        return {
            "velocity_tf": poly(self.velocity),
            "position_tf": poly(self.position),
            "current_tf": poly(self.current),
            "first_order": {"dc_gain": self.dc_gain, "time_constant": self.time_constant_s},
            "velocity_poles": [[float(p.real), float(p.imag)] for p in control.poles(self.velocity)],
            "velocity_zeros": [[float(z.real), float(z.imag)] for z in control.zeros(self.velocity)],
            "equivalent_input_offset_v": self.equivalent_input_offset_v,
        }


def truth_of(config: TrainerConfig) -> Truth:
    """Linearise the trainer (no dead-zone, Coulomb friction, rails) and build its TFs.

    Parameters
    ----------
    config : TrainerConfig
        Any configuration; its nonlinear parts are ignored.

    Returns
    -------
    Truth
        The exact transfer functions of the linear part: with the amplifier
        ``A(s) = gain·(1 + lead·s)/(1 + lag·s)`` and ``D(s) = (La s + Ra)(J s + b) + k²``,
        ω/V = A·k/D, I/V = A·(J s + b)/D, position = span/(2π)·gear·ω/s.
    """
    c = config
    s = control.tf("s")
    amp = c.amp_gain * ((1 + c.amp_lead_s * s) / (1 + c.amp_lag_s * s) if c.amp_lag_s > 0 or c.amp_lead_s > 0 else 1)
    den = (c.la_h * s + c.ra_ohm) * (c.j_kgm2 * s + c.b_nms) + c.k_motor**2
    omega = amp * c.k_motor / den
    current = amp * (c.j_kgm2 * s + c.b_nms) / den
    velocity = control.minreal(c.tacho_v_per_rad_s * omega, verbose=False)
    position = control.minreal(c.pot_span_v / (2 * math.pi) * c.gear_ratio * omega / s, verbose=False)
    current = control.minreal(c.current_v_per_a * current, verbose=False)
    poles = control.poles(velocity)
    zeros = control.zeros(velocity)
    tau = float(np.real(np.sum(-1.0 / poles) - np.sum(-1.0 / zeros)))
    # steady state with sliding friction and brake torque T: k·i = b·ω + T, V = Ra·i + k·ω, so the
    # torque costs Ra·T/k armature volts, i.e. Ra·T/(k·gain) input volts, on top of the dead-zone
    offset = c.amp_dead_zone_v + c.ra_ohm * (c.coulomb_nm + c.brake_nm) / (c.k_motor * c.amp_gain)
    return Truth(velocity, position, current, float(np.real(control.dcgain(velocity))), tau, float(offset))


def step_residence_time(config: TrainerConfig, step_volts: float) -> float:
    """Mean residence time of the velocity's noise-free step response from rest, nonlinear plant.

    ``∫(1 − ω(t)/ω∞) dt`` of the motor speed after a step at ``t = 0``, simulated with the
    dead-zone, the friction (stuck until the drive torque breaks away, then sliding), the rails
    and the amplifier lead/lag.  For the linear plant it is the moments time constant
    ``Σ1/p − Σ1/z`` of :func:`truth_of`; sliding friction is a load torque, whose transfer to
    the speed has the armature's zero ``−Ra/La``, so it lengthens the response by about
    ``La/Ra`` times the fraction of the step it costs.  This is the residence time a linear
    model of the recorded step can show (what an estimator is compared with), as the DC gain
    is the linear one times ``1 − offset/step``.

    Parameters
    ----------
    config : TrainerConfig
        The trainer (its noise, ripple and glitches play no part).
    step_volts : float
        Step level at the amplifier's input, V.

    Returns
    -------
    float
        The residence time, s.

    Raises
    ------
    OptionError
        When the step does not turn the motor (within the dead-zone and friction).
    """
    lin = truth_of(config).time_constant_s
    t = np.arange(0.0, RESIDENCE_SPAN * lin, RESIDENCE_STEP_S)
    speed = simulate_plant(config.quiet(), t, np.full(t.size, float(step_volts)), substeps=1).motor_speed_rad_s
    final = float(speed[-1])
    if not abs(final) > 0:
        raise OptionError(f"a step of {step_volts:g} V does not turn the trainer's motor (dead-zone and friction)")
    from scipy.integrate import trapezoid

    return float(trapezoid(1.0 - speed / final, dx=RESIDENCE_STEP_S))

"""Physical parameters of the virtual servo trainer and its presets.

The trainer stands in for the bench of the paper (Feedback 33-110 servo trainer recorded on a
Tektronix TDS2012C, Masoud 2019, section V) and of the lab report (Tsiolakis 2022, section 1).
Parameters are physical (ohms, henries, kg·m², N·m) so that the nonlinear simulation is
honest; each preset is built from the quantities its document measures (DC gain, time
constants) by :func:`_motor_from_targets`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from motorid.errors import OptionError

__all__ = ["TrainerConfig", "PRESET_NAMES", "preset"]


@dataclass(frozen=True, slots=True)
class TrainerConfig:
    """Everything that defines the virtual trainer.

    Attributes
    ----------
    amp_gain : float
        Servo-amplifier voltage gain (V at the armature per V at the input).
    amp_dead_zone_v : float
        Input dead-zone half-width, V.
    amp_rail_v : float
        Amplifier output saturation (rails), ±V.
    amp_lead_s, amp_lag_s : float
        Lead/lag of the amplifier ``(1 + lead·s)/(1 + lag·s)``; both 0 for none.  The paper
        attributes the zero of its velocity TF to the amplifier.
    ra_ohm, la_h : float
        Armature resistance and inductance.
    k_motor : float
        Torque constant = back-EMF constant (N·m/A = V·s/rad).
    j_kgm2, b_nms : float
        Rotor inertia and viscous friction.
    coulomb_nm, static_nm : float
        Coulomb (sliding) and static (break-away) friction torque.
    brake_nm : float
        Load torque of the magnetic brake (lab report §2.2.2), opposing motion.
    gear_ratio : float
        Output-shaft angle per motor angle.
    tacho_v_per_rad_s : float
        Tachogenerator gain on the motor shaft.
    tacho_ripple : float
        Commutator ripple, fraction of the tacho voltage.
    tacho_segments : int
        Ripple cycles per motor turn.
    pot_span_v : float
        Position-sensor volts per output turn; the output jumps by this at each wrap.
    pot_glitch_max : int
        Most near-zero samples recorded while the wiper crosses the gap (paper Fig. 22/24).
    current_v_per_a : float
        Armature-current monitor gain.
    pwm_noise_v, pwm_hz : float
        PWM H-bridge switching noise on the current monitor (paper Fig. 18).
    noise_v : float
        White noise of every measured channel (probe and scope front end), V rms.
    substeps : int
        Integration sub-steps per scope sample.
    """

    amp_gain: float = 2.0
    amp_dead_zone_v: float = 0.05
    amp_rail_v: float = 12.0
    amp_lead_s: float = 0.0
    amp_lag_s: float = 0.0
    ra_ohm: float = 2.5
    la_h: float = 0.05
    k_motor: float = 0.05
    j_kgm2: float = 4.0e-4
    b_nms: float = 1.0e-5
    coulomb_nm: float = 1.0e-3
    static_nm: float = 1.5e-3
    brake_nm: float = 0.0
    gear_ratio: float = 1.0 / 140.0
    tacho_v_per_rad_s: float = 0.0229
    tacho_ripple: float = 0.01
    tacho_segments: int = 7
    pot_span_v: float = 20.4
    pot_glitch_max: int = 3
    current_v_per_a: float = 1.0
    pwm_noise_v: float = 0.15
    pwm_hz: float = 4883.0
    noise_v: float = 0.01
    substeps: int = 8

    def ideal(self) -> "TrainerConfig":
        """The linear plant: no dead-zone, friction nonlinearity, rails, ripple or noise."""
        return replace(
            self, amp_dead_zone_v=0.0, amp_rail_v=1e9, coulomb_nm=0.0, static_nm=0.0,
            brake_nm=0.0, tacho_ripple=0.0, pot_glitch_max=0, pwm_noise_v=0.0, noise_v=0.0,
        )

    def quiet(self) -> "TrainerConfig":
        """The nonlinear plant without random noise, ripple or glitches."""
        return replace(self, tacho_ripple=0.0, pot_glitch_max=0, pwm_noise_v=0.0, noise_v=0.0)


def _motor_from_targets(
    base: TrainerConfig, *, dc_rad_s_per_v: float, tau_m_s: float, tau_e_s: float, ra_ohm: float
) -> TrainerConfig:
    """Physical motor parameters giving a DC gain and mechanical/electrical time constants.

    With ``kt = ke = k``: ``ω/V = k / ((La s + Ra)(J s + b) + k²)``.  Choosing ``k = 0.5/DC``
    leaves half of the damping to viscous friction; ``J = τm (Ra b + k²)/Ra``, ``La = τe·Ra``.
    """
    k = 0.5 / dc_rad_s_per_v
    b = k * (1.0 / dc_rad_s_per_v - k) / ra_ohm
    j = tau_m_s * (ra_ohm * b + k * k) / ra_ohm
    return replace(base, k_motor=k, b_nms=b, j_kgm2=j, ra_ohm=ra_ohm, la_h=tau_e_s * ra_ohm)


def _paper() -> TrainerConfig:
    # 5.92 V step → tacho 5.36 V (DC gain 0.905), first-order τ ≈ 0.43 s: mechanical pole
    # plus a visible electrical pole (20 ms) plus the amplifier's lead/lag (zero 60 ms,
    # pole 15 ms); mean residence time 0.44 + 0.02 + 0.015 − 0.06 ≈ 0.41 s, 63% time ≈ 0.45 s.
    base = TrainerConfig(amp_gain=2.0, amp_lead_s=0.06, amp_lag_s=0.015)
    dc = 19.8  # rad/s per armature volt
    cfg = _motor_from_targets(base, dc_rad_s_per_v=dc, tau_m_s=0.44, tau_e_s=0.02, ra_ohm=2.5)
    cfg = replace(cfg, coulomb_nm=0.02 * cfg.k_motor, static_nm=0.03 * cfg.k_motor)
    # the dead-zone and Coulomb friction cost part of the step: scale the tacho so that the
    # *measured* level at 5.92 V is the paper's 5.36 V (the linear DC gain is then ~0.917)
    offset = cfg.amp_dead_zone_v + cfg.ra_ohm * cfg.coulomb_nm / (cfg.k_motor * cfg.amp_gain)
    tacho = 0.905 * 5.92 / (5.92 - offset) / (cfg.amp_gain * dc)
    # position volts rise at about the tacho volts per second (paper eq. 40 vs 39)
    gear = tacho * 2 * math.pi / cfg.pot_span_v
    return replace(cfg, tacho_v_per_rad_s=tacho, gear_ratio=gear)


def _lab_report() -> TrainerConfig:
    # Tsiolakis 2022 §1: km = 249.3 (rad/s per V), kT = 3.61e-3 V/(rad/s), km·kT = 0.9,
    # Tm = 0.55 s, kμ = 1/36, k0 = 0.25: position = k0 × output angle (span 2π·k0 per turn).
    base = TrainerConfig(amp_gain=1.0, amp_dead_zone_v=0.05, amp_rail_v=12.0, gear_ratio=1 / 36,
                         tacho_v_per_rad_s=3.61e-3, pot_span_v=2 * math.pi * 0.25)
    cfg = _motor_from_targets(base, dc_rad_s_per_v=249.3, tau_m_s=0.55, tau_e_s=0.002, ra_ohm=3.0)
    return replace(cfg, coulomb_nm=0.01 * cfg.k_motor, static_nm=0.015 * cfg.k_motor)


def _order(n: int) -> TrainerConfig:
    p = _paper()
    if n == 1:
        return replace(p, la_h=p.ra_ohm * 0.0005, amp_lead_s=0.0, amp_lag_s=0.0,
                       j_kgm2=p.j_kgm2 * 0.43 / 0.455)
    if n == 2:
        return replace(p, amp_lead_s=0.0, amp_lag_s=0.0, la_h=p.ra_ohm * 0.04,
                       j_kgm2=p.j_kgm2 * 0.39 / 0.455)
    return p


#: Names accepted by :func:`preset`.
PRESET_NAMES: tuple[str, ...] = ("paper", "lab-report", "first-order", "second-order", "third-order")


def preset(name: str) -> TrainerConfig:
    """The named trainer configuration.

    Parameters
    ----------
    name : str
        ``paper`` (Masoud 2019's trainer at 5.92 V), ``lab-report`` (Tsiolakis 2022),
        ``first-order`` (electrical pole negligible, no amplifier zero), ``second-order``
        (visible electrical pole, no amplifier zero), ``third-order`` (= ``paper``:
        electrical pole and amplifier lead/lag).

    Raises
    ------
    OptionError
        For an unknown name.
    """
    table = {
        "paper": _paper,
        "lab-report": _lab_report,
        "first-order": lambda: _order(1),
        "second-order": lambda: _order(2),
        "third-order": lambda: _order(3),
    }
    if name not in table:
        raise OptionError(f"unknown trainer preset {name!r}; use one of {', '.join(PRESET_NAMES)}")
    return table[name]()

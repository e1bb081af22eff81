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
from motorid.options import TRAINER_PRESETS

__all__ = ["PRESET_NAMES", "TrainerConfig", "preset"]


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
    pwm_spike_v, pwm_spike_rate_hz : float
        Switching spikes on the current monitor: peak volts and mean rate of occurrence.
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
    pwm_spike_v: float = 0.6
    pwm_spike_rate_hz: float = 3.0
    noise_v: float = 0.01
    substeps: int = 8

    def __post_init__(self) -> None:
        positive = {"ra_ohm": self.ra_ohm, "la_h": self.la_h, "k_motor": self.k_motor,
                    "j_kgm2": self.j_kgm2, "amp_gain": self.amp_gain, "pot_span_v": self.pot_span_v,
                    "gear_ratio": self.gear_ratio, "tacho_v_per_rad_s": self.tacho_v_per_rad_s}
        for key, value in positive.items():
            if not value > 0:
                raise OptionError(f"trainer config: {key} must be > 0, got {value!r}")
        non_negative = {"b_nms": self.b_nms, "coulomb_nm": self.coulomb_nm, "brake_nm": self.brake_nm,
                        "amp_dead_zone_v": self.amp_dead_zone_v, "amp_lead_s": self.amp_lead_s,
                        "amp_lag_s": self.amp_lag_s, "noise_v": self.noise_v,
                        "pwm_noise_v": self.pwm_noise_v, "pwm_spike_v": self.pwm_spike_v,
                        "tacho_ripple": self.tacho_ripple}
        for key, value in non_negative.items():
            if not value >= 0:
                raise OptionError(f"trainer config: {key} must be >= 0, got {value!r}")
        if self.static_nm < self.coulomb_nm:
            raise OptionError("trainer config: static_nm (break-away) must be >= coulomb_nm (sliding)")
        if self.amp_lead_s > 0 and self.amp_lag_s <= 0:
            raise OptionError("trainer config: an amplifier lead needs amp_lag_s > 0 (proper lead/lag)")
        if not 0 <= self.pot_glitch_max <= 3:
            raise OptionError(f"trainer config: pot_glitch_max must be 0..3, got {self.pot_glitch_max!r}")
        if self.substeps < 1 or self.tacho_segments < 1:
            raise OptionError("trainer config: substeps and tacho_segments must be >= 1")

    def ideal(self) -> TrainerConfig:
        """The linear plant: no dead-zone, friction nonlinearity, rails, ripple or noise.

        Returns
        -------
        TrainerConfig
            A copy with the nonlinearities and noise removed.
        """
        return replace(
            self, amp_dead_zone_v=0.0, amp_rail_v=1e9, coulomb_nm=0.0, static_nm=0.0,
            brake_nm=0.0, tacho_ripple=0.0, pot_glitch_max=0, pwm_noise_v=0.0, pwm_spike_v=0.0,
            noise_v=0.0,
        )

    def quiet(self) -> TrainerConfig:
        """The nonlinear plant without random noise, ripple or glitches.

        Returns
        -------
        TrainerConfig
            A copy without the random parts.
        """
        return replace(self, tacho_ripple=0.0, pot_glitch_max=0, pwm_noise_v=0.0, pwm_spike_v=0.0,
                       noise_v=0.0)


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


#: Mechanical time constant of the paper preset (chosen so that the velocity τ is ≈ 0.43 s).
TAU_M_PAPER_S = 0.442


def _paper() -> TrainerConfig:
    # 5.92 V step → tacho 5.36 V (DC gain 0.905), first-order τ ≈ 0.43 s: mechanical pole
    # plus a visible electrical pole (20 ms) plus the amplifier's lead/lag (zero 40 ms,
    # pole 18 ms).  Mean residence time of ω/V is τm + τe/2 (half of the damping is viscous,
    # see _motor_from_targets) + lag − lead = τm + 0.01 + 0.018 − 0.04: τm = 0.442 s gives 0.43 s.
    # Unity-gain amplifier on ±15 V rails: the lead's initial kick (×2.2 at 5.92 V = 13.2 V)
    # stays inside the rails, so the zero is visible in the step response.
    base = TrainerConfig(amp_gain=1.0, amp_rail_v=15.0, amp_lead_s=0.04, amp_lag_s=0.018)
    dc = 19.8  # rad/s per armature volt
    cfg = _motor_from_targets(base, dc_rad_s_per_v=dc, tau_m_s=TAU_M_PAPER_S, tau_e_s=0.02, ra_ohm=2.5)
    cfg = replace(cfg, coulomb_nm=0.02 * cfg.k_motor, static_nm=0.03 * cfg.k_motor)
    # the dead-zone and Coulomb friction cost part of the step: scale the tacho so that the
    # *measured* level at 5.92 V is the paper's 5.36 V (the linear DC gain is then ~0.917)
    offset = cfg.amp_dead_zone_v + cfg.ra_ohm * cfg.coulomb_nm / (cfg.k_motor * cfg.amp_gain)
    tacho = 0.905 * 5.92 / (5.92 - offset) / (cfg.amp_gain * dc)
    # position volts rise at about the tacho volts per second (paper eq. 40 vs 39)
    gear = tacho * 2 * math.pi / cfg.pot_span_v
    return replace(cfg, tacho_v_per_rad_s=tacho, gear_ratio=gear)


#: Lab-report constants (Tsiolakis 2022, eqs. 7, 8, 17, 18, 19).
LAB_K_M, LAB_K_T, LAB_T_M_S, LAB_K_MU, LAB_K_0 = 249.3, 3.61e-3, 0.55, 1.0 / 36.0, 0.25


def _lab_report() -> TrainerConfig:
    # Tsiolakis 2022 §1 measures speeds in rpm: km = 249.3 rpm/V (eq. 19), kT = 3.61e-3 V/rpm
    # (eq. 17), km·kT = 0.9 (eq. 5), Tm = 0.55 s (eq. 7), kμ = 1/36 (eq. 8) and
    # k0 = 0.25 V per (output rpm · s) (eq. 18): θ̇ = kμ·k0·ω (eq. 10), so one output turn is
    # 60·k0 = 15 V of potentiometer (the report's Δθ = 15 V, eq. 11).
    rpm = 2 * math.pi / 60.0  # rad/s per rpm
    base = TrainerConfig(amp_gain=1.0, amp_dead_zone_v=0.05, amp_rail_v=12.0, gear_ratio=LAB_K_MU,
                         tacho_v_per_rad_s=LAB_K_T / rpm, pot_span_v=60.0 * LAB_K_0)
    cfg = _motor_from_targets(base, dc_rad_s_per_v=LAB_K_M * rpm, tau_m_s=LAB_T_M_S, tau_e_s=0.002,
                              ra_ohm=3.0)
    return replace(cfg, coulomb_nm=0.01 * cfg.k_motor, static_nm=0.015 * cfg.k_motor)


def _electrical(tau_e: float) -> TrainerConfig:
    # same motor and sensors as ``paper`` with another electrical time constant and no amplifier
    # lead/lag; J (∝ τm) is rescaled so that the velocity's mean residence time τm + τe/2 stays
    # at the paper's 0.43 s
    p = _paper()
    return replace(p, la_h=p.ra_ohm * tau_e, amp_lead_s=0.0, amp_lag_s=0.0,
                   j_kgm2=p.j_kgm2 * (0.43 - tau_e / 2) / TAU_M_PAPER_S)


def _underdamped() -> TrainerConfig:
    # the paper's motor with La = 0.3·Ra and no amplifier lead/lag (J kept): its mechanical and
    # electrical poles meet as a complex pair, −2.23 ± 1.60j (damping 0.81)
    p = _paper()
    return replace(p, la_h=p.ra_ohm * 0.3, amp_lead_s=0.0, amp_lag_s=0.0)


#: Names accepted by :func:`preset` (declared with the options, which the command line's help reads).
PRESET_NAMES: tuple[str, ...] = TRAINER_PRESETS


def preset(name: str) -> TrainerConfig:
    """The named trainer configuration.

    Parameters
    ----------
    name : str
        ``paper`` (Masoud 2019's trainer at 5.92 V), ``lab-report`` (Tsiolakis 2022),
        ``first-order`` (electrical pole negligible, no amplifier zero), ``second-order``
        (visible electrical pole, 40 ms, no amplifier zero), ``third-order`` (= ``paper``:
        electrical pole and amplifier lead/lag), ``electrical-7ms`` (an electrical pole of
        7 ms, under two samples of the paper's record, no amplifier zero), ``underdamped``
        (a slow armature, La = 0.3·Ra: the two poles are a complex pair, damping 0.81).

    Returns
    -------
    TrainerConfig
        The configuration.

    Raises
    ------
    OptionError
        For an unknown name.
    """
    table = {
        "paper": _paper,
        "lab-report": _lab_report,
        "first-order": lambda: _electrical(0.0005),
        "second-order": lambda: _electrical(0.04),
        "third-order": _paper,
        "electrical-7ms": lambda: _electrical(0.007),
        "underdamped": _underdamped,
    }
    if name not in table:
        raise OptionError(f"unknown trainer preset {name!r}; use one of {', '.join(PRESET_NAMES)}")
    return table[name]()

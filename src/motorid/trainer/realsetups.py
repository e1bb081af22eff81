"""Virtual-trainer presets that reproduce three real set-ups from other labs.

The paper's trainer (:mod:`.presets`) never produces what real recordings showed; these
presets do, with the same nonlinear plant (:func:`~motorid.trainer.plant.simulate_plant`) and
written to disk exactly as the real set-up writes them:

``fast-tbs1000``
    A small fast motor (τ ≈ 16 ms) recorded on a Tektronix TBS1102 at 0.1–0.4 ms/pt, 2500
    points; CH1 = tachogenerator, CH2 = armature-current shunt, **no input channel**; the
    trigger is well before the step; the user passes ``--step-volts 12.28``.
``pwm-encoder``
    A PWM-driven gearmotor with a ~6 % PWM dead-zone, velocity derived from an encoder
    (1632 counts per output turn, differenced and held every 5 samples of a 1 kHz log:
    quantum 0.77 rad/s), logged as a plain CSV with the commanded volts.
``daq-deadtime``
    A 100 Hz DAQ rig like ``../shared/real/hslu-rtl-dcmotor``: a 35 ms dead time, a step
    5 → 15 V from a running speed, speed in rpm, the HSLU column layout.

What differs between real captures (trigger position and step instant, the sub-sample
step phase where the input is not recorded, noise, the encoder's update phase, the TBS1000's
horizontal scale) comes from the seed.  Where the input is logged (``pwm-encoder``,
``daq-deadtime``) it changes at the logged sample: a phase against a logged input could not be
told from a dead time, so no identification could recover it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType

import control
import numpy as np

from motorid.frozen import frozen_getstate, frozen_setstate
from motorid.capture import Capture, ChannelInfo, ScopeInfo
from motorid.errors import OptionError
from motorid.options import TRAINER_RIGS
from motorid.io._common import check_writable
from motorid.io.tektronix import write_tds_channel
from motorid.trainer.plant import PlantResponse, simulate_plant
from motorid.trainer.presets import TrainerConfig, _motor_from_targets
from motorid.trainer.scope import RECORD_LENGTH, quantise
from motorid.trainer.sensors import current_v, encoder_velocity, tacho_v
from motorid.trainer.truth import truth_of

__all__ = [
    "REAL_SETUPS",
    "SCOPE_AND_DAQ_SETUPS",
    "RealSetupRecording",
    "RealSetupTruth",
    "real_setup_config",
    "write_real_setup",
]

#: Names accepted by :func:`write_real_setup`: three scope and DAQ set-ups here, and the hobby and
#: classroom rigs of :mod:`motorid.trainer.hobbyrigs`.
REAL_SETUPS: tuple[str, ...] = TRAINER_RIGS
#: The scope and DAQ set-ups of this module (the rest are :mod:`motorid.trainer.hobbyrigs`').
SCOPE_AND_DAQ_SETUPS: tuple[str, ...] = REAL_SETUPS[:3]

#: fast-tbs1000: the supply level the user types as ``--step-volts``.
FAST_STEP_V = 12.28
#: fast-tbs1000: TBS1000 horizontal scales giving 0.1, 0.2 and 0.4 ms per point.
FAST_SEC_PER_DIV = (0.025, 0.05, 0.1)
#: pwm-encoder: supply, dead-zone (6 % of the supply), step, log interval, encoder.
PWM_SUPPLY_V, PWM_DEAD_ZONE_V, PWM_STEP_V, PWM_DT_S = 12.0, 0.72, 9.0, 1e-3
PWM_COUNTS_PER_REV, PWM_EVERY = 1632, 5  # 48 CPR × 34:1 gearbox; 2π/(1632·5 ms) = 0.770 rad/s
#: daq-deadtime: sample interval, dead time, voltage levels, record (as the HSLU files).
DAQ_DT_S, DAQ_DEAD_TIME_S, DAQ_FROM_V, DAQ_TO_V, DAQ_SAMPLES = 0.01, 0.035, 5.0, 15.0, 1221
#: daq-deadtime: HSLU position_raw units per motor turn and its wrap (read off their files).
DAQ_POSITION_PER_REV, DAQ_POSITION_WRAP = 7.22, 230.16
RPM_PER_RAD_S = 60.0 / (2 * math.pi)


@dataclass(frozen=True, slots=True)
class RealSetupTruth:
    """What a perfect identification of one recording would report.

    Attributes
    ----------
    dc_gain : float
        Incremental gain the step shows, output units per input volt: the linear DC gain
        times ``1 − offset/step`` for a step from rest (the dead-zone and Coulomb friction
        cost a fixed part of it, as in the demo), the linear DC gain for a step between two
        running speeds (the offset cancels).
    time_constant_s : float
        Mean residence time of the linear velocity TF by moments, ``Σ1/p − Σ1/z``.
    delay_s : float
        Pure lag between the input and the recorded velocity: ``dead_time_s`` plus
        ``sensor_lag_s``.
    residence_time_s : float
        ``time_constant_s + delay_s``: the first moment of the recorded step response.
    step_volts : float
        Step size (the increment for a step from a running point).
    velocity_tf : control.TransferFunction
        Linearised input volts → recorded velocity units, without the delay.
    dead_time_s : float
        The input's delay before the plant.
    sensor_lag_s : float
        Mean lag the velocity measurement adds (encoder window and hold), 0 for a tacho.
    from_volts : float
        Input level before the step.
    step_time_s : float
        Instant the input changes, on the file's own time axis.
    output_units : str
        Units of the velocity channel (``V``, ``rad/s``, ``rpm``).
    """

    dc_gain: float
    time_constant_s: float
    delay_s: float
    residence_time_s: float
    step_volts: float
    velocity_tf: control.TransferFunction
    dead_time_s: float
    sensor_lag_s: float
    from_volts: float
    step_time_s: float
    output_units: str


@dataclass(frozen=True, slots=True)
class RealSetupRecording:
    """Files of one simulated real set-up and how a user identifies them.

    Attributes
    ----------
    name : str
        One of :data:`REAL_SETUPS`.
    files : Mapping[str, Path]
        Role → file (``velocity``, ``current`` for the scope pair; ``log`` for a CSV log).
    cli_args : tuple of str
        ``motorid identify`` arguments with default options only.
    truth : RealSetupTruth
    config : TrainerConfig
        The simulated plant.
    seed : int
    sample_interval_s : float
        Δt of the files.
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    name: str
    files: Mapping[str, Path]
    cli_args: tuple[str, ...]
    truth: RealSetupTruth
    config: TrainerConfig
    seed: int
    sample_interval_s: float

    def read_captures(self) -> dict[str, Capture]:
        """The captures a user names in :attr:`cli_args` (``--velocity X --current Y``).

        Read back with :func:`motorid.io.read_capture`, keyed by role.

        Returns
        -------
        dict of str to Capture
            The captures by role.
        """
        from motorid.io import read_capture

        args = list(self.cli_args)
        return {flag[2:]: read_capture(args[i + 1], role=flag[2:]) for i, flag in enumerate(args)
                if flag in ("--position", "--velocity", "--current")}

    @property
    def step_volts(self) -> float | None:
        """The ``--step-volts`` a user gives (set-ups without an input channel), else None."""
        args = list(self.cli_args)
        return float(args[args.index("--step-volts") + 1]) if "--step-volts" in args else None


def _fast_tbs1000() -> TrainerConfig:
    # a small motor (6000 rpm at 12 V: 52 rad/s/V) on a bench supply switched on: no
    # amplifier dead-zone or PWM; tacho 3.8 mV/(rad/s) gives the ≈ 2.4 V the CH1 shows;
    # τm 16 ms and τe 0.3 ms put the mean residence time at ≈ 16 ms (τ ≈ 13–21 ms)
    base = TrainerConfig(amp_gain=1.0, amp_dead_zone_v=0.0, amp_rail_v=30.0, tacho_ripple=0.015,
                         tacho_segments=5, tacho_v_per_rad_s=3.8e-3, current_v_per_a=0.5,
                         pwm_noise_v=0.0, pwm_spike_v=0.0, noise_v=0.004, pot_glitch_max=0, substeps=1)
    cfg = _motor_from_targets(base, dc_rad_s_per_v=52.0, tau_m_s=0.016, tau_e_s=0.0003, ra_ohm=4.0)
    return replace(cfg, coulomb_nm=0.01 * cfg.k_motor, static_nm=0.015 * cfg.k_motor)


def _pwm_encoder() -> TrainerConfig:
    # a 34:1 gearmotor (2.5 output rad/s per volt, 85 at the motor) behind an H-bridge whose
    # PWM dead-zone is 6 % of the 12 V supply; gearbox friction; the "tacho" gain is the gear
    # ratio so that the truth TF is in output-shaft rad/s per volt (what the encoder sees)
    gear = 1.0 / 34.0
    base = TrainerConfig(amp_gain=1.0, amp_dead_zone_v=PWM_DEAD_ZONE_V, amp_rail_v=PWM_SUPPLY_V,
                         gear_ratio=gear, tacho_v_per_rad_s=gear, tacho_ripple=0.0, pwm_noise_v=0.0,
                         pwm_spike_v=0.0, noise_v=0.0, pot_glitch_max=0, substeps=1)
    cfg = _motor_from_targets(base, dc_rad_s_per_v=2.5 / gear, tau_m_s=0.06, tau_e_s=0.001, ra_ohm=2.5)
    return replace(cfg, coulomb_nm=0.05 * cfg.k_motor, static_nm=0.08 * cfg.k_motor)


def _daq_deadtime() -> TrainerConfig:
    # the HSLU rig: 245.5 rpm/V incremental gain (authors' Kg); the running speed at 5 V
    # (≈ 1066 rpm, not 5·245.5) says ≈ 0.65 V of the input goes to friction; a power-amplifier
    # lag of 60 ms and τm 0.235 s give a mean residence time ≈ 0.30 s, + 35 ms dead time ≈
    # the authors' PT2 + Td (2·0.147 + 0.035 s)
    dc = 245.5 / RPM_PER_RAD_S
    base = TrainerConfig(amp_gain=1.0, amp_dead_zone_v=0.0, amp_rail_v=24.0, amp_lag_s=0.06,
                         tacho_v_per_rad_s=RPM_PER_RAD_S, tacho_ripple=0.0, pwm_noise_v=0.0,
                         pwm_spike_v=0.0, noise_v=0.3, pot_glitch_max=0, substeps=1)
    cfg = _motor_from_targets(base, dc_rad_s_per_v=dc, tau_m_s=0.235, tau_e_s=0.002, ra_ohm=2.0)
    coulomb = 0.65 * cfg.k_motor / cfg.ra_ohm
    return replace(cfg, coulomb_nm=coulomb, static_nm=1.2 * coulomb)


def real_setup_config(name: str) -> TrainerConfig:
    """The simulated plant of a real set-up.

    Parameters
    ----------
    name : str
        One of :data:`REAL_SETUPS`.

    Returns
    -------
    TrainerConfig

    Raises
    ------
    OptionError
        For an unknown name.
    """
    table = {"fast-tbs1000": _fast_tbs1000, "pwm-encoder": _pwm_encoder, "daq-deadtime": _daq_deadtime}
    if name not in REAL_SETUPS:
        raise OptionError(f"unknown real set-up {name!r}; use one of {', '.join(REAL_SETUPS)}")
    if name not in SCOPE_AND_DAQ_SETUPS:
        from motorid.trainer.hobbyrigs import hobby_rig_config

        return hobby_rig_config(name)
    return table[name]()


def _simulate_step(
    config: TrainerConfig,
    time_s: np.ndarray,
    *,
    step_index: int,
    phase_steps: int,
    oversample: int,
    from_v: float,
    to_v: float,
    dead_time_s: float = 0.0,
    lead_in_s: float = 0.0,
) -> tuple[PlantResponse, float]:
    """Simulate a step on a grid ``oversample`` times finer than the record and sample it.

    The input changes ``phase_steps`` fine steps before ``time_s[step_index]`` (a sub-sample
    step phase that the plant really sees) and reaches the plant ``dead_time_s`` later (dead
    time = the input delayed before the plant, rounded to the fine grid).  ``lead_in_s`` of
    ``from_v`` before the record starts brings a motor started at rest to its running point.

    Returns
    -------
    (PlantResponse, float)
        The plant at ``time_s`` and the exact step instant on that axis.
    """
    dt = float(time_s[1] - time_s[0])
    h = dt / oversample
    n_lead = round(lead_in_s / h)
    k = np.arange(-n_lead, time_s.size * oversample)
    t_fine = time_s[0] + k * h
    step_fine = step_index * oversample - phase_steps  # fine index of the input change
    delay_fine = round(dead_time_s / h)
    u = np.where(k >= step_fine + delay_fine, to_v, from_v)
    full = simulate_plant(config, t_fine, u, substeps=1)
    idx = n_lead + np.arange(time_s.size) * oversample
    plant = PlantResponse(time_s, *(np.asarray(a)[idx] for a in (
        full.amp_out_v, full.current_a, full.motor_speed_rad_s, full.motor_angle_rad, full.output_angle_rad)))
    return plant, float(time_s[0] + step_fine * h)


def _truth(config: TrainerConfig, *, from_v: float, to_v: float, dead_time_s: float, sensor_lag_s: float,
           step_time_s: float, units: str) -> RealSetupTruth:
    lin = truth_of(config)
    dc = lin.dc_gain
    if from_v == 0.0:
        # from rest: the dead-zone and sliding friction cost a fixed part of the step
        dc *= 1.0 - lin.equivalent_input_offset_v / abs(to_v)
    delay = dead_time_s + sensor_lag_s
    return RealSetupTruth(
        dc_gain=float(dc), time_constant_s=lin.time_constant_s, delay_s=delay,
        residence_time_s=lin.time_constant_s + delay, step_volts=float(to_v - from_v),
        velocity_tf=lin.velocity, dead_time_s=dead_time_s, sensor_lag_s=sensor_lag_s,
        from_volts=float(from_v), step_time_s=step_time_s, output_units=units,
    )


def _write_fast_tbs1000(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, seed: int,
                        force: bool) -> tuple[dict[str, Path], tuple[str, ...], RealSetupTruth, float]:
    # the horizontal scale cycles with the seed so that any three seeds cover 0.1, 0.2, 0.4 ms/pt
    sec_per_div = FAST_SEC_PER_DIV[seed % len(FAST_SEC_PER_DIV)]
    dt = 10.0 * sec_per_div / RECORD_LENGTH
    # the trigger (t = 0) at 5–15 % of the record, the step 10–30 % of the record after it
    trig = int(rng.integers(int(0.05 * RECORD_LENGTH), int(0.15 * RECORD_LENGTH) + 1))
    step_index = trig + int(rng.integers(int(0.10 * RECORD_LENGTH), int(0.30 * RECORD_LENGTH) + 1))
    oversample = 8
    t = (np.arange(RECORD_LENGTH) - trig) * dt
    plant, step_t = _simulate_step(cfg, t, step_index=step_index, phase_steps=int(rng.integers(oversample)),
                                   oversample=oversample, from_v=0.0, to_v=FAST_STEP_V)
    tacho_rng, current_rng = rng.spawn(2)
    scope = ScopeInfo(model="TBS 1102", serial="C010234", firmware="FV:v4.06", record_length=RECORD_LENGTH,
                      horizontal_scale_s=sec_per_div, trigger_index=trig)
    out = folder / "ALL0000"
    paths = {"velocity": out / "F0000CH1.CSV", "current": out / "F0000CH2.CSV"}
    check_writable(list(paths.values()), force=force)
    ch1, ch2 = ChannelInfo("CH1", "V", 1.0, 0.0, 1.0, 0.0), ChannelInfo("CH2", "V", 0.5, 0.0, 1.0, 0.0)
    write_tds_channel(paths["velocity"], t, quantise(tacho_v(cfg, plant, tacho_rng), 1.0), ch1, scope, force=True)
    write_tds_channel(paths["current"], t, quantise(current_v(cfg, plant, current_rng), 0.5), ch2, scope,
                      force=True)
    args = ("--velocity", str(paths["velocity"]), "--current", str(paths["current"]),
            "--step-volts", f"{FAST_STEP_V}")
    truth = _truth(cfg, from_v=0.0, to_v=FAST_STEP_V, dead_time_s=0.0, sensor_lag_s=0.0, step_time_s=step_t,
                   units="V")
    return paths, args, truth, dt


def _write_csv(path: Path, header: str, columns: list[np.ndarray], formats: list[str]) -> None:
    lines = [header]
    for row in zip(*columns, strict=False):
        lines.append(",".join(format(v, f) if f else repr(float(v)) for v, f in zip(row, formats, strict=False)))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(lines) + "\n", encoding="ascii")
    except OSError as exc:
        raise OptionError(f"cannot write the file ({exc.strerror or exc})", file=str(path)) from exc


def _write_pwm_encoder(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, seed: int,
                       force: bool) -> tuple[dict[str, Path], tuple[str, ...], RealSetupTruth, float]:
    n = 1500
    t = np.arange(n) * PWM_DT_S
    step_index = int(rng.integers(250, 501))
    oversample = 10
    # the firmware sets the PWM and logs the command in the same loop pass: the step is at the
    # logged sample (a sub-sample phase against a logged input would be unidentifiable)
    plant, step_t = _simulate_step(cfg, t, step_index=step_index, phase_steps=0,
                                   oversample=oversample, from_v=0.0, to_v=PWM_STEP_V)
    omega = encoder_velocity(plant.output_angle_rad, PWM_DT_S, counts_per_rev=PWM_COUNTS_PER_REV,
                             every=PWM_EVERY, phase=int(rng.integers(PWM_EVERY)))
    u = np.where(np.arange(n) >= step_index, PWM_STEP_V, 0.0)  # the commanded volts (duty × supply)
    path = folder / "pwm_encoder_log.csv"
    check_writable([path], force=force)
    # an Arduino log: millis, the commanded volts, the firmware's velocity
    _write_csv(path, "t_ms,u_V,omega_rad_s", [np.round(t * 1e3), u, omega], [".0f", ".2f", ".4f"])
    lag = (2 * PWM_EVERY - 1) * PWM_DT_S / 2  # encoder window T/2 + hold (every − 1)·Δt/2, see encoder_velocity
    truth = _truth(cfg, from_v=0.0, to_v=PWM_STEP_V, dead_time_s=0.0, sensor_lag_s=lag, step_time_s=step_t,
                   units="rad/s")
    return {"log": path}, ("--velocity", str(path)), truth, PWM_DT_S


def _write_daq_deadtime(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, seed: int,
                        force: bool) -> tuple[dict[str, Path], tuple[str, ...], RealSetupTruth, float]:
    t = (np.arange(DAQ_SAMPLES) + 1) * DAQ_DT_S
    step_index = int(rng.integers(275, 401))  # the HSLU steps are at index 323 and 374
    oversample = 20
    # output and input share the DAQ's clock: the logged voltage is applied from its sample on
    # (a random sub-sample phase would be inseparable from the dead time); the 35 ms dead
    # time (3.5 samples) puts the response's onset between samples
    plant, step_t = _simulate_step(cfg, t, step_index=step_index, phase_steps=0,
                                   oversample=oversample, from_v=DAQ_FROM_V, to_v=DAQ_TO_V,
                                   dead_time_s=DAQ_DEAD_TIME_S, lead_in_s=3.0)
    speed = tacho_v(cfg, plant, rng)
    u = np.where(np.arange(DAQ_SAMPLES) >= step_index, DAQ_TO_V, DAQ_FROM_V)
    position = np.mod(plant.motor_angle_rad / (2 * math.pi) * DAQ_POSITION_PER_REV, DAQ_POSITION_WRAP)
    zeros = np.zeros(DAQ_SAMPLES)
    path = folder / "daq_step_5_15.csv"
    check_writable([path], force=force)
    _write_csv(path, "time_s,motor_voltage_V,speed_rpm,speed_setpoint_rpm,position_raw,position_setpoint_raw",
               [t, u, speed, zeros, position, zeros], ["", "", "", "", "", ""])
    truth = _truth(cfg, from_v=DAQ_FROM_V, to_v=DAQ_TO_V, dead_time_s=DAQ_DEAD_TIME_S, sensor_lag_s=0.0,
                   step_time_s=step_t, units="rpm")
    return {"log": path}, ("--velocity", str(path)), truth, DAQ_DT_S


def write_real_setup(name: str, folder: Path, *, seed: int = 0, force: bool = False) -> RealSetupRecording:
    """Record one real set-up on the virtual trainer and write its files as that set-up does.

    Parameters
    ----------
    name : str
        One of :data:`REAL_SETUPS`.
    folder : Path
        Where the files go (created): ``ALL0000/F0000CH1.CSV`` (tacho) + ``F0000CH2.CSV``
        (current shunt) for ``fast-tbs1000``, one plain CSV for the others.
    seed : int
        Draws trigger position, step instant (and its sub-sample phase for the scope
        capture, which has no input channel), noise and the encoder's
        update phase; the TBS1000's horizontal scale is 0.1, 0.2, 0.4 ms/pt for seed mod 3 =
        0, 1, 2.  The same seed writes the same files.
    force : bool
        Overwrite existing files.

    Returns
    -------
    RealSetupRecording
        Files, the ``motorid identify`` arguments with default options, and the truth.

    Raises
    ------
    OptionError
        For an unknown name or a folder that cannot be written.
    OutputExistsError
        A file exists and ``force`` is false.
    """
    cfg = real_setup_config(name)
    rng = np.random.default_rng(seed)
    if name not in SCOPE_AND_DAQ_SETUPS:
        from motorid.trainer.hobbyrigs import write_hobby_rig

        files, args, truth, dt = write_hobby_rig(name, Path(folder), rng, force)
    else:
        writer = {"fast-tbs1000": _write_fast_tbs1000, "pwm-encoder": _write_pwm_encoder,
                  "daq-deadtime": _write_daq_deadtime}[name]
        files, args, truth, dt = writer(Path(folder), cfg, rng, int(seed), force)
    return RealSetupRecording(name=name, files=MappingProxyType(files), cli_args=tuple(args), truth=truth,
                              config=cfg, seed=int(seed), sample_interval_s=dt)

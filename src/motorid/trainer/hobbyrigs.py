"""Virtual-trainer presets that record as hobby and classroom rigs do (beside :mod:`.realsetups`).

Logs that no scope wrote: an Arduino or a PC loop stamps the samples with its own clock, logs
what it commanded, and counts encoder edges.  Each preset runs the trainer's nonlinear plant and
writes the file the rig writes:

``l298n-rpm``
    An L298N H-bridge (its ~1.4 V drop acts as a dead-zone) driving a gearmotor, a 30 ms
    firmware dead time, ``time,voltage,rpm`` at 100 Hz (rpm from encoder counts per 10 ms).
``arduino-millis``
    A 10.24 ms Arduino loop stamped with ``millis()`` (whole ms: steps of 10 and 11), the
    commanded volts and an encoder speed in rad/s.
``host-loop``
    A LEGO EV3 motor logged by a Python loop on a PC: stamps in seconds 4–22 ms apart, the
    commanded volts, the position in whole degrees (no speed column).
``encoder-counts``
    A micromouse encoder: counts every 5 ms, no input column, the log starting a sample before
    the step (the user gives ``--step-volts``).
``staircase``
    One log whose input steps 0 → 2 → 4 → 6 → 8 V, 3 s a level (tacho volts at 100 Hz); the user
    identifies one step with ``--segment 2`` (2 → 4 V, between two moving levels).
``ms-time``
    A log whose time column is whole milliseconds named plain ``time``.
``serial-plotter``
    An Arduino sketch printing ``t:…,pwm_V:…,rpm:…`` for the Serial Plotter (``millis()/1000.0``
    stamps of a 10.24 ms loop), saved from the serial monitor, its last line cut when the
    capture was stopped.
``picoscope``
    A PicoScope CSV export: ``Time,Channel A,Channel B`` over a units line ``(ms),(V),(V)`` and a
    blank line, the step on A and a tacho on B (8-bit codes of the ±5 V and ±2 V ranges); the
    user names the channels with ``--columns``.
``clock-stamps``
    A Raspberry Pi loop stamping each row with the wall clock (``2026-03-02 14:03:11.123456``),
    about 20 ms apart with scheduler jitter, the commanded volts and an rpm.
``no-header``
    An Arduino sketch printing ``millis(),volts,rpm`` and nothing else: no header row, the
    ``millis()`` stamps of a 10.24 ms loop; the user names the columns by position with
    ``--columns time=1,input=2,velocity=3`` and their unit with ``--units velocity=rpm``.
``arduino-pwm``
    An Arduino driving the motor with ``analogWrite`` (duty 0–255 of a 12 V supply) and logging
    ``t_ms,pwm,rpm`` every 10 ms: the input is the duty in counts, not volts, so the gain is rpm
    per count and every command (rails, dead-zone, peak) is in ``pwm``.

The truth of each is that of :func:`motorid.trainer.realsetups.write_real_setup`: the
incremental gain the identified step shows, the mean residence time (τ + dead time + sensor lag).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from motorid.errors import OptionError
from motorid.io._common import check_writable
from motorid.trainer.plant import simulate_plant
from motorid.trainer.presets import TrainerConfig, _motor_from_targets
from motorid.trainer.realsetups import RPM_PER_RAD_S, RealSetupTruth, _truth, _write_csv

__all__ = ["COUNTED_SPEED_RIGS", "HOBBY_RIGS", "hobby_rig_config", "write_hobby_rig"]

#: The presets of this module.
HOBBY_RIGS: tuple[str, ...] = ("l298n-rpm", "arduino-millis", "host-loop", "encoder-counts", "staircase", "ms-time",
                               "serial-plotter", "picoscope", "clock-stamps", "no-header", "arduino-pwm")
#: The presets whose speed column counts encoder edges over each logged interval (the mean speed
#: since the last line; ``--counted-velocity`` describes it): their truth's ``sensor_lag_s`` is
#: half that interval.
COUNTED_SPEED_RIGS: tuple[str, ...] = ("l298n-rpm", "arduino-millis", "ms-time", "serial-plotter", "clock-stamps",
                                       "no-header", "arduino-pwm")
#: The fine grid the plant runs on before the rig samples it (s).
FINE_S = 1e-4
#: L298N rig: supply step, the bridge's drop, the firmware's dead time, encoder counts per output turn.
L298N_STEP_V, L298N_DROP_V, L298N_DEAD_TIME_S, L298N_COUNTS = 6.0, 1.4, 0.03, 700
#: Arduino loop period (``millis()`` reports it in whole ms: 10 or 11).
ARDUINO_LOOP_S = 0.01024
#: EV3: degrees per output turn are 360; its loop steps 4–22 ms.
EV3_DT_RANGE_S = (0.004, 0.022)
#: Micromouse: counts per wheel turn and the log interval.
MOUSE_COUNTS, MOUSE_DT_S, MOUSE_STEP_V = 1440, 0.005, 6.0
#: Arduino PWM rig: the supply, the duty's full scale, the duty stepped to, the loop, encoder edges a turn.
PWM_SUPPLY_V, PWM_FULL, PWM_DUTY, PWM_LOOP_S, PWM_COUNTS = 12.0, 255, 153, 0.01, 900
#: Staircase: the levels and the time per level.
STAIR_LEVELS_V, STAIR_LEVEL_S = (0.0, 2.0, 4.0, 6.0, 8.0), 3.0

Writer = tuple[dict[str, Path], tuple[str, ...], RealSetupTruth, float]


def _gearmotor(dead_zone_v: float, *, tau_m: float, dc: float, noise: float = 0.0) -> TrainerConfig:
    base = TrainerConfig(amp_gain=1.0, amp_dead_zone_v=dead_zone_v, amp_rail_v=12.0, tacho_v_per_rad_s=1.0,
                         tacho_ripple=0.0, pwm_noise_v=0.0, pwm_spike_v=0.0, noise_v=noise, pot_glitch_max=0,
                         substeps=1)
    cfg = _motor_from_targets(base, dc_rad_s_per_v=dc, tau_m_s=tau_m, tau_e_s=0.001, ra_ohm=3.0)
    return replace(cfg, coulomb_nm=0.02 * cfg.k_motor, static_nm=0.03 * cfg.k_motor)


def hobby_rig_config(name: str) -> TrainerConfig:
    """The simulated plant of a hobby rig (see the module's list).

    Parameters
    ----------
    name : str
        One of :data:`HOBBY_RIGS`.

    Returns
    -------
    TrainerConfig
    """
    if name == "l298n-rpm":
        return _gearmotor(L298N_DROP_V, tau_m=0.08, dc=25.0)
    if name in ("arduino-millis", "ms-time", "serial-plotter", "no-header", "arduino-pwm"):
        return _gearmotor(0.3, tau_m=0.06, dc=20.0)
    if name == "picoscope":
        return replace(_gearmotor(0.2, tau_m=0.05, dc=30.0, noise=0.004), tacho_v_per_rad_s=0.01)
    if name == "clock-stamps":
        return _gearmotor(0.4, tau_m=0.12, dc=18.0)
    if name == "host-loop":
        return _gearmotor(0.2, tau_m=0.1, dc=15.0)
    if name == "encoder-counts":
        return _gearmotor(0.1, tau_m=0.05, dc=30.0)
    return replace(_gearmotor(0.5, tau_m=0.2, dc=10.0, noise=0.005), tacho_v_per_rad_s=0.05)  # staircase: tacho volts


def _run(cfg: TrainerConfig, times: np.ndarray, u_of_t: Callable[[np.ndarray], np.ndarray]) -> dict[str, np.ndarray]:
    """The plant on a fine grid from 1 s before the first sample, sampled at ``times`` (any instants)."""
    t_fine = np.arange(times[0] - 1.0, times[-1] + 2 * FINE_S, FINE_S)
    full = simulate_plant(cfg, t_fine, u_of_t(t_fine), substeps=1)
    return {k: np.interp(times, t_fine, np.asarray(getattr(full, k)))
            for k in ("motor_speed_rad_s", "motor_angle_rad", "output_angle_rad")}


def _step(t_step: float, from_v: float, to_v: float, dead_time_s: float = 0.0) -> Callable[[np.ndarray], np.ndarray]:
    return lambda t: np.where(t >= t_step + dead_time_s - 1e-12, to_v, from_v)


def _write_l298n(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool) -> Writer:
    dt = 0.01
    n = 400
    t = np.arange(n) * dt
    k = int(rng.integers(80, 121))
    s = _run(cfg, t, _step(t[k], 0.0, L298N_STEP_V, L298N_DEAD_TIME_S))
    # rpm from the encoder edges counted over each 10 ms loop: a moving average of one interval
    counts = np.floor(s["motor_angle_rad"] / (2 * math.pi) * L298N_COUNTS + rng.uniform())
    rpm = np.r_[0.0, np.diff(counts)] / L298N_COUNTS / dt * 60.0
    u = np.where(np.arange(n) >= k, L298N_STEP_V, 0.0)
    path = folder / "l298n_log.csv"
    check_writable([path], force=force)
    _write_csv(path, "time,voltage,rpm", [t, u, rpm], [".2f", ".1f", ".1f"])
    truth = _truth(cfg, from_v=0.0, to_v=L298N_STEP_V, dead_time_s=L298N_DEAD_TIME_S, sensor_lag_s=dt / 2,
                   step_time_s=float(t[k]), units="rpm")
    return {"log": path}, ("--velocity", str(path)), _scaled(truth, RPM_PER_RAD_S), dt


def _scaled(truth: RealSetupTruth, factor: float) -> RealSetupTruth:
    """The truth of a sensor reading ``factor`` × the output shaft's rad/s (rpm: 60/2π)."""
    return replace(truth, dc_gain=truth.dc_gain * factor, velocity_tf=truth.velocity_tf * factor)


def _write_arduino(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool, *,
                   name: str) -> Writer:
    n = 300
    start = float(rng.uniform(1.0, 5.0))
    true_t = start + np.arange(n) * ARDUINO_LOOP_S  # when the loop really ran
    stamps = np.floor(true_t * 1e3).astype(int)  # what millis() says
    k = int(rng.integers(60, 91))
    s = _run(cfg, true_t, _step(true_t[k], 0.0, 6.0))
    omega = s["motor_angle_rad"]
    counts = np.floor(omega / (2 * math.pi) * 1200 + rng.uniform())
    speed = np.r_[0.0, np.diff(counts)] / 1200 * 2 * math.pi / ARDUINO_LOOP_S
    u = np.where(np.arange(n) >= k, 6.0, 0.0)
    path = folder / ("arduino_log.csv" if name == "arduino-millis" else "ms_log.csv")
    check_writable([path], force=force)
    header = "millis,u_V,omega_rad_s" if name == "arduino-millis" else "time,voltage,speed"
    if name == "ms-time":  # a steady 10 ms loop stamped in whole ms under a plain "time" header
        stamps = (1000 + 10 * np.arange(n)).astype(int)
        true_t = stamps / 1e3
        s = _run(cfg, true_t, _step(true_t[k], 0.0, 6.0))
        counts = np.floor(s["motor_angle_rad"] / (2 * math.pi) * 1200 + rng.uniform())
        speed = np.r_[0.0, np.diff(counts)] / 1200 * 2 * math.pi / 0.01
    _write_csv(path, header, [stamps, u, speed], [".0f", ".1f", ".3f"])
    loop = ARDUINO_LOOP_S if name == "arduino-millis" else 0.01
    truth = _truth(cfg, from_v=0.0, to_v=6.0, dead_time_s=0.0, sensor_lag_s=loop / 2, step_time_s=float(true_t[k]),
                   units="rad/s")
    return {"log": path}, ("--velocity", str(path)), truth, loop


def _write_host_loop(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool) -> Writer:
    n = 300
    t = 10.0 + np.r_[0.0, np.cumsum(rng.uniform(*EV3_DT_RANGE_S, n - 1))]
    k = int(rng.integers(50, 81))
    s = _run(cfg, t, _step(t[k], 0.0, 6.0))
    degrees = np.floor(np.degrees(s["motor_angle_rad"]) + rng.uniform())
    u = np.where(np.arange(n) >= k, 6.0, 0.0)
    path = folder / "ev3_log.csv"
    check_writable([path], force=force)
    _write_csv(path, "time_s,voltage,position_deg", [t, u, degrees], [".4f", ".1f", ".0f"])
    truth = _truth(cfg, from_v=0.0, to_v=6.0, dead_time_s=0.0, sensor_lag_s=0.0, step_time_s=float(t[k]),
                   units="deg")
    return {"log": path}, ("--position", str(path)), _scaled(truth, 180.0 / math.pi), float(np.mean(np.diff(t)))


def _write_encoder_counts(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool) -> Writer:
    n = 400
    t = np.arange(n) * MOUSE_DT_S
    t_step = float(rng.uniform(0.0, MOUSE_DT_S))  # the motor is switched on just after the first sample
    s = _run(cfg, t, _step(t_step, 0.0, MOUSE_STEP_V))
    counts = np.floor(s["motor_angle_rad"] / (2 * math.pi) * MOUSE_COUNTS)
    path = folder / "mouse_log.csv"
    check_writable([path], force=force)
    _write_csv(path, "time_s,encoder_counts", [t, counts], [".3f", ".0f"])
    truth = _truth(cfg, from_v=0.0, to_v=MOUSE_STEP_V, dead_time_s=0.0, sensor_lag_s=0.0, step_time_s=t_step,
                   units="counts")
    args = ("--position", str(path), "--step-volts", f"{MOUSE_STEP_V:g}")
    return {"log": path}, args, _scaled(truth, MOUSE_COUNTS / (2 * math.pi)), MOUSE_DT_S


def _write_staircase(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool) -> Writer:
    dt = 0.01
    per = round(STAIR_LEVEL_S / dt)
    u = np.repeat(STAIR_LEVELS_V, per)
    t = np.arange(u.size) * dt
    s = _run(cfg, t, lambda tt: np.asarray(STAIR_LEVELS_V)[np.clip((tt // STAIR_LEVEL_S).astype(int), 0,
                                                                   len(STAIR_LEVELS_V) - 1)] * (tt >= 0))
    tacho = cfg.tacho_v_per_rad_s * s["motor_speed_rad_s"] + rng.normal(0.0, cfg.noise_v, t.size)
    path = folder / "staircase_log.csv"
    check_writable([path], force=force)
    _write_csv(path, "time_s,voltage,tacho_V", [t, u, tacho], [".2f", ".1f", ".5f"])
    # --segment 2: the step 2 → 4 V, between two levels that move the motor: the linear gain
    truth = _truth(cfg, from_v=STAIR_LEVELS_V[1], to_v=STAIR_LEVELS_V[2], dead_time_s=0.0, sensor_lag_s=0.0,
                   step_time_s=2 * STAIR_LEVEL_S, units="V")
    return {"log": path}, ("--velocity", str(path), "--segment", "2"), truth, dt


def _sketch_rpm(cfg: TrainerConfig, rng: np.random.Generator
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, RealSetupTruth]:
    """A 10.24 ms Arduino loop stepping 0 → 6 V and counting 1200 edges a turn (the sketches that print rpm).

    Returns the ``millis()`` stamps (whole ms), the commanded volts, the rpm counted over each
    loop and the truth (in rpm).
    """
    n = 300
    true_t = float(rng.uniform(1.0, 5.0)) + np.arange(n) * ARDUINO_LOOP_S
    stamps = np.floor(true_t * 1e3)  # millis()
    k = int(rng.integers(60, 91))
    s = _run(cfg, true_t, _step(true_t[k], 0.0, 6.0))
    counts = np.floor(s["motor_angle_rad"] / (2 * math.pi) * 1200 + rng.uniform())
    rpm = np.r_[0.0, np.diff(counts)] / 1200 / ARDUINO_LOOP_S * 60.0
    u = np.where(np.arange(n) >= k, 6.0, 0.0)
    truth = _truth(cfg, from_v=0.0, to_v=6.0, dead_time_s=0.0, sensor_lag_s=ARDUINO_LOOP_S / 2,
                   step_time_s=float(true_t[k]), units="rpm")
    return stamps, u, rpm, _scaled(truth, RPM_PER_RAD_S)


def _write_serial_plotter(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool) -> Writer:
    millis, u, rpm, truth = _sketch_rpm(cfg, rng)
    stamps = millis / 1e3  # millis() / 1000.0
    lines = [f"t:{a:.3f},pwm_V:{b:.1f},rpm:{c:.1f}" for a, b, c in zip(stamps, u, rpm, strict=True)]
    last = f"t:{stamps[-1] + 0.010:.3f},pwm_V:6.0,rp"  # the serial monitor stopped mid-line
    path = folder / "serial_plotter.txt"
    check_writable([path], force=force)
    _write_text(path, "\n".join([*lines, last]) + "\n")
    return {"log": path}, ("--velocity", str(path)), truth, ARDUINO_LOOP_S


def _write_arduino_pwm(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool) -> Writer:
    """``t_ms,pwm,rpm``: the duty stepped 0 → 153 of 255 on a 12 V supply, rpm counted over each 10 ms loop.

    The motor sees the duty's mean voltage (the PWM's frequency is far above its electrical pole);
    the truth's gain is in rpm per count of duty, its step in counts.
    """
    n = 300
    t_ms = (2000 + 10 * np.arange(n)).astype(int)  # a steady 10 ms loop (delay(10)), stamped by millis()
    t = t_ms / 1e3
    k = int(rng.integers(60, 91))
    volts = PWM_SUPPLY_V * PWM_DUTY / PWM_FULL
    s = _run(cfg, t, _step(t[k], 0.0, volts))
    counts = np.floor(s["motor_angle_rad"] / (2 * math.pi) * PWM_COUNTS + rng.uniform())
    rpm = np.r_[0.0, np.diff(counts)] / PWM_COUNTS / PWM_LOOP_S * 60.0
    duty = np.where(np.arange(n) >= k, PWM_DUTY, 0)
    path = folder / "pwm_log.csv"
    check_writable([path], force=force)
    _write_csv(path, "t_ms,pwm,rpm", [t_ms, duty, rpm], [".0f", ".0f", ".1f"])
    truth = _truth(cfg, from_v=0.0, to_v=volts, dead_time_s=0.0, sensor_lag_s=PWM_LOOP_S / 2, step_time_s=float(t[k]),
                   units="rpm")
    # per count of duty: the volts' gain times the volts a count is
    truth = replace(_scaled(truth, RPM_PER_RAD_S * PWM_SUPPLY_V / PWM_FULL), step_volts=float(PWM_DUTY))
    return {"log": path}, ("--velocity", str(path)), truth, PWM_LOOP_S


def _write_no_header(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool) -> Writer:
    millis, u, rpm, truth = _sketch_rpm(cfg, rng)
    path = folder / "sketch_log.csv"
    check_writable([path], force=force)
    _write_text(path, "\n".join(f"{a:.0f},{b:.1f},{c:.1f}" for a, b, c in zip(millis, u, rpm, strict=True)) + "\n")
    args = ("--velocity", str(path), "--columns", "time=1,input=2,velocity=3", "--units", "velocity=rpm")
    return {"log": path}, args, truth, ARDUINO_LOOP_S


#: PicoScope rig: sample interval, samples, pre-trigger samples, the two ranges (±V) of 8-bit codes.
PICO_DT_S, PICO_N, PICO_PRE, PICO_RANGES_V = 0.001, 1000, 100, (5.0, 2.0)


def _write_picoscope(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool) -> Writer:
    t = (np.arange(PICO_N) - PICO_PRE) * PICO_DT_S + float(rng.uniform(0.0, PICO_DT_S))
    s = _run(cfg, t, _step(0.0, 0.0, 4.0))
    step = np.where(t >= 0.0, 4.0, 0.0) + rng.normal(0.0, 0.01, t.size)
    tacho = cfg.tacho_v_per_rad_s * s["motor_speed_rad_s"] + rng.normal(0.0, cfg.noise_v, t.size)

    def codes(v: np.ndarray, full_v: float) -> np.ndarray:
        lsb = 2 * full_v / 256
        return np.clip(np.round(v / lsb), -128, 127) * lsb

    rows = [f"{1e3 * a:.8f},{b:.8f},{c:.8f}" for a, b, c in
            zip(t, codes(step, PICO_RANGES_V[0]), codes(tacho, PICO_RANGES_V[1]), strict=True)]
    path = folder / "pico_step.csv"
    check_writable([path], force=force)
    _write_text(path, "Time,Channel A,Channel B\n(ms),(V),(V)\n\n" + "\n".join(rows) + "\n")
    truth = _truth(cfg, from_v=0.0, to_v=4.0, dead_time_s=0.0, sensor_lag_s=0.0, step_time_s=0.0, units="V")
    args = ("--velocity", str(path), "--columns", "time=Time,input=Channel A,velocity=Channel B")
    return {"log": path}, args, truth, PICO_DT_S


def _write_clock_stamps(folder: Path, cfg: TrainerConfig, rng: np.random.Generator, force: bool) -> Writer:
    n = 260
    t = np.r_[0.0, np.cumsum(0.020 + rng.normal(0.0, 0.0015, n - 1))]  # a 20 ms loop, scheduler jitter
    k = int(rng.integers(40, 61))
    s = _run(cfg, t, _step(t[k], 0.0, 9.0))
    counts = np.floor(s["motor_angle_rad"] / (2 * math.pi) * 960 + rng.uniform())
    rpm = np.r_[0.0, np.diff(counts) / np.diff(t)] / 960 * 60.0
    u = np.where(np.arange(n) >= k, 9.0, 0.0)
    base = np.datetime64("2026-03-02T14:03:11.000000") + np.timedelta64(int(rng.integers(0, 10**6)), "us")
    stamps = [str(base + np.timedelta64(round(1e6 * a), "us")).replace("T", " ") for a in t]
    path = folder / "pi_log.csv"
    check_writable([path], force=force)
    _write_text(path, "timestamp,pwm_volts,rpm\n" + "\n".join(
        f"{a},{b:.1f},{c:.2f}" for a, b, c in zip(stamps, u, rpm, strict=True)) + "\n")
    lag = float(np.mean(np.diff(t))) / 2
    truth = _truth(cfg, from_v=0.0, to_v=9.0, dead_time_s=0.0, sensor_lag_s=lag, step_time_s=float(t[k]),
                   units="rpm")
    return {"log": path}, ("--velocity", str(path)), _scaled(truth, RPM_PER_RAD_S), float(np.mean(np.diff(t)))


def _write_text(path: Path, text: str) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="ascii")
    except OSError as exc:
        raise OptionError(f"cannot write the file ({exc.strerror or exc})", file=str(path)) from exc


def write_hobby_rig(name: str, folder: Path, rng: np.random.Generator, force: bool) -> Writer:
    """Write one hobby rig's log (the files, the user's arguments, the truth, the mean sample interval).

    Parameters
    ----------
    name : str
        One of :data:`HOBBY_RIGS`.
    folder : Path
        Where the log goes.
    rng : numpy.random.Generator
        Draws the step instant, clock phases and noise.
    force : bool
        Overwrite an existing log.

    Returns
    -------
    tuple
        ``(files, cli_args, truth, sample_interval_s)``.
    """
    cfg = hobby_rig_config(name)
    if name == "l298n-rpm":
        return _write_l298n(folder, cfg, rng, force)
    if name in ("arduino-millis", "ms-time"):
        return _write_arduino(folder, cfg, rng, force, name=name)
    if name == "host-loop":
        return _write_host_loop(folder, cfg, rng, force)
    if name == "encoder-counts":
        return _write_encoder_counts(folder, cfg, rng, force)
    writers = {"serial-plotter": _write_serial_plotter, "picoscope": _write_picoscope,
               "clock-stamps": _write_clock_stamps, "no-header": _write_no_header, "arduino-pwm": _write_arduino_pwm}
    return writers.get(name, _write_staircase)(folder, cfg, rng, force)

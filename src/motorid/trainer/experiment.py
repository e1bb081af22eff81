"""One experiment on the virtual trainer, recorded the way the paper records it.

Three separate acquisitions of the same step (position, velocity, current), each with its
own trigger point and its own step instant on the file's time axis, plus the sine, triangle
and square validation runs (Masoud 2019, sections V and VI-B).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType

import numpy as np

from motorid.frozen import frozen_getstate, frozen_setstate
from motorid.capture import Capture
from motorid.errors import OptionError
from motorid.trainer.plant import PlantResponse, simulate_plant
from motorid.trainer.presets import TrainerConfig
from motorid.trainer.presets import preset as _preset_config
from motorid.trainer.scope import RECORD_LENGTH, ScopeSettings, acquire, draw_trigger_index, quantise as to_codes
from motorid.trainer.scope import record_time
from motorid.trainer.sensors import current_v, position_v, tacho_v
from motorid.trainer.signals import TEST_SIGNALS, step_signal, test_signal
from motorid.trainer.truth import Truth, truth_of

__all__ = ["AVERAGE_COUNTS", "VOLTS_PER_DIV", "CaptureTruth", "TrainerExperiment", "run_experiment"]

#: CH2 vertical scale per measured channel (CH1, the input, is at 2 V/div).
VOLTS_PER_DIV: Mapping[str, float] = MappingProxyType({"position": 5.0, "velocity": 2.0, "current": 2.0})


@dataclass(frozen=True, slots=True)
class CaptureTruth:
    """What the trainer knows about one capture.

    Attributes
    ----------
    step_time_s : float
        Instant of the step on the capture's own time axis (NaN for test signals).
    step_volts : float
        Step level (the test signal's amplitude for validation runs).
    wraps : int
        Position wraps in the record (0 for other channels).
    """

    step_time_s: float
    step_volts: float
    wraps: int


@dataclass(frozen=True, slots=True)
class TrainerExperiment:
    """A recorded experiment with its ground truth.

    Attributes
    ----------
    captures : Mapping[str, Capture]
        Step captures keyed by role.
    capture_truth : Mapping[str, CaptureTruth]
        Truth per capture (step captures and validation runs).
    validation : Mapping[str, Capture]
        Velocity response to the onboard ``sine``, ``triangle``, ``square`` signals.
    truth : Truth
        Linearised transfer functions.
    config : TrainerConfig
    seed : int
    step_volts : float
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    captures: Mapping[str, Capture]
    capture_truth: Mapping[str, CaptureTruth]
    validation: Mapping[str, Capture]
    truth: Truth
    config: TrainerConfig
    seed: int
    step_volts: float


def _measure(
    role: str, cfg: TrainerConfig, plant: PlantResponse, rng: np.random.Generator, offset_v: float | None = None
) -> tuple[np.ndarray, int]:
    if role == "velocity":
        return tacho_v(cfg, plant, rng), 0
    if role == "current":
        return current_v(cfg, plant, rng), 0
    # the output shaft rests wherever the last run left it
    offset = float(rng.uniform(-0.4, 0.4) * cfg.pot_span_v) if offset_v is None else offset_v
    return position_v(cfg, plant, offset, rng)


#: Average-mode counts of the TDS1000/2000 (``ACQuire:NUMAVg``); 1 is Sample mode.
AVERAGE_COUNTS: tuple[int, ...] = (1, 4, 16, 64, 128)


def _averaged(role: str, cfg: TrainerConfig, settings: ScopeSettings, t: np.ndarray, step_volts: float,
              averages: int, rng: np.random.Generator, quantise: bool) -> tuple[np.ndarray, np.ndarray, float, int]:
    """Average mode: ``averages`` acquisitions of a repeating step, averaged, kept as 8-bit records.

    Each acquisition has its own step instant between two samples, its own noise and the rotor at its
    own resting angle (so the commutator ripple has its own phase); the position's shaft starts where
    the first one left it for all of them.  The TDS1000/2000 averages the acquisitions' codes and keeps
    the average on the 8-bit grid (``DATa:WIDth 2`` pads a zero byte: TDS1000/TDS2000 Programmer
    Manual, DATa:WIDth), so the quantiser's step stays while the random noise averages down.
    """
    dt = settings.sample_interval_s
    offset = float(rng.uniform(-0.4, 0.4) * cfg.pot_span_v) if role == "position" else None
    plants: dict[int, PlantResponse] = {}
    acc_u = np.zeros(t.size)
    acc_y = np.zeros(t.size)
    steps, wraps = [], 0
    for _ in range(averages):
        k = int(rng.integers(0, cfg.substeps))
        step_t = _step_instant(k, dt, cfg.substeps)
        if k not in plants:  # the plant is deterministic: one simulation per sub-step phase
            plants[k] = _simulate_between_samples(cfg, t, step_t, step_volts)
        plant = replace(plants[k], motor_angle_rad=plants[k].motor_angle_rad + float(rng.uniform(0, 2 * np.pi)))
        y, wraps = _measure(role, cfg, plant, rng, offset)
        u = step_signal(t, step_t, step_volts) + rng.normal(0.0, cfg.noise_v, t.size)
        acc_u += to_codes(u, settings.ch1_volts_per_div) if quantise else u
        acc_y += to_codes(y, settings.ch2_volts_per_div) if quantise else y
        steps.append(step_t)
    return acc_u / averages, acc_y / averages, float(np.mean(steps)), wraps


def _step_instant(k: int, dt: float, substeps: int) -> float:
    """The instant of a switch thrown in sub-step ``k`` before a sample (``t = 0``): its middle.

    The ``substeps`` instants ``−(k + ½)·dt/substeps`` spread evenly over the sample interval
    ``(−dt, 0)``, their mean at its middle, as a real switch's uniform instant (at the sub-steps'
    starts, ``−k·dt/substeps``, they had a mean ``dt/(2·substeps)`` later than the middle: every
    trainer capture's response then started on average a sixteenth of a sample late).
    """
    return -(k + 0.5) * dt / substeps


def _simulate_between_samples(cfg: TrainerConfig, t: np.ndarray, step_t: float, step_volts: float) -> PlantResponse:
    """The plant's response to a step at ``step_t``, which may fall between two samples of ``t``.

    The plant holds its input over each integration step; simulated on its sub-step grid (one
    sub-step per point), each sub-step holds the input's mean over it: 0 before the switch is
    thrown, the level after, and in the sub-step where it is thrown the part of the level that
    comes after the instant (the step's integral is exact, its response to second order in the
    sub-step).  The states are kept at the scope's samples.
    """
    m = cfg.substeps
    h = (t[1] - t[0]) / m
    fine = t[0] + np.arange(t.size * m) * h
    u = step_volts * np.clip((fine + h - step_t) / h, 0.0, 1.0)
    full = simulate_plant(cfg, fine, u, substeps=1)
    return PlantResponse(t, *(np.asarray(a)[::m] for a in (
        full.amp_out_v, full.current_a, full.motor_speed_rad_s, full.motor_angle_rad, full.output_angle_rad)))


def run_experiment(
    preset: str = "paper",
    *,
    step_volts: float = 5.92,
    seed: int = 0,
    sec_per_div: float = 1.0,
    config: TrainerConfig | None = None,
    noise: bool = True,
    quantise: bool = True,
    roles: tuple[str, ...] = ("position", "velocity", "current"),
    validation: bool = True,
    quantised: bool | None = None,
    volts_per_div: Mapping[str, float] | None = None,
    trigger_position_pct: float | None = None,
    averages: int = 1,
) -> TrainerExperiment:
    """Record a step experiment (and optionally the validation runs) on the virtual trainer.

    Each capture is a separate acquisition, as in the paper's procedure: the motor starts at
    rest, the scope is armed with its own pre-trigger position, switch S1 is thrown and the
    scope triggers on the CH1 edge (the step lies between the trigger sample and the one
    before it, at a random sub-sample phase); noise, ripple and glitches are drawn afresh.

    Parameters
    ----------
    preset : str
        Preset name (see :data:`PRESET_NAMES`; ignored when ``config`` is given).
    step_volts : float
        Level of switch S1, volts (within ±10 V).
    seed : int
        Seed of trigger points and noise; the same seed gives identical captures.
    sec_per_div : float
        Horizontal scale (the paper's 1 s/div gives 4 ms sampling).
    config : TrainerConfig, optional
        A configuration instead of a preset.
    noise : bool
        Random noise, ripple, PWM and glitches on (``False``: the nonlinear plant only).
    quantise : bool
        8-bit scope quantisation on.
    roles : tuple of str
        Which step captures to record (``position``, ``velocity``, ``current``).
    validation : bool
        Also record the sine, triangle and square runs (velocity on CH2).
    quantised : bool, optional
        Older spelling of ``quantise``; overrides it when given.
    volts_per_div : Mapping[str, float], optional
        Vertical scales: ``input`` (CH1 of every step capture, default 2 V/div) and each role's
        CH2 (default :data:`VOLTS_PER_DIV`).
    trigger_position_pct : float, optional
        Part of the record before the trigger point, % (default: each acquisition draws its own,
        as an operator's horizontal position differs between captures).
    averages : int
        Average mode of the step captures: 1 (Sample mode), 4, 16, 64 or 128 acquisitions.

    Returns
    -------
    TrainerExperiment
        Captures, their truth and the linearised transfer functions.

    Raises
    ------
    OptionError
        For an unknown preset or role, a step level outside ±10 V or a bad scale.

    References
    ----------
    Masoud 2019, section V (three separate captures of one step) and VI-B (test signals).
    """
    cfg = _preset_config(preset) if config is None else config
    if not noise:
        cfg = cfg.quiet()
    if quantised is not None:
        quantise = quantised
    if not np.isfinite(step_volts) or abs(step_volts) > 10.0:
        raise OptionError(f"step level must be within ±10 V (the trainer's input range), got {step_volts!r}")
    unknown = [r for r in roles if r not in VOLTS_PER_DIV]
    if unknown:
        raise OptionError(f"unknown role {unknown[0]!r}; use any of {', '.join(VOLTS_PER_DIV)}")
    scales = dict(volts_per_div or {})
    odd = [k for k in scales if k != "input" and k not in VOLTS_PER_DIV]
    if odd:
        raise OptionError(f"volts_per_div: unknown channel {odd[0]!r}; use input or {', '.join(VOLTS_PER_DIV)}")
    if averages not in AVERAGE_COUNTS:
        raise OptionError(f"averages must be one of {', '.join(map(str, AVERAGE_COUNTS))}, got {averages!r}")
    if trigger_position_pct is not None and not 0.0 <= trigger_position_pct < 100.0:
        raise OptionError(f"trigger position must be within 0 and 100 % of the record, got {trigger_position_pct!r}")
    rng = np.random.default_rng(seed)
    # one child generator per acquisition, always for all six, so that a capture does not
    # change when another one is left out
    keys = (*VOLTS_PER_DIV, *TEST_SIGNALS)
    children = dict(zip(keys, rng.spawn(len(keys)), strict=False))
    captures: dict[str, Capture] = {}
    truth: dict[str, CaptureTruth] = {}
    for role in roles:
        child = children[role]
        settings = ScopeSettings(sec_per_div=sec_per_div, ch1_volts_per_div=scales.get("input", 2.0),
                                 ch2_volts_per_div=scales.get(role, VOLTS_PER_DIV[role]))
        dt = settings.sample_interval_s
        trig = draw_trigger_index(settings, child)
        if trigger_position_pct is not None:  # drawn all the same: the noise does not depend on it
            trig = round(trigger_position_pct / 100.0 * RECORD_LENGTH)
        if averages > 1:
            t = record_time(settings, trig)
            u_avg, y_avg, step_t, wraps = _averaged(role, cfg, settings, t, step_volts, averages, child, quantise)
            captures[role] = acquire(settings, trig, u_avg, y_avg, role=role, source=f"<trainer:{role}>",
                                     quantised=quantise)
            truth[role] = CaptureTruth(step_t, float(step_volts), int(wraps))
            continue
        # the scope triggers on the first sample after the CH1 edge; the switch is thrown at a
        # random instant in the sample interval before it, which the motor sees (the plant runs
        # on its integration sub-steps: the instant is the middle of one of them)
        step_t = _step_instant(int(child.integers(0, cfg.substeps)), dt, cfg.substeps)
        t = record_time(settings, trig)
        u = step_signal(t, step_t, step_volts)
        plant = _simulate_between_samples(cfg, t, step_t, step_volts)
        y, wraps = _measure(role, cfg, plant, child)
        u_meas = u + child.normal(0.0, cfg.noise_v, t.size)
        captures[role] = acquire(settings, trig, u_meas, y, role=role, source=f"<trainer:{role}>",
                                 quantised=quantise)
        truth[role] = CaptureTruth(step_t, float(step_volts), int(wraps))
    runs: dict[str, Capture] = {}
    if validation:
        for kind in TEST_SIGNALS:
            child = children[kind]
            settings = ScopeSettings(sec_per_div=sec_per_div, ch1_volts_per_div=2.0,
                                     ch2_volts_per_div=2.0)
            trig = draw_trigger_index(settings, child)
            t = record_time(settings, trig)
            # the generator runs before the scope is armed: simulate one record length of
            # lead-in from rest and keep the last record, so the run is near its periodic regime
            n = t.size
            t_all = np.concatenate((t[0] + (np.arange(n) - n) * settings.sample_interval_s, t))
            u_all = test_signal(t_all, kind, phase_rad=float(child.uniform(0, 2 * np.pi)))
            full = simulate_plant(cfg, t_all, u_all)
            u = u_all[n:]
            plant = PlantResponse(*(np.asarray(a)[n:] for a in (
                full.time_s, full.amp_out_v, full.current_a, full.motor_speed_rad_s,
                full.motor_angle_rad, full.output_angle_rad)))
            y = tacho_v(cfg, plant, child)
            runs[kind] = acquire(settings, trig, u + child.normal(0.0, cfg.noise_v, t.size), y,
                                 role="velocity", source=f"<trainer:{kind}>", quantised=quantise)
            truth[kind] = CaptureTruth(float("nan"), 6.4, 0)
    return TrainerExperiment(
        captures=MappingProxyType(captures),
        capture_truth=MappingProxyType(truth),
        validation=MappingProxyType(runs),
        truth=truth_of(cfg),
        config=cfg,
        seed=seed,
        step_volts=float(step_volts),
    )

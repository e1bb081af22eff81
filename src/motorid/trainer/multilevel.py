"""Step experiments at several levels on the virtual trainer, with the static law they obey.

A lab repeats the step at a few amplitudes (e.g. 2–10 V, three times each) to see the
dead-zone, the friction and the rails.  :func:`multilevel_experiment` records exactly that:
one velocity capture per level and repeat, each a separate acquisition with the vertical
scales a student would pick (the smallest 1-2-5 step that keeps the trace on screen), and the
truth the captures should give back (:class:`StaticTruth`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from motorid.capture import Capture
from motorid.errors import OptionError
from motorid.simulation.signals import step_signal
from motorid.trainer.plant import PlantResponse, simulate_plant
from motorid.trainer.presets import TrainerConfig, preset
from motorid.trainer.scope import ScopeSettings, acquire, draw_trigger_index, record_time
from motorid.trainer.sensors import tacho_v
from motorid.trainer.truth import truth_of

__all__ = ["MULTILEVEL_PRESETS", "LevelCapture", "MultiLevelExperiment", "StaticTruth", "multilevel_config",
           "multilevel_experiment"]

#: Trainer variants with a visible dead-zone, Coulomb friction and rails (amplifier gain 1):
#: ``deadzone`` moves at every level of 2–10 V; ``deadzone-rails`` saturates above 8.3 V.
MULTILEVEL_PRESETS = ("deadzone", "deadzone-rails")
#: Vertical scales of the scope (1-2-5 sequence), volts per division.
VOLTS_PER_DIV_STEPS = (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0)
#: A trace is kept within this many divisions of the screen's ±5.
SCREEN_DIVS = 4.0


@dataclass(frozen=True, slots=True)
class StaticTruth:
    """The static law the trainer obeys (steady state; friction referred to the input).

    Attributes
    ----------
    dead_zone_v : float
        Amplifier dead-zone plus Coulomb friction referred to the input, ``u₀``.
    gain : float
        Linear DC gain (tacho volts per input volt above the dead-zone).
    saturation_input_v : float
        Input where the amplifier reaches its rails.
    time_constant_s : float
        First-order time constant of the linear dynamics.
    """

    dead_zone_v: float
    gain: float
    saturation_input_v: float
    time_constant_s: float


@dataclass(frozen=True, slots=True)
class LevelCapture:
    """One velocity step capture at one level.

    Attributes
    ----------
    step_volts : float
        The step level.
    repeat : int
        Repeat number at this level (0, 1, ...).
    capture : Capture
        CH1 = step input, CH2 = tacho.
    """

    step_volts: float
    repeat: int
    capture: Capture


@dataclass(frozen=True, slots=True)
class MultiLevelExperiment:
    """Captures at several levels and the truth.

    Attributes
    ----------
    captures : tuple of LevelCapture
    truth : StaticTruth
    config : TrainerConfig
    """

    captures: tuple[LevelCapture, ...]
    truth: StaticTruth
    config: TrainerConfig


def multilevel_config(name: str = "deadzone") -> TrainerConfig:
    """A trainer with a visible dead-zone and Coulomb friction (and rails for ``deadzone-rails``).

    The second-order preset's motor (no amplifier lead/lag, whose kick would clip at the rails
    and make the dynamics depend on the level) with a 0.3 V amplifier dead-zone and Coulomb
    friction worth another 0.2 V at the input.

    Parameters
    ----------
    name : str
        One of :data:`MULTILEVEL_PRESETS`.

    Returns
    -------
    TrainerConfig

    Raises
    ------
    OptionError
        For an unknown name.
    """
    if name not in MULTILEVEL_PRESETS:
        raise OptionError(f"unknown multi-level preset {name!r}; use one of {', '.join(MULTILEVEL_PRESETS)}")
    base = preset("second-order")
    coulomb = 0.2 * base.k_motor * base.amp_gain / base.ra_ohm
    cfg = replace(base, amp_dead_zone_v=0.3, coulomb_nm=coulomb, static_nm=1.2 * coulomb)
    rail = 8.0 if name == "deadzone-rails" else 15.0
    return replace(cfg, amp_rail_v=rail)


def static_truth(config: TrainerConfig) -> StaticTruth:
    """The static law of a trainer configuration.

    Parameters
    ----------
    config : TrainerConfig

    Returns
    -------
    StaticTruth
    """
    t = truth_of(config)
    return StaticTruth(dead_zone_v=t.equivalent_input_offset_v, gain=t.dc_gain,
                       saturation_input_v=config.amp_dead_zone_v + config.amp_rail_v / config.amp_gain,
                       time_constant_s=t.time_constant_s)


def _scale(level: float) -> float:
    for v in VOLTS_PER_DIV_STEPS:
        if abs(level) <= SCREEN_DIVS * v:
            return v
    return VOLTS_PER_DIV_STEPS[-1]


def _settled_at_start(cfg: TrainerConfig, t: np.ndarray, u: np.ndarray, start_volts: float) -> PlantResponse:
    """The plant over ``t``; from a non-zero start, after one record of lead-in at that input."""
    if start_volts == 0.0:
        return simulate_plant(cfg, t, u)
    n = t.size
    dt = float(t[1] - t[0])
    t_all = np.concatenate((t[0] + (np.arange(n) - n) * dt, t))
    full = simulate_plant(cfg, t_all, np.concatenate((np.full(n, start_volts), u)))
    return PlantResponse(*(np.asarray(a)[n:] for a in (
        full.time_s, full.amp_out_v, full.current_a, full.motor_speed_rad_s, full.motor_angle_rad,
        full.output_angle_rad)))


def multilevel_experiment(
    name: str = "deadzone",
    *,
    levels: Sequence[float] = (2.0, 4.0, 6.0, 8.0, 10.0),
    repeats: int = 3,
    seed: int = 0,
    sec_per_div: float = 0.5,
    config: TrainerConfig | None = None,
    start_volts: float = 0.0,
) -> MultiLevelExperiment:
    """Record velocity steps at several levels, each level ``repeats`` times.

    Parameters
    ----------
    name : str
        A :data:`MULTILEVEL_PRESETS` name (ignored when ``config`` is given).
    levels : sequence of float
        Step levels, volts (within ±10 V; negative levels step down).
    repeats : int
        Acquisitions per level.
    seed : int
        Seed of every trigger point and noise draw.
    sec_per_div : float
        Horizontal scale (0.5 s/div: 5 s records, over 10 time constants of the motor).
    config : TrainerConfig, optional
        A configuration instead of a named preset.
    start_volts : float
        The input before each step (0: from rest); the motor has settled at it before the
        scope triggers, as on a rig whose steps go e.g. from 5 V to 15 V.

    Returns
    -------
    MultiLevelExperiment

    Raises
    ------
    OptionError
        For a level outside ±10 V, fewer than one repeat or an unknown preset.
    """
    cfg = multilevel_config(name) if config is None else config
    if repeats < 1:
        raise OptionError(f"repeats must be >= 1, got {repeats}")
    bad = [u for u in levels if not np.isfinite(u) or abs(u) > 10.0 or u == start_volts]
    if bad or not (np.isfinite(start_volts) and abs(start_volts) <= 10.0):
        raise OptionError(f"step levels must differ from the start ({start_volts:g} V) and lie within ±10 V, "
                          f"got {bad[0] if bad else start_volts!r}")
    truth = static_truth(cfg)
    rngs = np.random.default_rng(seed).spawn(len(levels) * repeats)
    out: list[LevelCapture] = []
    for i, level in enumerate(levels):
        expected = truth.gain * max(abs(level) - truth.dead_zone_v, 0.0) + 0.3
        settings = ScopeSettings(sec_per_div=sec_per_div, ch1_volts_per_div=_scale(max(abs(level), abs(start_volts))),
                                 ch2_volts_per_div=_scale(expected))
        for r in range(repeats):
            rng = rngs[i * repeats + r]
            trig = draw_trigger_index(settings, rng)
            step_t = -float(rng.uniform(0.0, 1.0)) * settings.sample_interval_s
            t = record_time(settings, trig)
            u = start_volts + step_signal(t, step_t, float(level) - start_volts)
            plant = _settled_at_start(cfg, t, u, start_volts)
            y = tacho_v(cfg, plant, rng)
            cap = acquire(settings, trig, u + rng.normal(0.0, cfg.noise_v, t.size), y, role="velocity",
                          source=f"<trainer:velocity {level:g} V #{r + 1}>")
            out.append(LevelCapture(float(level), r, cap))
    return MultiLevelExperiment(tuple(out), truth, cfg)

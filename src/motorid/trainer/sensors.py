"""Sensors of the trainer: tachogenerator, wrapping position potentiometer, current monitor."""

from __future__ import annotations

import math

import numpy as np

from motorid.trainer.plant import PlantResponse
from motorid.trainer.presets import TrainerConfig

__all__ = ["tacho_v", "position_v", "current_v", "true_position_v"]


def tacho_v(config: TrainerConfig, plant: PlantResponse, rng: np.random.Generator) -> np.ndarray:
    """Tacho voltage with commutator ripple (proportional to speed, at the segment rate)."""
    c = config
    ripple = 1.0 + c.tacho_ripple * np.sin(c.tacho_segments * plant.motor_angle_rad)
    return c.tacho_v_per_rad_s * plant.motor_speed_rad_s * ripple + rng.normal(0.0, c.noise_v, plant.time_s.size)


def true_position_v(config: TrainerConfig, plant: PlantResponse, offset_v: float) -> np.ndarray:
    """The unwrapped potentiometer reading (what a perfect unwrapper would recover)."""
    return offset_v + config.pot_span_v / (2 * math.pi) * plant.output_angle_rad


def position_v(
    config: TrainerConfig, plant: PlantResponse, offset_v: float, rng: np.random.Generator
) -> tuple[np.ndarray, int]:
    """Potentiometer output: a sawtooth between ±span/2 with near-zero glitches at the jumps.

    Returns
    -------
    (ndarray, int)
        The channel and the number of wraps in the record.
    """
    c = config
    span = c.pot_span_v
    cont = true_position_v(c, plant, offset_v)
    turns = np.floor((cont + span / 2) / span)
    wrapped = cont - span * turns
    out = wrapped + rng.normal(0.0, c.noise_v, cont.size)
    jumps = np.flatnonzero(np.diff(turns) != 0) + 1
    for j in jumps:
        g = int(rng.integers(0, c.pot_glitch_max + 1)) if c.pot_glitch_max > 0 else 0
        seg = out[j : j + g]
        out[j : j + g] = rng.normal(0.0, 0.02 * span, seg.size)  # wiper in the gap: near 0 V
    return out, int(np.sum(np.abs(np.diff(turns))))


def current_v(config: TrainerConfig, plant: PlantResponse, rng: np.random.Generator) -> np.ndarray:
    """Current monitor: armature current plus PWM H-bridge switching noise (aliased)."""
    c = config
    t = plant.time_s
    pwm = 0.0
    if c.pwm_noise_v > 0:
        phase = rng.uniform(0, 2 * np.pi)
        jitter = rng.normal(0.0, 2e-6, t.size)  # switching-edge jitter: the aliased tone smears
        pwm = c.pwm_noise_v * np.sign(np.sin(2 * np.pi * c.pwm_hz * (t + jitter) + phase))
    return c.current_v_per_a * plant.current_a + pwm + rng.normal(0.0, c.noise_v, t.size)

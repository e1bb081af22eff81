"""Sensors of the trainer: tachogenerator, wrapping position potentiometer, current monitor."""

from __future__ import annotations

import math

import numpy as np

from motorid.trainer.plant import PlantResponse
from motorid.trainer.presets import TrainerConfig

__all__ = ["current_v", "encoder_velocity", "position_v", "tacho_v", "true_position_v"]


def tacho_v(config: TrainerConfig, plant: PlantResponse, rng: np.random.Generator) -> np.ndarray:
    """Tachogenerator volts with commutator ripple.

    Parameters
    ----------
    config : TrainerConfig
        Tacho gain (V per rad/s of the motor shaft), ripple fraction and segments per turn.
    plant : PlantResponse
        Simulated motor speed and angle.
    rng : numpy.random.Generator
        Source of the white noise.

    Returns
    -------
    ndarray
        Tacho volts: ``gain·ω·(1 + ripple·sin(segments·φ))`` plus noise; the ripple is
        proportional to the speed and at the commutator-segment frequency.
    """
    c = config
    ripple = 1.0 + c.tacho_ripple * np.sin(c.tacho_segments * plant.motor_angle_rad)
    return c.tacho_v_per_rad_s * plant.motor_speed_rad_s * ripple + rng.normal(0.0, c.noise_v, plant.time_s.size)


def true_position_v(config: TrainerConfig, plant: PlantResponse, offset_v: float) -> np.ndarray:
    """The unwrapped potentiometer reading (what a perfect unwrapper would recover).

    Parameters
    ----------
    config : TrainerConfig
        Potentiometer span (volts per output turn).
    plant : PlantResponse
        Simulated output-shaft angle.
    offset_v : float
        Reading at zero output angle.

    Returns
    -------
    ndarray
        ``offset_v + span/(2π)·θ_out``, continuous.
    """
    return offset_v + config.pot_span_v / (2 * math.pi) * plant.output_angle_rad


def position_v(
    config: TrainerConfig, plant: PlantResponse, offset_v: float, rng: np.random.Generator
) -> tuple[np.ndarray, int]:
    """Potentiometer output: a sawtooth in ``[−span/2, span/2)`` with near-zero glitches.

    Each time the wiper crosses the gap the reading jumps by a span; 0 to ``pot_glitch_max``
    samples right after the jump read close to 0 V (the wiper between the track ends).

    Parameters
    ----------
    config : TrainerConfig
        Span, glitch count and noise.
    plant : PlantResponse
        Simulated output-shaft angle.
    offset_v : float
        Reading at zero output angle (where the shaft happened to rest).
    rng : numpy.random.Generator
        Source of noise and glitches.

    Returns
    -------
    (ndarray, int)
        The channel and the number of true wraps (jumps) in the record.

    References
    ----------
    Masoud 2019, Figs. 22 and 24; Tsiolakis 2022, Fig. 2 (sawtooth position).
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
    """Current monitor: armature current plus PWM H-bridge switching noise.

    The H-bridge switches at ``pwm_hz`` (kHz), far above the scope's sample rate: the square
    wave is sampled with edge jitter, so it folds into a broadband, slowly beating
    component (aliasing, as on the paper's Fig. 18).  Switching spikes (one sample each,
    random sign, Poisson arrivals at ``pwm_spike_rate_hz``) ride on top.

    Parameters
    ----------
    config : TrainerConfig
        Monitor gain and noise levels.
    plant : PlantResponse
        The simulated armature current.
    rng : numpy.random.Generator
        Source of all randomness (no global RNG).

    Returns
    -------
    ndarray
        Monitor volts at the sample instants.

    References
    ----------
    Masoud 2019, Fig. 18 (armature current with PWM noise).
    """
    c = config
    t = plant.time_s
    out = c.current_v_per_a * plant.current_a + rng.normal(0.0, c.noise_v, t.size)
    if c.pwm_noise_v > 0:
        phase = rng.uniform(0, 2 * np.pi)
        jitter = rng.normal(0.0, 2e-6, t.size)  # switching-edge jitter: the aliased tone smears
        out = out + c.pwm_noise_v * np.sign(np.sin(2 * np.pi * c.pwm_hz * (t + jitter) + phase))
    if c.pwm_spike_v > 0 and c.pwm_spike_rate_hz > 0:
        duration = float(t[-1] - t[0])
        n_spikes = int(rng.poisson(c.pwm_spike_rate_hz * duration))
        where = rng.integers(0, t.size, n_spikes)
        height = c.pwm_spike_v * rng.uniform(0.5, 1.0, n_spikes) * rng.choice((-1.0, 1.0), n_spikes)
        np.add.at(out, where, height)
    return out


def encoder_velocity(
    angle_rad: np.ndarray, sample_interval_s: float, *, counts_per_rev: int, every: int, phase: int = 0
) -> np.ndarray:
    """Velocity derived from an incremental encoder, as a microcontroller logs it.

    Every ``every`` samples the firmware differences the encoder count over the last
    ``every`` samples and holds the result until the next update: the log shows a staircase
    with a quantum of ``2π / (counts_per_rev · every · Δt)`` rad/s.

    Parameters
    ----------
    angle_rad : ndarray
        Shaft angle at the sample instants (the encoder's shaft).
    sample_interval_s : float
        Δt of the log.
    counts_per_rev : int
        Encoder counts per revolution of that shaft (quadrature edges included).
    every : int
        Samples between velocity updates (also the differencing window).
    phase : int
        Index of the first update, 0 … ``every − 1`` (the firmware's loop is not aligned
        with the step).

    Returns
    -------
    ndarray
        Held, quantised velocity in rad/s; 0 before the first full window.

    Notes
    -----
    As a linear filter the window is a moving average (mean delay ``every·Δt/2``) and the
    hold adds ``(every − 1)·Δt/2`` on average over the update phase: the measured velocity
    lags the shaft by ``(2·every − 1)·Δt/2`` in the mean-residence sense.  The count
    differences telescope, so the quantisation is unbiased on average.
    """
    counts = np.floor(np.asarray(angle_rad, dtype=float) * counts_per_rev / (2 * math.pi))
    n = counts.size
    quantum = 2 * math.pi / (counts_per_rev * every * sample_interval_s)
    out = np.zeros(n)
    updates = np.arange(phase % every, n, every)
    updates = updates[updates >= every]
    values = (counts[updates] - counts[updates - every]) * quantum
    for j, (k, v) in enumerate(zip(updates, values, strict=False)):
        stop = updates[j + 1] if j + 1 < updates.size else n
        out[k:stop] = v
    return out

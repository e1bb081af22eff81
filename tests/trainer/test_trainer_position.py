"""The wrapping potentiometer: sawtooth jumps, glitch samples, true wrap count."""

from dataclasses import replace

import numpy as np
import pytest

from motorid.trainer import preset, run_experiment


def _count_jumps(pos, span):
    # glitch samples read near 0 V; look across them (the unwrapping rule of Masoud 2019 §V)
    idx = np.flatnonzero(np.abs(pos) > 0.1 * span)
    return int(np.sum(np.abs(np.diff(pos[idx])) > span / 2))


@pytest.mark.parametrize("name, seed", [("paper", 0), ("paper", 4), ("lab-report", 1)])
def test_jumps_equal_the_true_wraps(name, seed):
    step = 5.92 if name == "paper" else 10.0
    e = run_experiment(name, seed=seed, step_volts=step, validation=False, roles=("position",))
    pos = e.captures["position"].output_v
    span = e.config.pot_span_v
    # ±span/2 (10.2 V for the paper) plus one rounding step of the 0.2 V LSB (5 V/div)
    assert np.all(np.abs(pos) <= span / 2 + 0.2 + 1e-9)
    wraps = e.capture_truth["position"].wraps
    assert wraps >= 1
    assert _count_jumps(pos, span) == wraps


def test_lab_report_sawtooth_period():
    # Tsiolakis 2022 eq. 11-12: 15 V per output turn, one turn per 0.867 s at 10 V
    e = run_experiment("lab-report", seed=0, step_volts=10.0, validation=False, roles=("position",))
    cap = e.captures["position"]
    # time turning after the step, less the lag Tm of the speed behind a ramp
    turning_s = cap.time_s[-1] - e.capture_truth["position"].step_time_s - 0.55
    # ±1 for the unknown starting angle within the turn
    assert abs(e.capture_truth["position"].wraps - turning_s / 0.867) <= 1.0


def test_glitch_samples_near_zero_only_when_enabled():
    cfg = replace(preset("lab-report"), pot_glitch_max=3)
    e = run_experiment(config=cfg, seed=3, step_volts=10.0, validation=False, roles=("position",))
    pos = e.captures["position"].output_v
    span = cfg.pot_span_v
    near_zero = np.abs(pos) < 0.1 * span
    # away from the jumps the sawtooth is near 0 only around mid-turn, where the neighbours
    # are near 0 too; a glitch sits between samples of about ±span/2
    big = np.abs(pos) > 0.3 * span
    glitch = near_zero[1:-1] & (big[:-2] | big[2:])
    assert glitch.sum() >= 1
    quiet = run_experiment(config=replace(cfg, pot_glitch_max=0), seed=3, step_volts=10.0,
                           validation=False, roles=("position",))
    q = quiet.captures["position"].output_v
    qbig = np.abs(q) > 0.3 * span
    assert not np.any((np.abs(q) < 0.1 * span)[1:-1] & (qbig[:-2] | qbig[2:]))


def test_negative_step_wraps_downwards():
    e = run_experiment("paper", seed=0, step_volts=-5.92, validation=False, roles=("position",))
    pos = e.captures["position"].output_v
    idx = np.flatnonzero(np.abs(pos) > 2.0)
    d = np.diff(pos[idx])
    jumps = d[np.abs(d) > 10.2]
    assert jumps.size == e.capture_truth["position"].wraps >= 1
    assert np.all(jumps > 0)  # turning backwards: from −10.2 V up to +10.2 V

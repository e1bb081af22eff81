"""The virtual trainer's motor sees the step when the switch is thrown, between two scope samples.

The scope triggers on the first sample after the CH1 edge, so the switch was thrown somewhere in
the sample interval before it; the plant used to start at the trigger sample (its input held per
scope sample), so the recorded response was up to a sample late against the recorded truth.
Checked against python-control's response of the linearised truth, started at the true instant.
"""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.trainer import preset, run_experiment

#: Slow: left out by ``pytest -m "not slow"``; ``.ci/run`` runs it.
pytestmark = pytest.mark.slow


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_response_starts_at_the_true_step_instant(seed):
    ex = run_experiment(config=preset("second-order").ideal(), noise=False, quantised=False, seed=seed,
                        validation=False, roles=("velocity",))
    cap, truth = ex.captures["velocity"], ex.capture_truth["velocity"]
    t, y = np.asarray(cap.time_s), np.asarray(cap.output_v)
    dt = float(t[1] - t[0])
    assert -dt < truth.step_time_s <= 0.0

    fine = np.arange(0.0, 1.0, 1e-6)  # the truth's step response from rest, then read at t − t0
    y_fine = ex.step_volts * np.ravel(control.step_response(ex.truth.velocity, fine).outputs)

    def response_from(t0: float) -> np.ndarray:
        return np.where(t >= t0, np.interp(t - t0, fine, y_fine), 0.0)

    early = slice(int(np.searchsorted(t, 0.0)), int(np.searchsorted(t, 0.8)))  # the rise, where timing shows
    err_true = np.max(np.abs(y[early] - response_from(truth.step_time_s)[early]))
    err_edge = np.max(np.abs(y[early] - response_from(0.0)[early]))
    scale = float(np.max(np.abs(y)))
    assert err_true < 1e-3 * scale  # the plant's own nonlinear parts are off in the ideal preset
    if truth.step_time_s < -0.2 * dt:  # a phase large enough to tell
        assert err_true < 0.5 * err_edge


def test_the_instants_spread_evenly_over_the_sample_interval():
    # a real switch's instant is uniform in the interval before the trigger sample, its mean at the middle
    # (where the conditioning puts the step); the sub-steps' starts had their mean dt/16 late
    from motorid.trainer.experiment import _step_instant

    dt, m = 0.004, preset("paper").substeps
    instants = np.array([_step_instant(k, dt, m) for k in range(m)])
    assert np.all((-dt < instants) & (instants < 0.0))
    assert np.mean(instants) == pytest.approx(-dt / 2, abs=1e-15)
    assert np.var(instants) == pytest.approx(dt**2 / 12, rel=2 / m**2)  # a uniform's, to the grid's 1/m²
    seen = {run_experiment("paper", seed=s, validation=False, roles=("velocity",)).capture_truth["velocity"].step_time_s
            for s in range(24)}
    assert all(np.min(np.abs(instants - x)) < 1e-12 for x in seen) and len(seen) > m // 2

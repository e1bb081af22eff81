"""The output-error fit's data are ranges of each response (views), the values of the masks they replace."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from motorid.conditioning.pipeline import condition_experiment
from motorid.identification import stages
from motorid.trainer import run_experiment


@pytest.fixture(scope="module")
def trainer_velocity():
    return run_experiment("paper", seed=0, roles=("velocity",), validation=False).captures["velocity"]


def _masked(cond, length):
    # the formulas the ranges replace: a mask of the samples kept, less the glitches
    out = {}
    for role in cond.full_outputs:
        r = cond.responses[role]
        good = np.ones(r.time_s.size, dtype=bool)
        if r.glitches is not None:
            good[r.glitches] = False
        after = good & (r.time_s >= -1e-9 * r.sample_interval_s)
        if length is not None:
            after &= r.time_s <= length + 0.5 * r.sample_interval_s
        out[role] = (r.time_s[after] + stages._sampled_phase(r), r.output_v[after], r.output_v[good & (r.time_s < 0)])
    return out


@pytest.mark.parametrize("glitches", [None, np.array([3, 1200, 1201, 2099])])
def test_the_fitted_ranges_are_the_masked_samples(trainer_velocity, monkeypatch, glitches):
    cond = condition_experiment({"velocity": trainer_velocity})
    if glitches is not None:
        r = cond.responses["velocity"]
        cond = replace(cond, responses={"velocity": replace(r, glitches=glitches[glitches < r.time_s.size])})
    for length in (None, 0.7):
        monkeypatch.setattr(stages, "fit_record_length", lambda c, _l=length: _l)
        data = stages._channel_data(cond)
        want = _masked(cond, length)["velocity"]
        assert np.array_equal(data.time_s["velocity"], want[0])
        assert np.array_equal(data.outputs["velocity"], want[1]) and np.array_equal(data.pre["velocity"], want[2])
        assert not data.outputs["velocity"].flags.writeable  # never written: views are safe


def test_the_quantiser_terms_read_the_step_as_a_prefix(trainer_velocity):
    cond = condition_experiment({"velocity": trainer_velocity})
    r = cond.responses["velocity"]
    assert stages.split_at(r.time_s, r.output_v)[0].size == int(np.count_nonzero(r.time_s < 0))
    # the old formula of the level's quantiser term, on the masks
    y, before = r.output_v, r.time_s < 0
    after = np.flatnonzero(~before)
    settled = y[after[int((1.0 - stages.SETTLED_FRACTION) * after.size):]]
    change = float(np.mean(settled) - np.mean(y[before]))
    quantum = stages.quantisation_step(y, below=0.25 * abs(change))
    want = np.hypot(stages.quantisation_bias_std(y[before], quantum), stages.quantisation_bias_std(settled, quantum))
    assert quantum > 0 and stages.output_level_rel_std(cond) == pytest.approx(float(want / abs(change)), rel=1e-9)

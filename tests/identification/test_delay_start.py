"""The dead-time fit starts off the sample grid: its result does not hang on the last bit of the read-off."""

from __future__ import annotations

from dataclasses import replace

import pytest

import motorid as mi
from motorid.conditioning.pipeline import condition_experiment
from motorid.identification.stages import oe_stage, read_off_delay
from motorid.trainer.realsetups import write_real_setup


def test_a_read_off_on_a_sample_gives_the_same_dead_time_whatever_its_last_bit(tmp_path):
    # the l298n rig log: 30 ms firmware dead time + 5 ms of its rpm's averaging, read off as 30 ms,
    # which is a sample instant (100 Hz); 0.030000000000000006 and 0.030000000000000027 s (the two
    # grids' roundings) ended at 29.3 ms (BIC −157) and 36.05 ms (BIC −440) when the fit started there
    write_real_setup("l298n-rpm", tmp_path, seed=0)
    exp = mi.read_experiment(velocity=tmp_path / "l298n_log.csv")
    cond = condition_experiment(exp.captures)
    init = mi.identify(exp, method="classic").model
    delays = []
    for read_off in (0.030000000000000006, 0.030000000000000027):
        c = replace(cond, dead_time_s=read_off)
        assert read_off_delay(c) == pytest.approx(0.035, abs=1e-12)  # the middle of the interval after it
        # the Markov stage carries the read-off as its delay: it starts from the middle too
        res, _ = oe_stage(c, init.replace(delay_s=read_off), (1, 0), delay=True)
        delays.append(res.delay_s)
    assert delays[0] == pytest.approx(delays[1], abs=1e-6)
    assert delays[0] == pytest.approx(0.035, abs=0.002)


def test_a_fitted_delay_of_the_starting_model_is_kept_as_the_start(tmp_path):
    write_real_setup("l298n-rpm", tmp_path, seed=0)
    exp = mi.read_experiment(velocity=tmp_path / "l298n_log.csv")
    cond = condition_experiment(exp.captures)
    init = mi.identify(exp, method="classic").model
    res, _ = oe_stage(cond, init.replace(delay_s=0.0361), (1, 0), delay=True)
    assert res.delay_s == pytest.approx(0.0360, abs=0.001)
    assert read_off_delay(replace(cond, dead_time_s=0.0)) == 0.0

"""SRIVC's second opinion reads the output-error fit's record, not a long log sub-sampled whole."""

from __future__ import annotations

import numpy as np
import pytest

import motorid as mi


def test_a_long_logs_second_opinion_sees_the_time_constant(tmp_path):
    # 400 s at 100 Hz of a 0.3 s motor: the whole record in 1000 samples is one sample per 0.4 s
    # (more than τ), and SRIVC read τ 0.9 s on such a log; its first 50 time constants show it
    k = np.arange(40_000) - 100
    t = k * 0.01
    y = np.where(k >= 0, 10.0 * -np.expm1(-np.maximum(t, 0.0) / 0.3), 0.0)
    y += np.random.default_rng(0).normal(0, 0.01, k.size)
    log = tmp_path / "long.csv"
    np.savetxt(log, np.column_stack([t, np.where(k >= 0, 5.0, 0.0), y]), fmt="%.6f", delimiter=",",
               header="time,input,velocity", comments="")
    from motorid.conditioning.pipeline import condition_experiment
    from motorid.identification.stages import srivc_stage

    fit = mi.identify(mi.read_experiment(velocity=log))
    cond = condition_experiment(mi.read_experiment(velocity=log).captures)
    # 100 samples over the whole 400 s were one per 4 s (SRIVC read τ 0.25 s; 0.9 s on a 10 000 s log);
    # over the fit's record (50 time constants) one per 0.15 s
    stage = srivc_stage(cond, fit.model, (1, 0), max_samples=100)
    assert stage.first_order().time_constant_s == pytest.approx(0.3, rel=0.02)

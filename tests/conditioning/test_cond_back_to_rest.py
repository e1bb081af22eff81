"""A velocity that falls back to rest before the record ends (an end stop, the drive switched off)
is not a step response: the identification says so and how to keep the step part."""

from __future__ import annotations

import numpy as np
import pytest

import motorid as mi


def _log(path, *, stop_s: float | None):
    t = np.arange(-0.5, 4.0, 0.01)
    u = np.where(t >= 0, 5.0, 0.0)
    v = np.where(t >= 0, 4.5 * (1 - np.exp(-np.clip(t, 0, None) / 0.3)), 0.0)
    if stop_s is not None:
        v = np.where(t > stop_s, v * np.exp(-(t - stop_s) / 0.05), v)
    v = v + np.random.default_rng(0).normal(0, 0.01, t.size)
    np.savetxt(path, np.column_stack([t, u, v]), delimiter=",", header="time_s,input_V,velocity_V", comments="")
    return path


def test_a_velocity_that_stops_is_named_with_the_record_length_to_keep(tmp_path):
    fit = mi.identify(mi.read_experiment(velocity=_log(tmp_path / "stop.csv", stop_s=2.0)), method="pinv")
    said = [w for w in fit.warnings if "falls back to its pre-step level" in w]
    assert len(said) == 1, fit.warnings
    keep = float(said[0].split("--record-length ")[1])
    assert 1.5 < keep < 2.0
    kept = mi.identify(mi.read_experiment(velocity=tmp_path / "stop.csv"), record_length_s=keep)
    assert kept.params["dc_gain"].value == pytest.approx(0.9, rel=0.01)
    assert not any("falls back" in w for w in kept.warnings)


def test_a_step_that_settles_is_not_called_stopped(tmp_path):
    fit = mi.identify(mi.read_experiment(velocity=_log(tmp_path / "step.csv", stop_s=None)), method="pinv")
    assert not any("falls back" in w for w in fit.warnings), fit.warnings

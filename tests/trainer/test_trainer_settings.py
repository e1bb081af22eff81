"""The virtual trainer records at any scope setting: volts/div per channel, trigger position, Average mode."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.errors import OptionError
from motorid.trainer.experiment import run_experiment


def test_volts_per_div_and_trigger_position_are_recorded():
    exp = run_experiment("paper", seed=3, roles=("velocity", "current"), validation=False, sec_per_div=0.25,
                         volts_per_div={"input": 5.0, "velocity": 1.0}, trigger_position_pct=20.0)
    vel, cur = exp.captures["velocity"], exp.captures["current"]
    assert vel.output_info.vertical_scale == 1.0 and vel.input_info.vertical_scale == 5.0
    assert cur.output_info.vertical_scale == 2.0  # the default for the current
    assert vel.scope.trigger_index == cur.scope.trigger_index == 500
    assert vel.scope.horizontal_scale_s == 0.25
    # on the 8-bit grid of its own scale
    assert np.allclose(vel.output_v / 0.04, np.round(vel.output_v / 0.04))


def test_the_default_recording_is_unchanged():
    a = run_experiment("paper", seed=5, roles=("velocity",), validation=False)
    b = run_experiment("paper", seed=5, roles=("velocity",), validation=False, averages=1)
    assert np.array_equal(a.captures["velocity"].output_v, b.captures["velocity"].output_v)


def test_average_mode_lowers_the_noise_and_stays_8_bit():
    kw = dict(seed=1, roles=("velocity",), validation=False, sec_per_div=0.25, trigger_position_pct=10.0,
              volts_per_div={"velocity": 0.5, "input": 2.0}, step_volts=0.5)
    one = run_experiment("paper", **kw).captures["velocity"]
    many = run_experiment("paper", averages=64, **kw).captures["velocity"]
    assert np.allclose(many.output_v / 0.02, np.round(many.output_v / 0.02))

    def wiggle(c):  # sample-to-sample noise of the settled part
        return float(np.std(np.diff(c.output_v[-1000:])))

    assert wiggle(many) < 0.6 * wiggle(one)


def test_bad_settings_are_refused():
    with pytest.raises(OptionError, match="averages"):
        run_experiment("paper", roles=("velocity",), validation=False, averages=3)
    with pytest.raises(OptionError, match="volts_per_div"):
        run_experiment("paper", roles=("velocity",), validation=False, volts_per_div={"tacho": 1.0})
    with pytest.raises(OptionError, match="trigger position"):
        run_experiment("paper", roles=("velocity",), validation=False, trigger_position_pct=100.0)

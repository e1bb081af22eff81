"""The simulated TDS2000 acquisition: record length, 8-bit grid, time axis, trigger points."""

import numpy as np
import pytest

from motorid.errors import OptionError
from motorid.trainer import ScopeSettings, run_experiment
from motorid.trainer.scope import quantise


@pytest.mark.parametrize("sec_per_div", [1.0, 0.5])
def test_scope_acquisition_format(sec_per_div):
    e = run_experiment("paper", seed=2, sec_per_div=sec_per_div)
    trig = set()
    for name, cap in {**e.captures, **e.validation}.items():
        assert cap.n_samples == 2500 and cap.scope.record_length == 2500
        assert cap.format == "trainer" and cap.source == f"<trainer:{name}>"
        assert cap.scope.model == "TDS 2012C" and cap.scope.horizontal_scale_s == sec_per_div
        assert cap.sample_interval_s == pytest.approx(10 * sec_per_div / 2500)
        # t = 0 at the trigger index, negative before
        assert cap.time_s[cap.scope.trigger_index] == pytest.approx(0.0, abs=1e-12)
        assert 0.08 * 2500 <= cap.scope.trigger_index <= 0.20 * 2500
        for values, info in ((cap.output_v, cap.output_info), (cap.input_v, cap.input_info)):
            codes = values / info.lsb
            np.testing.assert_allclose(codes, np.round(codes), atol=1e-9)  # 8-bit grid
            assert np.all((codes >= -128) & (codes <= 127))
            assert info.probe_atten == 1.0
        trig.add(cap.scope.trigger_index)
    assert len(trig) >= 4  # each acquisition has its own trigger point


def test_step_sits_just_before_the_trigger_sample():
    e = run_experiment("paper", seed=7, validation=False)
    for role, cap in e.captures.items():
        ct = e.capture_truth[role]
        dt = cap.sample_interval_s
        assert -dt < ct.step_time_s <= 0.0
        k = cap.scope.trigger_index
        # CH1 (2 V/div, LSB 0.08 V): at rest before, at the level from the trigger on
        assert abs(cap.input_v[k - 1]) <= 0.08 and cap.input_v[k] == pytest.approx(5.92, abs=0.05)
        assert ct.step_volts == 5.92


def test_quantise_clips_to_the_screen():
    v = np.array([-100.0, -0.03, 0.05, 100.0])
    out = quantise(v, 1.0)  # LSB 0.04 V, codes −128…127
    np.testing.assert_allclose(out, [-5.12, -0.04, 0.04, 5.08])


def test_bad_settings():
    with pytest.raises(OptionError):
        ScopeSettings(sec_per_div=-1.0)
    with pytest.raises(OptionError):
        ScopeSettings(pretrigger_range=(0.5, 0.2))

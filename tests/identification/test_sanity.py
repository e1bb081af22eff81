"""The sanity gate: every wrong-looking result is flagged with its text."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.conditioning.pipeline import ConditioningSettings
from motorid.identification.pipeline import IdentifySettings, identify_experiment
from motorid.identification.sanity import first_order_baseline, sanity_checks
from motorid.model import model_from_velocity_tf
from motorid.trainer.experiment import run_experiment


def _record(tau: float = 0.4, k: float = 0.9, step: float = 5.0, dt: float = 4e-3, n: int = 2000, seed: int = 0):
    t = np.arange(n) * dt
    y = k * step * (1 - np.exp(-t / tau)) + np.random.default_rng(seed).normal(0, 0.01, n)
    return t, y


def test_a_good_model_passes_every_check() -> None:
    t, y = _record()
    m = model_from_velocity_tf([0.9 / 0.4], [1.0, 1 / 0.4], step_volts=5.0)
    rep = sanity_checks(m, t, y, 5.0, sample_interval_s=4e-3)
    assert rep.passed, rep.failures


def test_unstable_model_is_flagged() -> None:
    # what the paper's pinv gave on a PWM motor at the default 0.1 s: a pole at +1.465
    t, y = _record()
    m = model_from_velocity_tf([1.0], [1.0, -1.465], step_volts=5.0, method="pinv")
    rep = sanity_checks(m, t, y, 5.0, sample_interval_s=4e-3)
    assert not rep.passed
    assert any("UNSTABLE model: pole(s) at +1.465" in f for f in rep.failures)


def test_model_worse_than_a_first_order_baseline_is_flagged_on_a_real_produced_model() -> None:
    # the paper's Taylor-basis Markov method on 8-bit trainer captures (49 % NRMSE)
    e = run_experiment("paper", seed=0, validation=False)
    r = identify_experiment(dict(e.captures), IdentifySettings(method="markov", markov_basis="taylor"))
    assert not r.sanity.passed
    text = " ".join(r.sanity.failures)
    assert "worse than three parameters" in text
    assert "DC gain" in text and "read off the record" in text and "steady state is not the record" in text
    assert any(w.startswith("SANITY CHECK FAILED") for w in r.model.warnings)
    assert r.model.extras["sanity"]["passed"] is False


def test_headline_outside_its_interval_is_flagged() -> None:
    t, y = _record()
    m = model_from_velocity_tf([0.9 / 0.4], [1.0, 1 / 0.4], step_volts=5.0)
    m = m.replace(uncertainty={"dc_gain": {"value": 0.95, "std": 0.001, "ci95": [0.948, 0.952]},
                               "time_constant": {"value": 0.4, "std": 0.001, "ci95": [0.398, 0.402]}})
    rep = sanity_checks(m, t, y, 5.0, sample_interval_s=4e-3)
    assert any("headline DC gain 0.9 V/V OUTSIDE its 95 % interval [0.948, 0.952] V/V" in f for f in rep.failures)


def test_whitened_and_unwhitened_disagreement_is_flagged(real_dir) -> None:
    """`--method oe --order 1` on the HSLU rig (dead time): the AR whitening absorbed the
    misfit and doubled τ (0.72 s vs 0.33 s unwhitened)."""
    from motorid.io import read_capture

    cap = read_capture(real_dir / "hslu-rtl-dcmotor" / "csv" / "06_dc_step_5_15_00.csv", role="velocity")
    r = identify_experiment({"velocity": cap}, IdentifySettings(method="oe", order=1))
    text = " ".join(r.sanity.failures)
    assert "the noise model absorbed a misfit of the structure" in text
    assert "63 % time of the model" in text


def test_default_path_on_the_real_rig_passes(real_dir) -> None:
    """Reference test on the HSLU rig (PROVENANCE.md): the authors' gain (tangent method) within
    1 %, and their hand-refined PT2 + dead time's mean residence time 2·T1 + Td within 5 % (their
    fit is a reference, not ground truth: 5 % is the issue's tolerance for the residence time)."""
    from motorid.io import read_capture

    for name, gain, residence in (("06_dc_step_5_15_00.csv", 245.5, 2 * 0.1468 + 0.035),
                                  ("06_dc_step_5_15_05.csv", 150.5, 2 * 0.1015 + 0.045)):
        cap = read_capture(real_dir / "hslu-rtl-dcmotor" / "csv" / name, role="velocity")
        r = identify_experiment({"velocity": cap})
        assert r.sanity.passed, (name, r.sanity.failures)
        fo = r.model.first_order()
        assert fo.dc_gain == pytest.approx(gain, rel=0.01)
        assert fo.time_constant_s + r.model.delay_s == pytest.approx(residence, rel=0.05)


def test_pinv_at_the_papers_interval_on_a_dead_time_rig_is_flagged(real_dir) -> None:
    from motorid.io import read_capture

    cap = read_capture(real_dir / "hslu-rtl-dcmotor" / "csv" / "06_dc_step_5_15_00.csv", role="velocity")
    r = identify_experiment({"velocity": cap}, IdentifySettings(
        method="pinv", conditioning=ConditioningSettings(sample_interval_s=0.1)))
    assert any("worse than three parameters" in f for f in r.sanity.failures)


def test_first_order_baseline_recovers_a_first_order_plus_dead_time() -> None:
    t = np.arange(0, 3, 0.01)
    y = np.where(t >= 0.05, 2.0 * 5 * (1 - np.exp(-(t - 0.05) / 0.3)), 0.0)
    _fit, par = first_order_baseline(t, y, 5.0)
    assert par["dc_gain"] == pytest.approx(2.0, rel=1e-4)
    assert par["time_constant"] == pytest.approx(0.3, rel=1e-3)
    assert par["delay"] == pytest.approx(0.05, abs=2e-3)


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_closed_loop_records_are_flagged_not_silently_modelled(real_dir) -> None:
    """The HSLU closed-loop files record the controller's output as the "input": not a step.
    Identified as if it were one, the model is that of a step that did not happen."""
    from motorid.io import read_capture

    for name in ("12_dc_step_20_25_00.csv", "12_dc_step_20_25_05.csv", "09_dc_step_20_25_05.csv"):
        cap = read_capture(real_dir / "hslu-rtl-dcmotor" / "csv" / name, role="velocity")
        r = identify_experiment({"velocity": cap})
        assert any("it is not a step" in f for f in r.sanity.failures), (name, r.sanity.failures)


def test_closed_loop_record_without_a_step_is_refused_with_the_reason(real_dir, run_cli) -> None:
    res = run_cli("identify", "--velocity", real_dir / "hslu-rtl-dcmotor" / "csv" / "09_dc_step_20_25_00.csv")
    assert res.code == 2
    assert "open-loop step" in res.err and len(res.err.strip().splitlines()) == 1


def test_a_reversed_tacho_gives_a_negative_gain_with_a_warning() -> None:
    from dataclasses import replace as dc_replace

    e = run_experiment("second-order", seed=2, roles=("velocity",), validation=False)
    cap = e.captures["velocity"]
    flipped = dc_replace(cap, output_v=-cap.output_v)
    r = identify_experiment({"velocity": flipped}, IdentifySettings(method="classic"))
    assert r.model.dc_gain() == pytest.approx(-e.truth.dc_gain * (1 - e.truth.equivalent_input_offset_v / e.step_volts), rel=0.02)
    assert any("negative DC gain" in w for w in r.model.warnings)

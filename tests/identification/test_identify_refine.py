"""Output-error refinement, SRIVC, order selection and uncertainty on trainer data."""

import json

import pytest

from motorid.identification.pipeline import IdentifySettings, identify_experiment
from motorid.trainer import preset, run_experiment


@pytest.fixture(scope="module")
def clean():
    """The linear trainer, no noise, no quantisation: every method must find the truth."""
    return run_experiment(config=preset("paper").ideal(), noise=False, quantised=False, seed=0, validation=False)


#: Noise-free, the DC gain is exact; τ is known to the sub-sample phase of each capture's step
#: (the switch is thrown somewhere in the 4 ms before the trigger sample; the fit takes the
#: middle): at most 2 ms of 430, 0.47 %, and inside the interval, which carries dt/√12.
TAU_PHASE_REL = 0.005


def test_oe_recovers_the_noise_free_linear_truth(clean):
    r = identify_experiment(dict(clean.captures), IdentifySettings(method="oe"))
    fo = r.model.first_order()
    assert fo.dc_gain == pytest.approx(clean.truth.dc_gain, rel=1e-3)
    assert r.model.residence_time_s() == pytest.approx(clean.truth.time_constant_s, rel=TAU_PHASE_REL)
    lo, hi = r.model.uncertainty["residence_time_s"]["ci95"]
    assert lo <= clean.truth.time_constant_s <= hi
    # the paper preset's velocity TF: three poles and the amplifier zero
    assert len(r.model.velocity_tf.poles()) >= 3


@pytest.mark.parametrize("method, rel", [("pinv", 0.10), ("classic", 0.10), ("srivc", 0.01),
                                         ("auto", TAU_PHASE_REL)])
def test_every_method_recovers_the_noise_free_truth(clean, method, rel):
    # tolerances: pinv and classic are the paper's (biased by the 100 ms reduction and the
    # first-order shape); srivc is a consistent estimator started from them; auto: the step's
    # sub-sample phase (see TAU_PHASE_REL)
    r = identify_experiment(dict(clean.captures), IdentifySettings(method=method))
    fo = r.model.first_order()
    assert fo.dc_gain == pytest.approx(clean.truth.dc_gain, rel=max(rel, 1e-3))
    assert r.model.residence_time_s() == pytest.approx(clean.truth.time_constant_s, rel=rel)


def test_oe_beats_the_paper_pinv_on_a_noisy_capture():
    e = run_experiment("paper", seed=11, validation=False)
    offset = e.truth.equivalent_input_offset_v
    dc_eff = e.truth.dc_gain * (1 - offset / e.step_volts)  # what a step can show of the gain
    oe = identify_experiment(dict(e.captures), IdentifySettings(method="oe")).model.first_order()
    pv = identify_experiment(dict(e.captures), IdentifySettings(method="pinv", order=2)).model.first_order()
    assert abs(oe.time_constant_s - e.truth.time_constant_s) < abs(pv.time_constant_s - e.truth.time_constant_s)
    assert abs(oe.dc_gain - dc_eff) < abs(pv.dc_gain - dc_eff)


def test_auto_json_has_uncertainty_and_stages(tmp_path, run_cli, demo_run):
    out = demo_run.folder
    m = tmp_path / "m.json"
    res = run_cli("identify", "--velocity", out / "ALL0001", "--position", out / "ALL0000",
                  "--current", out / "ALL0002", "--method", "auto", "--json", m)
    assert res.code == 0, res.err
    doc = json.loads(m.read_text())
    u = doc["uncertainty"]
    for key in ("dc_gain", "time_constant"):
        lo, hi = u[key]["ci95"]
        assert lo < u[key]["value"] < hi and u[key]["std"] > 0
    assert len(u["poles"]) == len(doc["poles"])
    stages = [s["stage"] for s in doc["stages"]]
    assert "paper method" in stages and "output-error" in stages
    oe = next(s for s in doc["stages"] if s["stage"] == "output-error")
    assert oe["runner_up"] is not None and "BIC" in oe["evidence"]
    assert "±" in res.out  # the terminal summary shows the intervals


def test_paper_auto_keeps_a_stable_model_before_a_better_fitting_unstable_one():
    """The lab report's trainer, seed 15: pinv's model (poles −1.80 and +0.0006 1/s, a position fed back into
    the velocity) had the smallest velocity NRMSE, 0.78 % against the Markov method's 0.79 %, and paper-auto
    kept it, a model its gate rejects as unstable; a stable model now comes first, whatever the NRMSE."""
    import numpy as np

    exp = run_experiment("lab-report", seed=15, validation=False)
    r = identify_experiment(dict(exp.captures), IdentifySettings(method="paper-auto"))
    assert np.all(np.real(r.model.poles()) < 0), r.model.poles()
    assert r.sanity.passed, r.sanity.failures
    reason = r.model.extras["choice"]
    pinv = identify_experiment(dict(exp.captures), IdentifySettings(method="pinv")).model
    if np.any(np.real(pinv.poles()) >= 0):  # the case this test is about (scipy's and numpy's versions decide it)
        assert r.model.method != "pinv"
        assert "whose models are stable" in reason and "pinv 0.78% unstable" in reason, reason

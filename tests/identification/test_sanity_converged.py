"""A fit that stopped before converging fails the sanity gate, and says what that means.

Found on the host-loop rig preset (an EV3 position log resampled from jittered stamps): the chosen
structure's fit crawled along a near-cancelling pole–zero pair to its 200-evaluation limit, and the
printout said "sanity checks: all 11 passed" beside a one-line "stopped early" warning.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import scipy.signal

import motorid as mi
from motorid.identification.method_options import MethodOptions, OutputErrorOptions
from motorid.identification.result import STOPPED_EARLY
from motorid.identification.sanity import sanity_checks
from motorid.model.motor import MotorModel
from motorid.trainer import run_experiment


def _model(warn: tuple[str, ...]) -> MotorModel:
    """Velocity 30·(s/40 + 1)/((s/38.44 + 1)(s/10 + 1)): a pole and a zero 4 % apart."""
    num = 30.0 * np.array([1 / 40, 1.0])
    den = np.polymul([1 / 38.44, 1.0], [1 / 10, 1.0])
    a, b, c, d = scipy.signal.tf2ss(num, den)
    return MotorModel(A=a, B=b, C=c, D=d, states=("x1", "x2"), outputs=("velocity",), step_volts=1.0,
                      warnings=warn)


def _checks(model: MotorModel):
    t = np.arange(0, 1.5, 0.005)
    v = np.asarray(model.step_response(t, 1.0)["velocity"])
    return sanity_checks(model, t, v, 1.0, sample_interval_s=0.005).checks


def test_a_fit_stopped_early_fails_the_gate_and_names_the_pair():
    stopped = _checks(_model((f"{STOPPED_EARLY}: The maximum number of function evaluations is exceeded.",)))
    converged = _checks(_model(()))
    failed = [c for c in stopped if c.name == "the fit converged"]
    assert len(failed) == 1 and not failed[0].passed
    assert "maximum number of function evaluations" in failed[0].detail
    assert "-38.44" in failed[0].detail and "-40" in failed[0].detail and "nearly cancel" in failed[0].detail
    # a converged model gets no such line: its checks are those it had
    assert [c.name for c in converged] == [c.name for c in stopped if c.name != "the fit converged"]
    assert all(c.passed for c in converged)


def test_identify_with_too_few_evaluations_says_so_in_the_gate_once():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = run_experiment("first-order", seed=0, validation=False)
        fit = mi.identify(mi.Experiment(captures=dict(rec.captures)), method="oe",
                          method_options=MethodOptions(output_error=OutputErrorOptions(max_nfev=2)))
    failed = [c for c in fit.sanity.checks if c.name == "the fit converged"]
    assert failed and not failed[0].passed
    assert any(w.startswith("SANITY CHECK FAILED — the fit of this structure stopped before converging")
               for w in fit.warnings)
    assert not any(w.startswith(STOPPED_EARLY) for w in fit.warnings)  # the gate's line, not twice


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_a_model_that_failed_the_converged_check_goes_on_to_design_simulate_and_the_report(tmp_path):
    """The model of a fit stopped early (not a hand-made one) is still a model: a design, its closed
    loop and the report, which carries the gate's line."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = run_experiment("first-order", seed=0, validation=False)
        fit = mi.identify(mi.Experiment(captures=dict(rec.captures)), method="oe",
                          method_options=MethodOptions(output_error=OutputErrorOptions(max_nfev=2)))
    design = mi.design(fit.model, overshoot=5, settling_time=2.0)
    sim = mi.simulate(fit.model, design)
    assert np.all(np.isfinite(np.asarray(sim.time_s)))
    mi.write_report(tmp_path / "report.html", fit, design=design)
    assert "stopped before converging" in (tmp_path / "report.html").read_text(encoding="utf-8")

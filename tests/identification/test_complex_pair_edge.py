"""A motor whose two slow poles are a complex pair: the output-error fit's real poles meet at their
double pole, the edge of what they can represent; ``auto`` then takes the Markov method's polished
model, whose poles may be complex, when it fits clearly better, and the printout says why.

The trainer's paper motor with a large armature inductance (τe = 0.3 s, no amplifier lead/lag):
its velocity poles are −2.23 ± 1.60j (damping 0.81).  Before, ``motorid identify`` printed a
double pole at −2.878 with "damping 1 ± 0.018" and τ 0.695 s against the truth's 0.592 s; the
sanity gate failed two checks without naming the cause.  After, the output-error fit's warning
names the pair held at the edge, and ``auto`` answers with the polished Markov model
(−2.233 ± 1.598j, τ 0.5924 s, its interval covering the truth); where the polish does not fit
clearly better (every trainer preset and HSLU log tried), the output-error fit stays, with the warning.
"""

from __future__ import annotations


import numpy as np
import pytest
from clihelpers import motorid_fresh

import motorid as mi
from motorid.trainer import run_experiment

EDGE_WORDS = "sit at their double pole"


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_auto_takes_the_complex_pair_when_its_fit_is_held_at_the_edge_as_a_user_runs_it(tmp_path):
    """Through the command line in a fresh process: the output-error fit holds the pair at its double
    pole (before, that was the answer, τ 17 % off); the Markov method's polished model, whose poles
    may be complex, fits the velocity 4× better and is the answer, its pair within 2 % of the
    truth's and τ within 1 %, and the printout says why."""
    import json

    from motorid.io import write_tds_capture

    rec = run_experiment("underdamped", seed=0, validation=False)
    truth = np.roots(np.squeeze(rec.truth.velocity.den[0][0]))
    assert np.all(np.abs(np.imag(truth)) > 1.0)  # the plant's pair is complex
    files = {role: write_tds_capture(tmp_path / role, cap, index=i)
             for i, (role, cap) in enumerate(rec.captures.items())}
    args = [a for role, path in files.items() for a in (f"--{role}", str(path))]
    out = tmp_path / "model.json"
    proc = motorid_fresh("identify", *args, "--json", out, cwd=tmp_path)
    text = " ".join(proc.stdout.split())
    assert "identified model: method markov" in text
    assert "held a pair of poles at their double pole" in text and "that model is the answer" in text
    assert "stage output-error: method oe" in text  # the fit it replaced is shown
    m = json.loads(out.read_text())
    assert m["method"] == "markov"
    upper = [p for p in mi.MotorModel.from_json(m).poles() if np.imag(p) > 0]
    assert len(upper) == 1 and abs(upper[0] - truth[np.imag(truth) > 0][0]) < 0.02 * abs(truth[0])
    # τ within 1 % (it was 17 % off); its interval is not asserted: with realistic noise the Markov
    # polish's τ interval covers the truth in only a quarter of the runs (docs/timing.md)
    assert abs(m["uncertainty"]["time_constant"]["value"] / rec.truth.time_constant_s - 1) < 0.01


def test_the_method_the_warning_points_to_finds_the_complex_pair_with_an_honest_interval():
    """``--method markov`` (its polish fits complex poles): the pair within 2 % of the truth's, τ
    within 1 %, no warning of a pair at the edge, every sanity check passed (where the output-error
    fit is 17 % off)."""
    rec = run_experiment("underdamped", seed=0, validation=False)
    fit = mi.identify(mi.Experiment(captures=dict(rec.captures)), method="markov")
    truth = np.roots(np.squeeze(rec.truth.velocity.den[0][0]))
    pair = [p for p in fit.model.poles() if np.imag(p) > 0]
    assert len(pair) == 1 and abs(pair[0] - truth[np.imag(truth) > 0][0]) < 0.02 * abs(truth[0])
    assert abs(fit.model.first_order().time_constant_s / rec.truth.time_constant_s - 1) < 0.01
    assert not any(EDGE_WORDS in w for w in fit.model.warnings)
    assert all(c.passed for c in fit.sanity.checks)


def test_distinct_real_poles_carry_no_such_warning():
    """The demo's motor (three distinct real poles) and a second-order one: no pair at the edge."""
    for name in ("paper", "second-order"):
        rec = run_experiment(name, seed=0, validation=False)
        fit = mi.identify(mi.Experiment(captures=dict(rec.captures)))
        assert not any(EDGE_WORDS in w for w in fit.model.warnings), (name, fit.model.warnings)


@pytest.mark.parametrize(("poles", "edge"), [((-5.0, -14.24, -14.25), [1]), ((-5.0, -9.0, -14.0), []),
                                             ((-14.24, -14.25), [0])])
def test_pairs_at_the_edge_are_the_neighbours_whose_damping_is_one(poles, edge):
    """The rule on the damping the fit reports for each pair of neighbouring poles (slowest first)."""
    from types import SimpleNamespace

    from motorid.identification.stages import pairs_at_the_edge

    p = np.sort(np.array(poles))[::-1]
    ci = {}
    for i in range(p.size - 1):
        wn = np.sqrt(p[i] * p[i + 1])
        zeta = -(p[i] + p[i + 1]) / (2 * wn)
        ci[f"pair_{i}_zeta"] = (zeta - 0.01, zeta + 0.01)
    assert pairs_at_the_edge(SimpleNamespace(poles=p.astype(complex), ci95=ci)) == edge


def test_close_real_poles_at_the_edge_keep_the_output_error_fit():
    """The demo's motor, seed 3: its fast real poles (the truth's) land at a double pole; the
    polished Markov model is tried and shown as a stage, but it does not fit clearly better, so the
    output-error fit stays the answer, with its warning."""
    rec = run_experiment("paper", seed=3, validation=False)
    fit = mi.identify(mi.Experiment(captures=dict(rec.captures)))
    assert fit.model.method == "oe"
    assert any(EDGE_WORDS in w for w in fit.model.warnings)
    names = [st.name if hasattr(st, "name") else st.get("stage") for st in fit.model.stages]
    assert "markov, polished (complex poles allowed)" in names, names


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_the_model_auto_takes_goes_on_to_design_simulate_and_the_report(tmp_path):
    """The polished Markov model that ``auto`` answers with on the underdamped motor (not a hand-made
    one): a critically damped design, its closed loop simulated, and the report written."""
    rec = run_experiment("underdamped", seed=0, validation=False)
    fit = mi.identify(mi.Experiment(captures=dict(rec.captures)))
    assert fit.model.method == "markov"
    design = mi.design(fit.model, overshoot=5, settling_time=3.0)
    sim = mi.simulate(fit.model, design)
    assert np.all(np.isfinite(np.asarray(sim.time_s)))
    mi.write_report(tmp_path / "report.html", fit, design=design)
    html = (tmp_path / "report.html").read_text(encoding="utf-8")
    assert "that model is the answer" in html


def test_a_pair_its_own_zeros_cancel_is_not_taken_for_the_motors():
    """A resonance its anti-resonance undoes is not a complex pair the data want: on a Raspberry Pi
    rpm log (clock-stamps rig preset, seed 0) the Markov polish put a pair at −14.75 ± 86.92j beside
    zeros at −9.217 ± 89.05j in a first-order gearmotor, fitted the counted rpm's ripple 26 % better
    and became auto's answer."""
    import scipy.signal

    from motorid.identification.pipeline import _complex_pair
    from motorid.model.motor import MotorModel

    def model(zeros):
        num = np.real(np.poly(zeros)) if zeros else np.array([1.0])
        den = np.real(np.poly([-14.75 + 86.92j, -14.75 - 86.92j, -8.39]))
        a, b, c, d = scipy.signal.tf2ss(num * den[-1] / num[-1], den)
        return MotorModel(A=a, B=b, C=c, D=d, states=("x1", "x2", "x3"), outputs=("velocity",))

    cancelled = model([-9.217 + 89.05j, -9.217 - 89.05j])
    alone = model([])
    assert _complex_pair(cancelled) is not None  # it is a complex pair ...
    assert _complex_pair(cancelled, uncancelled=True) is None  # ... that its zeros undo
    assert _complex_pair(alone, uncancelled=True) == _complex_pair(alone)


def test_auto_on_the_pi_rpm_log_keeps_no_cancelled_pair(tmp_path):
    """Whatever auto answers on that log, its model has no complex pair that a zero cancels."""
    import warnings

    from motorid.identification.pipeline import PAIR_CANCEL_REL
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("clock-stamps", tmp_path / "pi", seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = mi.identify(mi.read_experiment(velocity=str(rec.files["log"])))  # its --velocity
    zeros = np.asarray(fit.model.zeros())
    for p in fit.model.poles():
        if np.imag(p) > 0 and zeros.size:
            assert np.min(np.abs(zeros - p)) >= PAIR_CANCEL_REL * abs(p)
    assert fit.model.first_order().dc_gain == pytest.approx(rec.truth.dc_gain, rel=0.01)

"""On the virtual trainer: the paper's methods on noisy, 8-bit, nonlinear captures."""

import pytest

from motorid.identification.pipeline import IdentifySettings, identify_experiment
from motorid.trainer import run_experiment

SEEDS = range(20)


@pytest.fixture(scope="module")
def paper_runs():
    return [run_experiment("paper", seed=s, validation=False, roles=("position", "velocity")) for s in SEEDS]


def test_pinv_reduced_recovers_first_order_within_10_percent(paper_runs):
    for e in paper_runs:
        r = identify_experiment(dict(e.captures), IdentifySettings(method="pinv", order=2))
        assert r.model.states == ("position", "velocity")
        fo = r.model.first_order()
        # truth: the linearised trainer's velocity TF by the method of moments
        assert fo.dc_gain == pytest.approx(e.truth.dc_gain, rel=0.10), e.seed
        assert fo.time_constant_s == pytest.approx(e.truth.time_constant_s, rel=0.10), e.seed


def test_markov_detects_order_2_or_3_on_the_paper_preset(paper_runs):
    orders = [
        identify_experiment({"velocity": e.captures["velocity"]},
                            IdentifySettings(method="markov", markov_basis="taylor")).model.order
        for e in paper_runs
    ]
    assert set(orders) <= {2, 3}, orders


def test_markov_detects_order_2_without_the_amplifier_zero():
    orders = []
    for s in SEEDS:
        e = run_experiment("second-order", seed=s, validation=False, roles=("velocity",))
        orders.append(identify_experiment(dict(e.captures),
                                          IdentifySettings(method="markov", markov_basis="taylor")).model.order)
    assert set(orders) == {2}, orders


def test_noise_free_linear_trainer_pinv_is_close():
    """Quantisation and noise off, the paper's pinv still carries the sample-reduction bias."""
    from motorid.trainer import preset

    e = run_experiment(config=preset("paper").ideal(), noise=False, quantised=False, seed=0, validation=False)
    r = identify_experiment(dict(e.captures), IdentifySettings(method="pinv", order=2))
    assert r.model.first_order().dc_gain == pytest.approx(e.truth.dc_gain, rel=0.02)

"""The printout's sanity line names the headline-interval check only when it ran.

The paper's least-squares methods give no interval: their "all passed" line said "headline inside its
interval" all the same, a check that had not run.  The Markov method's polish gives intervals, and
the check runs on them.
"""

from __future__ import annotations

import warnings

import pytest

import motorid as mi


@pytest.fixture(scope="module")
def experiment():
    from motorid.trainer import run_experiment

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = run_experiment("first-order", seed=0, validation=False)
    return mi.Experiment(captures=dict(rec.captures))


def _sanity_line(res) -> str:
    return next(line for line in res.summary(advice=False).splitlines() if line.startswith("sanity checks:"))


@pytest.mark.parametrize("method", ["classic", "pinv"])
def test_a_method_without_intervals_does_not_claim_the_headline_check(experiment, method):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = mi.identify(experiment, method=method)
    assert not any(c.name.startswith("headline ") for c in res.sanity.checks)
    line = _sanity_line(res)
    assert "passed" in line and "no interval to hold the headline to" in line, line
    assert "headline inside its interval" not in line, line


@pytest.mark.parametrize("method", ["auto", "markov"])
def test_a_method_with_intervals_names_the_headline_check_it_ran(experiment, method):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = mi.identify(experiment, method=method)
    assert any(c.name.startswith("headline ") and c.passed for c in res.sanity.checks)
    line = _sanity_line(res)
    assert "headline inside its interval" in line and "no interval" not in line, line

"""The Laguerre polish stops as the output-error fit does: its tolerances and its evaluation budget.

On the first-order trainer (realistic noise, seed 1) the order-2 polish with the current capture has a
pole–zero pair to spare; at ``ftol = xtol = 1e-10`` and 100 evaluations a parameter it crept on for all
900 evaluations (8 s of the Markov method's 16 s) and changed no order chosen.
"""

from __future__ import annotations

import warnings

import pytest

import motorid as mi
from motorid.identification import laguerre_refine
from motorid.identification.method_options import FIT_TOLERANCE, MAX_NFEV, SEARCH_TOLERANCE


def test_every_polish_fit_stops_within_the_output_error_budget(monkeypatch):
    import scipy.optimize

    from motorid.trainer import run_experiment

    real = scipy.optimize.least_squares
    polish: list[tuple[int, float, float]] = []

    def spy(*args, **kwargs):
        sol = real(*args, **kwargs)
        if kwargs.get("diff_step") == 1e-6:  # the polish's call (its finite differences' step)
            polish.append((int(sol.nfev), kwargs["ftol"], kwargs["xtol"]))
        return sol

    # the polish imports scipy.optimize inside the function: its attribute is what it calls
    monkeypatch.setattr(scipy.optimize, "least_squares", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = run_experiment("first-order", seed=1, validation=False)
        res = mi.identify(mi.Experiment(captures=dict(rec.captures)), method="markov")
    assert polish, "no polish fit ran"
    # as the output-error method: the candidates at the order search's tolerance, the chosen one at the final fit's
    assert all(ftol == xtol == SEARCH_TOLERANCE for _, ftol, xtol in polish[:-1])
    assert polish[-1][1] == polish[-1][2] == FIT_TOLERANCE
    assert max(n for n, _, _ in polish) <= MAX_NFEV, polish
    # the order and the gain the polish chose are unchanged by the budget (the first-order truth)
    assert res.model.order == 1
    assert res.model.first_order().dc_gain == pytest.approx(0.905, rel=2e-3)
    assert laguerre_refine.MAX_NFEV == MAX_NFEV


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_the_polish_reuses_its_sampled_systems_and_gets_the_same_model(monkeypatch):
    """A finite-difference column of a numerator moves neither ``A`` nor the delay: the polish keeps the sampled
    system (the exponentials and the eigenvalue problem) and passes it back; kept or made anew, the model JSON is
    the same to the bit."""
    import json

    from motorid.model import forced
    from motorid.trainer import run_experiment

    made = []
    real = forced.delayed_discretisation

    def counting(*args):
        made.append(1)
        return real(*args)

    monkeypatch.setattr(laguerre_refine, "delayed_discretisation", counting)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        rec = run_experiment("second-order", seed=2, validation=False)
        exp = mi.Experiment(captures=dict(rec.captures))
        kept = mi.identify(exp, method="markov").model.to_dict()
        n_kept = len(made)
        made.clear()
        monkeypatch.setattr(laguerre_refine, "SAMPLED_KEPT", 1)  # only the last one: made anew almost every time
        anew = mi.identify(exp, method="markov").model.to_dict()
    assert n_kept < 0.7 * len(made), (n_kept, len(made))
    for d in (kept, anew):
        d.pop("provenance", None)
    assert json.dumps(kept, sort_keys=True, default=str) == json.dumps(anew, sort_keys=True, default=str)

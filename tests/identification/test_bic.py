"""The one BIC the estimators choose structures by: the Gaussian log-likelihood's, checked
against an independent computation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from motorid.identification.metrics import bic


def test_bic_is_minus_twice_the_gaussian_log_likelihood_plus_the_penalty():
    # independent: scipy's normal log-density at the maximum-likelihood variance of each channel
    rng = np.random.default_rng(0)
    residuals = {"velocity": rng.normal(0, 0.3, 400), "current": rng.normal(0, 2.0, 250)}
    n = {c: r.size for c, r in residuals.items()}
    mse = {c: float(np.mean(r**2)) for c, r in residuals.items()}
    loglik = sum(stats.norm.logpdf(r, scale=np.sqrt(mse[c])).sum() for c, r in residuals.items())
    p = 5
    constant = sum(n.values()) * (1 + np.log(2 * np.pi))  # the same for every structure compared
    assert bic(n, mse, p) == pytest.approx(-2 * loglik - constant + p * np.log(sum(n.values())), rel=1e-12)


def test_bic_prefers_the_smaller_error_and_charges_each_parameter_log_n():
    n = {"velocity": 1000}
    assert bic(n, {"velocity": 0.01}, 3) < bic(n, {"velocity": 0.02}, 3)
    assert bic(n, {"velocity": 0.01}, 4) - bic(n, {"velocity": 0.01}, 3) == pytest.approx(np.log(1000))

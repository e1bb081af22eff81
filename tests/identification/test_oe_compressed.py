"""The output-error fit on the triangular factor of ``[J f]`` is the fit on the full residuals.

scipy's ``trf`` is handed ``n + 1`` rows with the same normal equations instead of thousands of
residuals (speed); these tests check the factor against its definition and the whole fit against
``least_squares`` run on the full residuals and Jacobian of the same problem.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize

from motorid.identification.closed_form import PartialFractions, residue_derivatives, residues, separate
from motorid.identification.output_error import (
    OeSettings,
    _Compressed,
    _OeProblem,
    _triangular_factor,
    output_error_fit,
)


@pytest.mark.parametrize("spread", [0.0, 3.0, 6.0, 9.0])
def test_the_factor_has_the_normal_equations_of_jacobian_and_residuals(spread):
    """``RᵀR = [J f]ᵀ[J f]`` to rounding, whether it comes from Cholesky or (ill-conditioned) from QR."""
    rng = np.random.default_rng(3)
    jac = rng.standard_normal((2000, 6)) * np.logspace(0, spread, 6)
    jac[:, 5] = jac[:, 4] * 10 ** (spread / 3) + jac[:, 5] * 10.0 ** (-spread)  # nearly collinear columns
    f = rng.standard_normal(2000)
    r = _triangular_factor(jac, f, _Compressed.MIN_PIVOT)
    a = np.column_stack([jac, f])
    gram = a.T @ a
    scale = np.sqrt(np.outer(np.diag(gram), np.diag(gram)))
    assert r.shape == (7, 7)
    assert np.allclose(np.tril(r, -1), 0.0)
    assert np.max(np.abs(r.T @ r - gram) / scale) < 1e-12
    if spread > 6.0:
        return  # numerically rank-deficient: no unique step to compare
    # and the least-squares step it gives is numpy's on the full matrices
    step_full = np.linalg.lstsq(jac, -f, rcond=None)[0]
    step_small = np.linalg.lstsq(r[:, :-1], -r[:, -1], rcond=None)[0]
    assert np.allclose(step_small, step_full, rtol=1e-6, atol=1e-9 * np.abs(step_full).max())


def test_a_non_finite_point_stays_non_finite():
    """A point where the model overflows is handed on as non-finite (the optimiser then shrinks its step)."""
    jac = np.ones((50, 3))
    f = np.ones(50)
    f[7] = np.inf
    assert not np.any(np.isfinite(_triangular_factor(jac, f, 1e-6)))


def _problem(seed: int = 0):
    rng = np.random.default_rng(seed)
    t = np.arange(1500) * 1e-3
    tau1, tau2, k, step = 0.12, 0.012, 0.9, 2.0
    v = step * k * (1 - (tau1 * np.exp(-t / tau1) - tau2 * np.exp(-t / tau2)) / (tau1 - tau2))
    y = v + 0.004 * rng.standard_normal(t.size)
    pre = 0.004 * rng.standard_normal(200)
    return t, step, {"velocity": y}, {"velocity": pre}


def test_the_fit_equals_least_squares_on_the_full_residuals():
    """Same optimum, same residuals and same covariance as ``least_squares`` on the uncompressed problem."""
    t, step, channels, pre = _problem()
    settings = OeSettings(n_poles=2, n_zeros=0, shifts=False)
    sigma = {"velocity": 0.004}
    ours = output_error_fit(t, step, channels, sigma, [0.2, 0.02], 1.0, settings, pre=pre)
    prob = _OeProblem.build(t, step, channels, sigma, settings, pre=pre, block=None, whiten=None, pre_sigma=None,
                            wrap_count=None)
    th0 = np.clip(prob.initial_parameters([0.2, 0.02], 1.0, [], 0.0), prob.lower + 1e-9, prob.upper - 1e-9)
    ref = scipy.optimize.least_squares(prob.residuals, th0, jac=prob.jacobian, bounds=(prob.lower, prob.upper),
                                       x_scale="jac", method="trf", ftol=1e-12, xtol=1e-12)
    assert np.allclose(ours.params, ref.x, rtol=1e-6, atol=1e-9)
    assert ours.cost == pytest.approx(ref.cost, rel=1e-9)
    assert ours.residuals["velocity"].size == t.size
    # the degrees of freedom count samples: the pre-step samples are two rows of the residuals
    assert prob.n_total == t.size + pre["velocity"].size
    cov_ref = np.linalg.pinv(ref.jac.T @ ref.jac) * (2 * ref.cost / (prob.n_total - ref.x.size))
    assert np.allclose(ours.cov, cov_ref, rtol=1e-4, atol=0.0)
    assert ours.dc_gain == pytest.approx(0.9, rel=2e-3)


def test_the_pre_step_rows_carry_every_pre_step_sample():
    """The two pre-step rows have the per-sample rows' sum of squares, Jacobian product and gradient.

    Per sample, the pre-step residuals are ``w·(x_i − offset)``, whose Jacobian is ``−w`` in the
    offset's column: built here by hand, they are compared with the problem's at a point away from
    the optimum (an offset off the samples' mean).
    """
    t, step, channels, pre = _problem(1)
    settings = OeSettings(n_poles=2, n_zeros=0, shifts=False)
    prob = _OeProblem.build(t, step, channels, {"velocity": 0.004}, settings, pre=pre, block=None, whiten=None,
                            pre_sigma={"velocity": 0.005}, wrap_count=None)
    th = np.clip(prob.initial_parameters([0.2, 0.02], 1.0, [], 0.0), prob.lower + 1e-9, prob.upper - 1e-9)
    off = prob.layout.idx["off_velocity"]
    th[off] += 0.01
    f, jac = prob.residuals(th), prob.jacobian(th)
    n_post = t.size
    assert f.size == n_post + 2 and jac.shape[0] == n_post + 2
    w = 1.0 / 0.005
    per_sample = w * (pre["velocity"] - th[off])
    j_per_sample = np.zeros((pre["velocity"].size, th.size))
    j_per_sample[:, off] = -w
    f_full = np.r_[f[:n_post], per_sample]
    j_full = np.vstack([jac[:n_post], j_per_sample])
    assert f @ f == pytest.approx(f_full @ f_full, rel=1e-12)
    np.testing.assert_allclose(jac.T @ jac, j_full.T @ j_full, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(jac.T @ f, j_full.T @ f_full, rtol=1e-10, atol=1e-9)


def test_partial_fractions_are_the_residues_of_each_numerator():
    """One set of partial fractions, several numerators: the same residues and derivatives as one call each."""
    taus = np.array([0.3, 0.05, 0.05 * (1 + 1e-7), 0.004])
    pf = PartialFractions(taus)
    assert np.array_equal(pf.taus, separate(taus))
    for num in ([1.0], [0.02, 1.0], [3.0, 0.5, 2.0], [1e-3, 0.0, 0.0, 1.0]):
        p, r, n0 = pf.residues(num)
        p1, r1, n1 = residues(num, taus)
        assert np.array_equal(p, p1) and np.array_equal(r, r1) and n0 == n1
        d, dr = pf.derivatives(num)
        d1, dr1 = residue_derivatives(num, taus)
        assert np.array_equal(d, d1) and np.array_equal(dr, dr1)
        # and the residues are those of the partial-fraction expansion N(s)/(s·D(s)) at p_i
        den = np.poly1d([1.0])
        for tau in pf.taus:
            den *= np.poly1d([tau, 1.0])
        for i, pi in enumerate(p):
            rest = np.poly1d([1.0, 0.0]) * den / np.poly1d([pf.taus[i], 1.0])
            expect = np.polyval(num, pi) / (pf.taus[i] * np.polyval(rest.coeffs if hasattr(rest, "coeffs")
                                                                     else rest[0].coeffs, pi))
            assert r[i] == pytest.approx(expect, rel=1e-6)

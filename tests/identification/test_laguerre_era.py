"""The Laguerre stage's ERA is python-control's ``eigensys_realization``, to rounding."""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.identification.laguerre import eigensystem_realisation


@pytest.mark.parametrize("order", [1, 2, 3])
@pytest.mark.parametrize("size", [8, 13, 24])
def test_realisation_equals_python_control(order, size):
    rng = np.random.default_rng(order * 100 + size)
    # a decaying impulse response of a stable third-order discrete system, with noise
    poles, residues = rng.uniform(-0.5, 0.9, 3), rng.normal(size=3)
    g = (residues[None, :] * poles[None, :] ** np.arange(size)[:, None]).sum(axis=1)
    g = g + 1e-3 * rng.normal(size=size)
    rows = size // 2
    ref, _ = control.eigensys_realization(np.r_[0.0, g], r=order, m=rows, n=size - rows)
    a, b, c = eigensystem_realisation(g, order, rows, size - rows)
    scale = max(1.0, float(np.max(np.abs(ref.A))))
    assert np.allclose(a, ref.A, rtol=0, atol=1e-12 * scale)
    assert np.allclose(b, ref.B, rtol=0, atol=1e-12 * max(1.0, float(np.max(np.abs(ref.B)))))
    assert np.allclose(c, ref.C, rtol=0, atol=1e-12 * max(1.0, float(np.max(np.abs(ref.C)))))
    # and it realises the sequence as well as the library's
    fit = [float((c @ np.linalg.matrix_power(a, k) @ b)[0, 0]) for k in range(size)]
    fit_ref = [float((ref.C @ np.linalg.matrix_power(ref.A, k) @ ref.B)[0, 0]) for k in range(size)]
    assert np.allclose(fit, fit_ref, atol=1e-10)


@pytest.mark.parametrize("size", [3, 5, 7, 8])
def test_the_noise_floor_is_the_quantile_of_the_largest_singular_values(size):
    """The floor is the quantile of σ₁ of noise Hankel matrices drawn with the coefficients' covariance:
    recomputed here from the same draws (seed 0) with numpy's 2-norm."""
    from motorid.identification.laguerre import laguerre_noise_floor

    rng = np.random.default_rng(size)
    root = rng.normal(size=(size, size))
    cov = root @ root.T
    w, v = np.linalg.eigh(cov)
    draws = np.random.default_rng(0).standard_normal((400, size)) @ (v * np.sqrt(np.clip(w, 0.0, None))).T
    rows = (size + 1) // 2
    hankels = draws[:, np.add.outer(np.arange(rows), np.arange(size - rows + 1))]
    expected = np.quantile(np.linalg.norm(hankels, ord=2, axis=(1, 2)), 0.95)
    assert laguerre_noise_floor(cov, draws=400, quantile=0.95, seed=0) == pytest.approx(expected, rel=1e-12)

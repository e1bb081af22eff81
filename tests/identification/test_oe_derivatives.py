"""The output-error fit's derivatives against plain finite differences of what they differentiate."""

from __future__ import annotations

import numpy as np
import pytest

from motorid.identification.output_error import OeSettings, _derived, _Layout, _t63_gradient

CASES = [
    (OeSettings(n_poles=2, n_zeros=1, delay=True), ["velocity"], [0.9, np.log(0.4), np.log(0.03), 0.01, 0.02]),
    (OeSettings(n_poles=3, n_zeros=0), ["velocity"], [0.9, np.log(0.4), np.log(0.03), np.log(0.002)]),
    (OeSettings(n_poles=1, n_zeros=0, delay=True), ["velocity"], [0.9, np.log(0.3), 0.05]),
]


@pytest.mark.parametrize(("settings", "channels", "head"), CASES)
def test_63_time_gradient_equals_differences_of_root_searches(settings, channels, head):
    """The implicit-function gradient of the 63 % time against central differences of its root search."""
    layout = _Layout(settings, channels)
    th = np.r_[head, np.zeros(len(layout.names) - len(head))]
    t63 = _derived(layout, th)["t63"]
    ours = _t63_gradient(layout, th, t63)
    for i in range(th.size):
        h = 1e-6 * max(abs(th[i]), 1e-3)
        up, down = th.copy(), th.copy()
        up[i] += h
        down[i] -= h
        ref = (_derived(layout, up)["t63"] - _derived(layout, down)["t63"]) / (2 * h)
        assert ours[i] == pytest.approx(ref, rel=1e-5, abs=1e-8), layout.names[i]


SHAPES = [((0.4,), ()), ((0.4, 0.03), ()), ((0.4, 0.03), (0.01,)), ((0.4, 0.03, 0.004), (0.02,)),
          ((0.4, 0.05), (0.05 * (1 + 1e-4),))]


@pytest.mark.parametrize("kind", ["step", "position"])
@pytest.mark.parametrize(("taus", "zeros"), SHAPES)
@pytest.mark.parametrize("block", [None, (7, 0.004)])
def test_shape_derivatives_equal_differences_of_the_closed_forms(kind, taus, zeros, block):
    """Analytic basis derivatives (block means too, and the block holding the step) against
    central differences of the closed form itself, in ln τ and in each zero's time constant."""
    from motorid.identification.closed_form import (
        ResponseBasis,
        position_closed_form,
        residues,
        step_response_closed_form,
    )
    from motorid.identification.output_error import _vel_num

    fn = position_closed_form if kind == "position" else step_response_closed_form
    t = np.arange(-5, 400) * 0.004 + 0.0013
    k = 0.9
    taus, zeros = np.array(taus), np.array(zeros)
    dnums = [np.polymul(_vel_num(k, np.delete(zeros, j)), [1.0, 0.0]) for j in range(zeros.size)]
    ours = 5.92 * ResponseBasis(t, residues([1.0], taus)[0], block).shape(kind, _vel_num(k, zeros), taus, dnums)
    scale = np.max(np.abs(fn(t, _vel_num(k, zeros), taus, 5.92, block)))
    for j in range(taus.size + zeros.size):
        h = 1e-6
        if j < taus.size:
            up, down = taus.copy(), taus.copy()
            up[j] *= np.exp(h)
            down[j] *= np.exp(-h)
            ref = (fn(t, _vel_num(k, zeros), up, 5.92, block) - fn(t, _vel_num(k, zeros), down, 5.92, block)) / (2 * h)
        else:
            up, down = zeros.copy(), zeros.copy()
            up[j - taus.size] += h
            down[j - taus.size] -= h
            ref = (fn(t, _vel_num(k, up), taus, 5.92, block) - fn(t, _vel_num(k, down), taus, 5.92, block)) / (2 * h)
        assert np.max(np.abs(ours[:, j] - ref)) <= 1e-5 * scale, j


def test_nearly_equal_time_constants_differentiate_exactly():
    """Two time constants 0.1 % apart: their residues are ±1000 times the response and no finite
    difference of the closed form resolves the derivative (central differences are off by 1e-4);
    the analytic one matches the exact derivative of ``K(1 − (a·e^{−t/a} − b·e^{−t/b})/(a − b))``
    in ``ln a`` to 1e-7."""
    from motorid.identification.closed_form import ResponseBasis, residues

    a, b, k = 0.4, 0.4 * (1 + 1e-3), 0.9
    t = np.arange(1, 400) * 0.004
    g = a * np.exp(-t / a) - b * np.exp(-t / b)
    exact = -k * a * (np.exp(-t / a) * (1 + t / a) / (a - b) - g / (a - b) ** 2)
    ours = ResponseBasis(t, residues([1.0], [a, b])[0]).shape("step", np.array([k]), np.array([a, b]))[:, 0]
    assert np.max(np.abs(ours - exact)) <= 1e-7


@pytest.mark.parametrize("block", [None, (7, 0.004)])
def test_a_basis_on_times_out_of_order_gives_the_same_values(block):
    """Every response of a basis zeroes the samples (blocks) before the step; on increasing times that
    is a leading run zeroed in place, on any other order an elementwise mask: both give the same values."""
    from motorid.identification.closed_form import ResponseBasis, residues

    t = np.arange(-5, 300) * 0.004 + 0.0013
    order = np.random.default_rng(1).permutation(t.size)
    p, r, n0 = residues([0.3, 0.9], np.array([0.4, 0.03]))
    rs = np.column_stack([r, 2 * r])
    sorted_basis, shuffled = ResponseBasis(t, p, block), ResponseBasis(t[order], p, block)
    for name, args in (("step", (r, n0)), ("step", (rs, np.array([n0, 2 * n0]))), ("slope", (r,)),
                       ("position", (r, n0)), ("shape", ("step", [0.3, 0.9], np.array([0.4, 0.03])))):
        ours = getattr(shuffled, name)(*args)
        ref = getattr(sorted_basis, name)(*args)[order]
        assert np.array_equal(ours, ref), name
        span = 0.0 if block is None else (block[0] - 1) * block[1]  # a block holding the step is averaged
        assert np.all(ours[t[order] + span < 0] == 0.0), name

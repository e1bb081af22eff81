"""The Laguerre stage's state simulation against the sample-by-sample recursion it replaces."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from motorid.identification.laguerre import _simulate


def _loop(a, b, t, u, step_volts, delay):
    """The plain recursion: one matrix step per sample (exact for a held input)."""
    ns, ni = b.shape
    out = np.zeros((t.size, ns, ni))
    te = t - delay
    start = int(np.searchsorted(te, 0.0, side="left"))
    h = float(t[1] - t[0])

    def zoh(step):
        mm = np.zeros((ns + ni, ns + ni))
        mm[:ns, :ns], mm[:ns, ns:] = a, b
        e = scipy.linalg.expm(mm * step)
        return e[:ns, :ns], e[:ns, ns:]

    f, g = zoh(h)
    if u is None:
        x = zoh(float(te[start]))[1] * step_volts
        for i in range(start, t.size):
            out[i] = x
            x = f @ x + g * step_volts
    else:
        ud = np.interp(te, t, u, left=0.0)
        x = np.zeros((ns, ni))
        for i in range(start, t.size):
            out[i] = x
            x = f @ x + g * ud[i]
    return out


RNG = np.random.default_rng(0)
A3 = np.array([[-3.0, 1.0, 0.0], [0.0, -40.0, 1.0], [0.0, 0.0, -300.0]])
B3 = RNG.normal(size=(3, 2))
# with an integrator (the position's regressors): an eigenvalue at zero
A4 = np.block([[A3, np.zeros((3, 1))], [RNG.normal(size=(1, 3)), np.zeros((1, 1))]])
B4 = np.vstack([B3, np.zeros((1, 2))])
T = np.arange(-20, 2480) * 0.004
U = np.where(T >= 0, 5.92, 0.0) + 0.01 * RNG.normal(size=T.size)


@pytest.mark.parametrize(("a", "b"), [(A3, B3), (A4, B4)])
@pytest.mark.parametrize("u", [None, U])
@pytest.mark.parametrize("delay", [0.0, 0.0123])
@pytest.mark.parametrize("n", [T.size, 70])
def test_block_recursion_equals_the_loop(a, b, u, delay, n):
    ours = _simulate(a, b, T[:n], None if u is None else u[:n], 5.92, delay)
    ref = _loop(a, b, T[:n], None if u is None else u[:n], 5.92, delay)
    assert np.max(np.abs(ours - ref)) <= 1e-10 * np.max(np.abs(ref))


@pytest.mark.parametrize("integrate", [False, True])
@pytest.mark.parametrize("u", [None, U])
def test_regressors_equal_the_loop(integrate, u):
    """The Laguerre network's responses (12 terms) against the plain recursion on the same network."""
    from motorid.identification.laguerre import laguerre_network, laguerre_regressors

    n = 12
    a_l, b_l = laguerre_network(8.0, n)
    if integrate:
        a_l = np.block([[a_l, np.zeros((n, n))], [np.eye(n), np.zeros((n, n))]])
        b_l = np.vstack([b_l, np.zeros((n, 1))])
    ref = _loop(a_l, b_l, T, u, 5.92, 0.01)[..., 0]
    ref = ref[:, -n:] if integrate else ref
    ours = laguerre_regressors(T, 8.0, n, input_v=u, step_volts=5.92, delay_s=0.01, integrate=integrate)
    assert np.max(np.abs(ours - ref)) <= 1e-10 * np.max(np.abs(ref))

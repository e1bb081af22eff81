"""Forced and free responses of a linear model on a uniform grid: the state recursion they share.

The Laguerre stage's regressors and ``validate``'s simulation both step ``x[k+1] = F x[k] + G w[k]``
over long records.  A Python loop over the samples (what ``control.forced_response`` and
``scipy.signal.dlsim`` do) costs about 2 µs a sample; :func:`held_states` runs the same products in
blocks of :data:`RECURSION_BLOCK` samples as array products, which no library offers for a
recursion of this kind (``scipy.signal.lfilter`` does, but in transfer-function form, whose
coefficients lose digits on stiff models; here the state form is kept).

:func:`linear_hold_response` is python-control's ``forced_response`` (the input linear between
samples, the same discretisation of the augmented exponential) and ``initial_response`` in one
call, on that recursion.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

#: Samples per block of :func:`held_states`.
RECURSION_BLOCK = 64


def held_states(f: np.ndarray, x0: np.ndarray, g: np.ndarray, w: np.ndarray | None, n: int) -> np.ndarray:
    """``X[0] = x0``, ``X[k+1] = F X[k] + G·w[k]`` (``w ≡ 1`` when None) for ``k < n``.

    In blocks of :data:`RECURSION_BLOCK` samples: within a block ``X[j] = F^j X[0] + Σ_{i<j}
    F^{j−1−i} G w[i]`` from the block's powers of ``F`` (array products), and one step per block
    carries the state on: the same products as the sample-by-sample loop.

    Parameters
    ----------
    f : ndarray, shape (states, states)
        The step matrix ``F``.
    x0 : ndarray, shape (states, columns)
        Initial states, one column per response.
    g : ndarray, shape (states, columns)
        Input matrix, one column per response (each driven by the same scalar ``w``).
    w : ndarray or None
        The scalar input sequence (at least ``n`` samples); None for a constant 1.
    n : int
        Number of samples.

    Returns
    -------
    ndarray, shape (n, states, columns)
    """
    ns = f.shape[0]
    size = min(RECURSION_BLOCK, n)
    powers = np.empty((size + 1, ns, ns))
    powers[0] = np.eye(ns)
    for j in range(size):
        powers[j + 1] = f @ powers[j]
    fg = powers[:size] @ g  # F^j G
    lag = np.arange(size)[:, None] - 1 - np.arange(size)[None, :]  # j − 1 − i
    causal = lag >= 0
    kernel = np.where(causal[:, :, None, None], fg[np.clip(lag, 0, None)], 0.0)  # (j, i, states, columns)
    ni = x0.shape[1]
    out = np.empty((n, ns, ni))
    x = x0
    # every block's forced response in one matrix product: the kernel as a (rows, i) matrix
    # against the blocks' inputs as columns (a held step, w ≡ 1, forces every block alike; a
    # short last block uses its first rows)
    n_blocks = -(-n // size)
    inputs = np.ones((size, 1 if w is None else n_blocks))
    if w is not None:
        padded = np.zeros(n_blocks * size)
        padded[:n] = w[:n]
        inputs = padded.reshape(n_blocks, size).T
    flat = kernel.transpose(0, 2, 3, 1).reshape(size * ns * ni, size)
    forced_all = (flat @ inputs).reshape(size, ns, ni, -1)
    for b, s0 in enumerate(range(0, n, size)):
        m = min(size, n - s0)
        wb = inputs[:, 0 if w is None else b]
        forced = forced_all[..., 0 if w is None else b]
        block = powers[:size] @ x + forced
        out[s0 : s0 + m] = block[:m]
        # the state one step after the block's last sample
        x = f @ block[size - 1] + g * wb[size - 1]
    return out


def linear_hold_response(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, dt: float,
                         u: np.ndarray, initial: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Output of ``ẋ = A x + B u``, ``y = C x + D u`` from rest, ``u`` linear between samples.

    ``x[k+1] = A_d x[k] + B_0 u[k] + B_1 u[k+1]`` with ``A_d``, ``B_0``, ``B_1`` from one
    exponential of the augmented matrix (python-control's ``forced_response`` for a
    continuous-time system, which steps the same formula in a Python loop).

    Parameters
    ----------
    a, b, c, d : ndarray
        A single-input, single-output realisation: shapes (n, n), (n, 1), (1, n), (1, 1).
    dt : float
        The grid's sample interval [s].
    u : ndarray, shape (samples,)
        The input at the samples.
    initial : ndarray, shape (n, k), optional
        Initial states whose free responses ``C A_dᵏ x0`` are returned too (one column each).

    Returns
    -------
    forced : ndarray, shape (samples,)
        The response to ``u`` from rest (``nan`` where an unstable model overflows).
    free : ndarray, shape (samples, k)
        The free responses to ``initial`` (``k = 0`` without it).
    """
    n = a.shape[0]
    u = np.asarray(u, dtype=float).ravel()
    m = np.zeros((n + 2, n + 2))
    m[:n, :n], m[:n, n : n + 1], m[n, n + 1] = a * dt, b * dt, 1.0
    with np.errstate(over="ignore", invalid="ignore"):
        e = scipy.linalg.expm(m)
    k = 0 if initial is None else initial.shape[1]
    if not np.all(np.isfinite(e)):
        return np.full(u.size, np.nan), np.full((u.size, k), np.nan)
    ad, b1 = e[:n, :n], e[:n, n + 1 : n + 2]
    b0 = e[:n, n : n + 1] - b1
    # u[k] drives through B_0 and u[k+1] through B_1: one recursion each (the free responses, input
    # columns of zero, ride along with the first).  Not z[k] = x[k] − B_1 u[k], which needs one
    # recursion only but cancels digits when the model grows much over a sample (A_d B_1 ≫ B_0)
    x0 = np.zeros((n, 1)) if initial is None else np.hstack([np.zeros((n, 1)), initial])
    with np.errstate(over="ignore", invalid="ignore"):
        y = np.einsum("s,nsk->nk", c[0], held_states(ad, x0, np.hstack([b0, np.zeros((n, k))]), u, u.size))
        ahead = np.r_[u[1:], u[-1:]]
        forced = (y[:, 0] + held_states(ad, np.zeros((n, 1)), b1, ahead, u.size)[:, :, 0] @ c[0]
                  + d[0, 0] * u)
    return forced, y[:, 1:]

"""Forced and free responses of a linear model on a uniform grid: every estimator's and ``validate``'s.

Three discretisations, one per kind of input the project simulates, all from the exact
exponential of the model (:func:`motorid.model.lti.zoh` or the augmented matrix of a linear
input):

- :func:`linear_hold_response` — the input linear between samples, from rest and from given
  initial states, in state form (``validate``: a recorded test signal over a long record);
- :func:`linear_hold_filtered` — the same hold in transfer-function form through a compiled
  filter, for many signals and output rows at once (SRIVC's prefilters, run many times per fit);
- :func:`zero_hold_delayed` — the input held over each sample and delayed by any fraction of a
  sample (the modified z-transform: the Laguerre stage's output-error polish);
- :func:`held_states` — the state recursion under all of them in state form (the Laguerre
  regressors' held input, with its own interpolated delay).

A step response has its closed form (:mod:`motorid.model.response`, the output-error fit's
``step_response_closed_form``); the closed loop and the trainer step nonlinear systems with the
same :func:`motorid.model.lti.zoh`.

The Laguerre stage's regressors and ``validate``'s simulation step ``x[k+1] = F x[k] + G w[k]``
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

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from numpy.lib.stride_tricks import sliding_window_view

from motorid.model import lti

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
    ni = x0.shape[1]
    # the block's Toeplitz kernel K[j, i] = F^(j−1−i) G for j > i, else 0, as (j, states, columns, i):
    # windows of the reversed sequence [F^(size−1) G, …, G, 0, …, 0] (views; the reshape copies once)
    reversed_fg = np.concatenate([np.zeros((size, ns, ni)), fg])[::-1]
    kernel = sliding_window_view(reversed_fg, size, axis=0)[size:0:-1]
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
    flat = np.ascontiguousarray(kernel.reshape(size * ns * ni, size))
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


def _linear_hold(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """``(A_d, B_0, B_1)`` of an input linear over a sample, None when the exponential overflows.

    One exponential of the augmented matrix: ``x[k+1] = A_d x[k] + B_0 u[k] + B_1 u[k+1]``.
    """
    n = a.shape[0]
    m = np.zeros((n + 2, n + 2))
    m[:n, :n], m[:n, n : n + 1], m[n, n + 1] = a * dt, b * dt, 1.0
    with np.errstate(over="ignore", invalid="ignore"):
        e = scipy.linalg.expm(m)
    if not np.all(np.isfinite(e)):
        return None
    b1 = e[:n, n + 1 : n + 2]
    return e[:n, :n], e[:n, n : n + 1] - b1, b1


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
    k = 0 if initial is None else initial.shape[1]
    hold = _linear_hold(a, b, dt)
    if hold is None:
        return np.full(u.size, np.nan), np.full((u.size, k), np.nan)
    ad, b0, b1 = hold
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


def linear_hold_filtered(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray, t: np.ndarray,
                         inputs: np.ndarray) -> list[np.ndarray]:
    """Rows of ``y = C x + D u`` for ``ẋ = A x + B u`` from rest, ``u`` linear between samples, per signal.

    The same discretisation as :func:`linear_hold_response` (and ``scipy.signal.lsim`` with
    ``interp=True``): ``x[k+1] = A_d x[k] + B_0 u[k] + B_1 u[k+1]``.  Each output row is the sum of
    two compiled filter runs (:func:`motorid.model.lti.lfilter`), ``C(zI − A_d)⁻¹B_0`` on ``u`` and
    ``C(zI − A_d)⁻¹B_1`` on ``u`` advanced one sample, and the discretisation, numerators and filter
    runs are shared by every signal.  In transfer-function form it is 4–6× faster than the block
    recursion on the records SRIVC filters (2 500–20 000 samples, many times per fit) and equal to
    ``lsim`` to about 1e-10 of the signal, which SRIVC's instruments need; a validation over a long
    record uses the state form (1e-15).

    Parameters
    ----------
    a, b, c, d : ndarray
        A single-input realisation, shapes (n, n), (n, 1), (outputs, n), (outputs, 1).
    t : ndarray
        The uniform sample times.
    inputs : ndarray, shape (signals, samples)
        Each row one input signal.

    Returns
    -------
    list of ndarray, each of shape (outputs, samples)
        One entry per signal (``nan`` when the model's exponential overflows).
    """
    u = np.asarray(inputs, dtype=float)
    hold = _linear_hold(a, b, float(t[1] - t[0]))
    if hold is None:
        # an unstable estimate's exponential overflows: its response is not finite (lsim's too)
        return [np.full((c.shape[0], u.shape[1]), np.nan) for _ in range(u.shape[0])]
    ad, b0, b1 = hold
    ahead = np.concatenate([u[:, 1:], u[:, -1:]], axis=1)
    den = np.real(np.poly(ad))
    n0, n1 = _numerators(ad, b0, c, den), _numerators(ad, b1, c, den)
    out = np.empty((u.shape[0], c.shape[0], u.shape[1]))
    for i in range(c.shape[0]):
        out[:, i] = lti.lfilter(n0[i], den, u) + lti.lfilter(n1[i], den, ahead) + d[i, 0] * u
    return list(out)


def _numerators(a: np.ndarray, b: np.ndarray, c: np.ndarray, den: np.ndarray) -> np.ndarray:
    """Numerators (rows, in powers of ``z⁻¹``) of ``C(zI − A)⁻¹B`` over ``den = det(zI − A)``.

    From the Markov parameters ``M_i = C Aⁱ B``: ``b_k = Σ_{j<k} a_j M_{k−1−j}`` (Cayley–Hamilton),
    every row at once; ``scipy.signal.ss2tf`` takes two eigenvalue problems per row.
    """
    n = a.shape[0]
    markov = np.empty((n, c.shape[0]))
    x = b[:, 0]
    for i in range(n):
        markov[i] = c @ x
        x = a @ x
    num = np.zeros((c.shape[0], n + 1))
    for k in range(1, n + 1):
        num[:, k] = sum(den[j] * markov[k - 1 - j] for j in range(k))
    return num


@dataclass(frozen=True, slots=True)
class DelayedHold:
    """A held input's sampled system with a dead time: ``x_{k+1} = Φ x_k + Γa v_k + Γb v_(k−1)``.

    Attributes
    ----------
    whole : int
        Whole samples of the dead time.
    frac : float
        The rest of the dead time [s], ``0 ≤ frac < h``.
    phi, gamma_a, gamma_b : ndarray
        ``Φ`` (n, n), ``Γa`` and ``Γb`` (n, 1).
    den : ndarray
        ``det(zI − Φ)``, highest power first.
    """

    whole: int
    frac: float
    phi: np.ndarray
    gamma_a: np.ndarray
    gamma_b: np.ndarray
    den: np.ndarray


def delayed_discretisation(a_c: np.ndarray, b_c: np.ndarray, h: float, delay: float) -> DelayedHold:
    """The sampled system of :func:`zero_hold_delayed`: what depends on ``A``, ``B``, ``h`` and the delay only.

    Parameters
    ----------
    a_c, b_c : ndarray
        ``A`` (n, n) and ``B`` (n, 1).
    h : float
        The sample interval [s].
    delay : float
        The dead time ``θ = whole·h + frac`` [s].

    Returns
    -------
    DelayedHold
        A fit that varies only a model's output rows (its numerators) can keep it and pass it
        back (``discretisation=``): the exponentials and the eigenvalue problem are most of a
        call's cost.
    """
    whole = math.floor(delay / h + 1e-12)
    frac = delay - whole * h
    e_rest, g_rest = lti.zoh(a_c, b_c, h - frac)  # the part of the interval fed by the current sample
    e_head, g_head = lti.zoh(a_c, b_c, frac)
    phi = e_rest @ e_head
    g_b = e_rest @ g_head  # the head of the interval, still fed by the previous sample
    return DelayedHold(whole, frac, phi, g_rest, g_b, np.real(np.poly(phi)))


def zero_hold_delayed(a_c: np.ndarray, b_c: np.ndarray, c_rows: np.ndarray, d_col: np.ndarray, h: float,
                      u: np.ndarray, delay: float, discretisation: DelayedHold | None = None) -> np.ndarray:
    """Exact sampled response of ``ẋ = Ax + Bu(t − θ)``, ``y = Cx + Du(t − θ)`` to a held input.

    The input ``u_k`` holds over ``[t_k, t_k + h)``; a delay ``θ = n·h + f`` splits each sample
    interval at ``f`` (the modified z-transform), so the response is smooth in ``θ`` and the
    fit can move the dead time by fractions of a sample (the Laguerre stage's output-error
    polish differentiates it by finite differences).

    Parameters
    ----------
    a_c, b_c : ndarray
        ``A`` (n, n) and ``B`` (n, 1).
    c_rows : ndarray, shape (outputs, n)
        The output rows.
    d_col : ndarray, shape (outputs,)
        The feedthrough of each output.
    h : float
        The sample interval [s].
    u : ndarray
        The input samples, each held over its interval.
    delay : float
        The dead time ``θ`` [s] (negative: the input advanced).
    discretisation : DelayedHold, optional
        :func:`delayed_discretisation` of the same ``a_c``, ``b_c``, ``h`` and ``delay``, computed
        before; computed here when not given.

    Returns
    -------
    ndarray, shape (len(u), outputs)
    """
    # scipy.signal loads here, when the Markov method's polish runs (``auto`` does not: start-up);
    # motorid.model.lti's filter differs from it in the last bits, which the polish's finite
    # differences feel (8x the evaluations on a first-order record)
    from scipy.signal import lfilter

    if discretisation is None:
        discretisation = delayed_discretisation(a_c, b_c, h, delay)
    whole, frac, phi, den = discretisation.whole, discretisation.frac, discretisation.phi, discretisation.den
    # a negative delay (a capture triggered late) advances the input: the input started `lead` samples before
    # the first output sample, so the response runs from there (the state at the first sample is not zero), the
    # input held at its last sample for the samples it runs ahead at the end
    lead = max(-whole, 0)
    if lead:
        u = np.r_[u, np.full(lead, u[-1])]
    idx = np.arange(u.size) - max(whole, 0)
    v = np.where(idx < 0, 0.0, u[np.clip(idx, 0, u.size - 1)])
    v_prev = np.r_[0.0, v[:-1]]
    out = np.empty((u.size, c_rows.shape[0]))
    # every row's numerators from Φ's Markov parameters (the denominator's eigenvalue problem is the
    # only one; ss2tf took two per row), their leading coefficient exactly zero
    n_a = _numerators(phi, discretisation.gamma_a, c_rows, den)
    n_b = _numerators(phi, discretisation.gamma_b, c_rows, den)
    for i in range(c_rows.shape[0]):
        # x_{k+1} = Φ x_k + Γa v_k + Γb v_(k−1): y_k = C x_k (a one-sample lag in both filters)
        y = lfilter(n_a[i], den, v) + lfilter(n_b[i], den, v_prev)
        out[:, i] = y + d_col[i] * (v_prev if frac > 0 else v)
    return out[lead:]

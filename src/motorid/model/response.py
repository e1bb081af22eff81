"""Responses of a :class:`~motorid.model.motor.MotorModel`.

The exact step response on any grid and the NRMSE of a model against a measured step.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from motorid.blockwise import BLOCK, max_abs
from motorid.errors import OptionError
from motorid.model.lti import zoh

if TYPE_CHECKING:
    from motorid.model.motor import MotorModel


def step_response(model: MotorModel, time_s: Any, step_volts: float | None = None) -> dict[str, np.ndarray]:
    """Exact response of every output channel of ``model`` to a step applied at ``t = 0``.

    Exact for a step on any grid: the matrix exponential of ``[[A, B], [0, 0]]`` once
    per sample interval on a uniform grid (then a recursion), at each time otherwise;
    samples before 0 (before ``delay_s`` for a model with a dead time) are zero.  A model
    with a static nonlinearity (Hammerstein) responds to the step its dead-zone and rails
    let through, ``f(step)``.

    Parameters
    ----------
    model : MotorModel
        The model.
    time_s : array_like
        Times in seconds (any grid).
    step_volts : float, optional
        Step level; defaults to the model's ``step_volts``.

    Returns
    -------
    dict of str to ndarray
        One array per output channel, in volts.

    Raises
    ------
    OptionError
        When no step level is given or known.
    """
    step = model.step_volts if step_volts is None else float(step_volts)
    if step is None:
        raise OptionError("step_response needs step_volts (the model has none)")
    if model.static_nonlinearity is not None:
        step = float(model.static_nonlinearity.effective_input(step))
    t = np.asarray(time_s, dtype=float).ravel()
    if model.delay_s:
        t = t - model.delay_s  # (no copy of a long record without a dead time: t - 0.0 is t)
    n = model.order
    after = t >= 0
    everywhere = bool(after.all())
    # a record from the step on (the synchronised one) is filled in place: no zeros, no copy of
    # the times after the step, no array of its steps (a 10 M-sample record held ten such arrays)
    x = np.empty((t.size, n)) if everywhere else np.zeros((t.size, n))
    if everywhere or np.any(after):
        ta = t if everywhere else t[after]
        with np.errstate(over="ignore", invalid="ignore"):  # unstable models overflow
            # uniform within float64's resolution of the stamps themselves: t/dt beyond ~4.5 million made
            # 1e-9·dt tighter than the rounding of t, and a 10 M-row log took an expm per sample
            d0 = float(ta[1] - ta[0]) if ta.size > 1 else 0.0
            resolution = 16.0 * np.finfo(float).eps * max_abs(ta)
            if ta.size > 2 and _uniform_steps(ta, d0, 1e-9 * max(abs(d0), 1e-300) + resolution):
                # uniform grid: one exact step matrix, then the recursion
                # x[k+1] = Φ x[k] + Γ·step (exact for a step; 100x faster than an expm
                # per sample)
                phi, gamma = zoh(model.A, model.B, d0)
                x0 = zoh(model.A, model.B, ta[0])[1][:, 0] * step
                if everywhere:
                    _affine_orbit(phi, gamma[:, 0] * step, x0, ta.size, out=x)
                else:
                    x[after] = _affine_orbit(phi, gamma[:, 0] * step, x0, ta.size)
            else:
                # a non-uniform grid: the exact state at each instant, one exponential per sample
                x[after] = zoh(model.A, model.B, ta[:, None, None])[1][:, :, 0] * step
    with np.errstate(over="ignore", invalid="ignore"):
        y = _outputs(x, model.C)
        del x
        # + D·step after the step, + 0.0 before it (in place: the same sums as adding the full array)
        if everywhere:
            y += model.D[:, 0] * step
        else:
            y += np.where(after[:, None], model.D[:, 0] * step, 0.0)
    return {name: y[:, i] for i, name in enumerate(model.outputs)}


def _outputs(x: np.ndarray, c: np.ndarray) -> np.ndarray:
    """``x @ c.T``: the outputs of the states ``x`` (one row a sample), written over ``x`` when it fits.

    A long record (at least two :data:`BLOCK` of samples) with as many outputs as states has its
    outputs computed in row blocks of at least ``BLOCK`` rows (the last block takes the remainder,
    so no product is small) and stored over ``x``: each output row depends on its own state row
    only, and each block is the same BLAS product as the whole (tests/model/test_response_memory.py
    compares the bits), so the states and the outputs of a 10 M-sample record are not held
    together; the outputs' columns are laid out as the whole product's.  Otherwise (fewer outputs
    than states: their columns over the states would be strided, and copied by whoever needs them
    contiguous) the whole product, as before.
    """
    count, n = x.shape
    m = c.shape[0]
    if count < 2 * BLOCK or m != n or not x.flags.c_contiguous:
        return x @ c.T
    starts = list(range(0, count - BLOCK, BLOCK))  # the last block holds BLOCK to 2·BLOCK − 1 rows
    for i, start in enumerate(starts):
        stop = starts[i + 1] if i + 1 < len(starts) else count
        x[start:stop] = x[start:stop] @ c.T
    return x


def _uniform_steps(t: np.ndarray, d0: float, tol: float) -> bool:
    """Whether every step of ``t`` is within ``tol`` of ``d0``: ``all(|diff(t) − d0| <= tol)``, in blocks."""
    for i in range(0, t.size - 1, BLOCK):
        d = np.diff(t[i : i + BLOCK + 1])
        d -= d0
        np.abs(d, out=d)
        if not np.all(d <= tol):
            return False
    return True


def _affine_orbit(phi: np.ndarray, gam: np.ndarray, x0: np.ndarray, count: int,
                  out: np.ndarray | None = None) -> np.ndarray:
    """``x[0] = x0``, ``x[k] = Φ x[k−1] + Γ`` for ``k < count``, without a Python loop per sample.

    The affine map ``x ↦ Φx + Γ`` composed with itself ``m`` times is ``x ↦ Φᵐx + c_m`` with
    ``c_2m = Φᵐ c_m + c_m``: each doubling extends the orbit by a batched product, so a
    300 000-sample record costs 19 numpy products instead of 300 000 Python iterations
    (scipy's ``dlsim`` loops in Python; ``lfilter`` would need ``ss2tf``, ill-conditioned
    for the wide pole spreads of motor models).
    """
    n = x0.size
    if out is None:
        out = np.empty((count, n))
    out[0] = x0
    power, offset, m = phi.copy(), gam.copy(), 1
    while m < count:
        k = min(m, count - m)
        # the product straight into the orbit and the offset added in place: the same BLAS product
        # and the same sums as ``out[:k] @ power.T + offset``, without its two temporaries of half
        # the record (tests/model/test_model_response_inplace.py compares the bits)
        np.matmul(out[:k], power.T, out=out[m : m + k])
        out[m : m + k] += offset
        offset = power @ offset + offset
        power = power @ power
        m *= 2
    return out


def recorded_step_response(model: MotorModel, time_s: Any, step_volts: float | None = None, *,
                           velocity_window_s: float = 0.0, velocity_window_ends: Any = None) -> dict[str, np.ndarray]:
    """:func:`step_response` as the sensors record it: a counted velocity is a mean over a window.

    A speed counted from encoder edges over each sample interval is the mean over the window
    ``T`` before each time (:attr:`motorid.capture.Capture.sample_window_s`); the model's is
    averaged the same way before it is compared with such a record: ``(P(t) − P(t − T))/T``, with
    ``P`` the velocity's integral (the velocity transfer function with an integrator, the same dead
    time and static nonlinearity), exact across a dead time's kink and the step.

    Parameters
    ----------
    model : MotorModel
        The model.
    time_s : array_like
        Times in seconds (any grid).
    step_volts : float, optional
        Step level; defaults to the model's ``step_volts``.
    velocity_window_s : float
        The velocity's window ``T`` (s); 0 for a sampled velocity (then :func:`step_response`).
    velocity_window_ends : array_like, optional
        Where each time's window ends (default: at the time itself); a count kept over several
        lines ends at the last line that logged it
        (:meth:`~motorid.conditioning.pipeline.ConditionedExperiment.velocity_window_ends`).

    Returns
    -------
    dict of str to ndarray
        One array per output channel, the velocity as recorded.
    """
    out = step_response(model, time_s, step_volts)
    if velocity_window_s <= 0 or "velocity" not in out:
        return out
    t = np.asarray(time_s if velocity_window_ends is None else velocity_window_ends, dtype=float).ravel()
    integral = velocity_integral(model)
    step = model.step_volts if step_volts is None else step_volts
    late = step_response(integral, t, step)["position"]
    early = step_response(integral, t - velocity_window_s, step)["position"]
    return {**out, "velocity": (late - early) / velocity_window_s}


def velocity_integral(model: MotorModel) -> MotorModel:
    """The model whose ``position`` output is the integral of ``model``'s velocity.

    Its velocity transfer function with an integrator appended, with the same dead time and
    static nonlinearity (a velocity-only model's position, a counted velocity's window).

    Parameters
    ----------
    model : MotorModel
        A model with a velocity output.

    Returns
    -------
    MotorModel
    """
    from motorid.model.motor import model_from_velocity_tf

    return model_from_velocity_tf(*model._row_tf("velocity"), with_position=True).replace(
        delay_s=model.delay_s, static_nonlinearity=model.static_nonlinearity)


def step_nrmse(
    model: MotorModel,
    time_s: Any,
    measured: Any,
    *,
    channel: str = "velocity",
    step_volts: float | None = None,
) -> float:
    """RMS of (measured − model) step response divided by the measured steady state.

    Parameters
    ----------
    model : MotorModel
    time_s : array_like
        Sample times in seconds, 0 at the step edge.
    measured : array_like
        The measured channel in volts, same length as ``time_s``.
    channel : str
        Output channel to compare.
    step_volts : float, optional
        Step level; defaults to the model's.

    Returns
    -------
    float
        ``sqrt(mean((y − ŷ)²)) / |mean of the last 10 % of y|`` (docs/formats.md,
        ``fit.velocity_nrmse``).

    Raises
    ------
    OptionError
        On mismatched lengths, an unknown channel or a zero steady state.
    """
    t = np.asarray(time_s, dtype=float).ravel()
    y = np.asarray(measured, dtype=float).ravel()
    if t.size != y.size or t.size < 2:
        raise OptionError(f"step_nrmse needs equally long time and data arrays, got {t.size} and {y.size}")
    if channel not in model.outputs and channel != "position":
        raise OptionError(f"the model has no {channel!r} output; it has {list(model.outputs)}")
    if channel in model.outputs:
        yhat = model.step_response(t, step_volts)[channel]
    else:
        # Position of a velocity-only model: integral of the velocity output (its dead time and
        # static nonlinearity included, as the velocity's own response has them)
        step = model.step_volts if step_volts is None else float(step_volts)
        if step is None:
            raise OptionError("step_nrmse needs step_volts (the model has none)")
        yhat = velocity_integral(model).step_response(t, step)["position"]
    tail = y[-max(1, y.size // 10):]
    final = float(np.mean(tail))
    if final == 0.0:
        raise OptionError(f"the measured {channel} has a zero steady state; NRMSE is undefined")
    # an unstable model's response overflows: its NRMSE is infinite, not a warning
    with np.errstate(over="ignore", invalid="ignore"):
        value = float(np.sqrt(np.mean((y - yhat) ** 2)) / abs(final))
    return value if np.isfinite(value) else float("inf")

"""Goodness of fit: one NRMSE and MATLAB's ``compare`` fit %, used by identify and validate.

NRMSE (normalised root-mean-square error)
    ``NRMSE = sqrt(mean((y − ŷ)²)) / Δy``: the RMS error over the *measured change of the
    response* ``Δy``.

    - ``reference="final"`` (a step response whose pre-step baseline has been removed): ``Δy``
      is the steady-state change, ``|mean of the last 10 % of y|`` — the docs/formats.md
      definition of ``fit.velocity_nrmse``.
    - ``reference="span"`` (any other input: sine, triangle, square, …, and the step response
      of a current, which returns towards 0): ``Δy`` is the range
      the response covers, ``P99(y) − P1(y)`` (1st to 99th percentile: the peak-to-peak
      change, robust to a few spikes).  For a step response from rest the two agree up to
      overshoot and noise.

    0 is a perfect model; a model that predicts nothing at all scores about
    ``RMS(y) / Δy`` (≈ 0.84 for a first-order step response recorded over 5 τ).

Fit %
    MATLAB ``compare``'s normalised fit ``100·(1 − ‖y − ŷ‖₂ / ‖y − mean(y)‖₂)``: 100 % is a
    perfect model, 0 % no better than the measured mean, negative is worse than the mean.
    It does not depend on the kind of input.

Both compare arrays of equal length; nuisance parameters (delay, offsets, initial state) are
applied to ``ŷ`` by the caller before scoring.

BIC
    The one information criterion the estimators choose a structure by (:func:`bic`): the
    Gaussian ``Σ_c n_c·log(MSE_c) + p·log(Σ_c n_c)`` over the fitted channels.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Literal

import numpy as np

from motorid.blockwise import BLOCK, centred_sum_of_squares
from motorid.errors import OptionError

__all__ = ["REFERENCES", "bic", "fit_percent", "nrmse", "response_change", "step_fit"]

#: Names of the NRMSE normalisations (see the module docstring).
REFERENCES = ("final", "span")


def _pair(measured: object, simulated: object) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(measured, dtype=float).ravel()
    # a 1-D simulation as it is: ravel() would copy a column of a step response (a strided view of
    # its outputs), and the simulation is only used elementwise (y − ŷ; the sums run over that
    # contiguous result, so their order, and bits, are unchanged)
    yhat = np.asarray(simulated, dtype=float)
    if yhat.ndim != 1:
        yhat = yhat.ravel()
    if y.size != yhat.size or y.size < 2:
        raise OptionError(f"measured and simulated must be equally long (≥ 2 samples), got {y.size} and {yhat.size}")
    return y, yhat


def response_change(measured: object, reference: Literal["final", "span"] = "final") -> float:
    """The measured change of a response, the denominator of :func:`nrmse`.

    Parameters
    ----------
    measured : array_like
        The measured response [V].  For ``"final"``: the increment from the pre-step
        baseline.
    reference : {"final", "span"}
        ``"final"``: ``|mean of the last 10 % of the samples|`` (steady-state change of a
        step response); ``"span"``: ``P99 − P1`` of the samples (peak-to-peak change).

    Returns
    -------
    float
        ``Δy`` [V], ≥ 0.

    Raises
    ------
    OptionError
        For an unknown ``reference``.
    """
    y = np.asarray(measured, dtype=float).ravel()
    if reference == "final":
        return float(abs(np.mean(y[-max(1, y.size // 10):])))
    if reference == "span":
        lo, hi = np.percentile(y, [1.0, 99.0])
        return float(hi - lo)
    raise OptionError(f"NRMSE reference must be one of {', '.join(REFERENCES)} or a number, not {reference!r}")


def nrmse(
    measured: object,
    simulated: object,
    *,
    reference: Literal["final", "span"] | float = "final",
) -> float:
    """RMS of (measured − simulated) over the measured change of the response.

    Parameters
    ----------
    measured, simulated : array_like
        Equally long records [V].
    reference : {"final", "span"} or float
        How ``Δy`` is taken (:func:`response_change`): ``"final"`` for a step response from
        its baseline (docs/formats.md ``fit.velocity_nrmse``), ``"span"`` for other inputs, or
        ``Δy`` itself as a positive number.

    Returns
    -------
    float
        ``sqrt(mean((y − ŷ)²)) / Δy``; ``inf`` when the simulation overflowed (an unstable
        model).

    Raises
    ------
    OptionError
        On unequal lengths, an unknown reference, or ``Δy`` zero (the response never moved).
    """
    y, yhat = _pair(measured, simulated)
    if isinstance(reference, str):
        delta = response_change(y, reference)
    else:
        delta = float(reference)
        if not np.isfinite(delta) or delta <= 0:
            raise OptionError(f"NRMSE reference must be a positive number, got {reference!r}")
    if delta == 0.0:
        raise OptionError(f"the measured response has no change ({reference}); NRMSE is undefined")
    with np.errstate(over="ignore", invalid="ignore"):
        # one temporary of the record's length, squared in place (the same numbers as ``(y - yhat) ** 2``)
        residual = np.subtract(y, yhat)
    return _nrmse_of(residual, delta)


def _nrmse_of(residual: np.ndarray, delta: float) -> float:
    """:func:`nrmse` from a contiguous ``y − ŷ`` (squared in place) and ``Δy``."""
    with np.errstate(over="ignore", invalid="ignore"):
        np.square(residual, out=residual)
        value = float(np.sqrt(np.mean(residual)) / delta)
    return value if np.isfinite(value) else float("inf")


def fit_percent(measured: object, simulated: object) -> float:
    """MATLAB ``compare``'s fit: ``100·(1 − ‖y − ŷ‖ / ‖y − mean(y)‖)``.

    Parameters
    ----------
    measured, simulated : array_like
        Equally long records [V].

    Returns
    -------
    float
        Fit in percent (100 perfect, 0 as good as the mean, ``-inf`` for an overflowed
        simulation).

    Raises
    ------
    OptionError
        On unequal lengths or a constant measured record.

    References
    ----------
    MathWorks, ``compare`` (System Identification Toolbox), "NRMSE" fit:
    ``fit = 100·(1 − norm(y − ŷ)/norm(y − mean(y)))``.
    """
    y, yhat = _pair(measured, simulated)
    spread = _spread(y)
    with np.errstate(over="ignore", invalid="ignore"):
        return _fit_of(y - yhat, spread)


def _spread(y: np.ndarray) -> float:
    """``‖y − mean(y)‖``, the denominator of :func:`fit_percent` (refused when zero)."""
    spread = float(np.linalg.norm(y - y.mean()))
    if spread == 0.0:
        raise OptionError("the measured record is constant; fit % is undefined")
    return spread


def _fit_of(residual: np.ndarray, spread: float) -> float:
    """:func:`fit_percent` from ``y − ŷ`` and ``‖y − mean(y)‖``."""
    with np.errstate(over="ignore", invalid="ignore"):
        value = float(100.0 * (1.0 - np.linalg.norm(residual) / spread))
    return value if np.isfinite(value) else float("-inf")


def step_fit(
    measured: Mapping[str, np.ndarray],
    simulate: Callable[[slice], Mapping[str, np.ndarray]],
    nrmse_channels: Sequence[str],
) -> tuple[dict[str, float], dict[str, float]]:
    """:func:`nrmse` (``reference="final"``) and :func:`fit_percent` of a simulation, a block at a time.

    The same numbers as calling them one by one (to rounding: the sums are taken a block at a
    time), without an array of the record's length: the measured side (``Δy``, the fit's spread)
    is taken first, then the simulation is asked for one block of samples after another and each
    channel's sum of squared residuals accumulated (a 10 M-sample record's fit held a simulated
    record and its residual, 80 MB each).

    Parameters
    ----------
    measured : Mapping[str, ndarray]
        The measured channels (1-D, equally long) by name.
    simulate : callable
        ``simulate(block)`` returns the simulated channels by name at the samples ``block`` (a
        slice) of the record.
    nrmse_channels : sequence of str
        The channels whose NRMSE is wanted; each must be measured and simulated.

    Returns
    -------
    (dict, dict)
        NRMSE by channel (in the order of ``nrmse_channels``) and fit % of every measured channel
        the simulation has and whose record is not constant (in the order of ``measured``).

    Raises
    ------
    OptionError
        When a channel of ``nrmse_channels`` has no change (NRMSE undefined).
    """
    measured = {ch: np.asarray(y, dtype=float).ravel() for ch, y in measured.items()}  # (as _pair)
    deltas: dict[str, float] = {}
    for ch in nrmse_channels:
        deltas[ch] = response_change(measured[ch], "final")
        if deltas[ch] == 0.0:
            raise OptionError("the measured response has no change (final); NRMSE is undefined")
    spreads: dict[str, float] = {}
    for ch, y in measured.items():
        spread = math.sqrt(centred_sum_of_squares(y))  # ‖y − mean(y)‖ (_spread), a block at a time
        if spread != 0.0:  # a constant record has no fit %
            spreads[ch] = spread
    n = min((y.size for y in measured.values()), default=0)
    squares: dict[str, float] = {}
    for start in range(0, max(n, 1), BLOCK):
        block = slice(start, min(start + BLOCK, n))
        simulated = simulate(block)
        for ch, y in measured.items():
            if ch not in simulated or (ch not in spreads and ch not in deltas):
                continue
            with np.errstate(over="ignore", invalid="ignore"):
                residual = np.subtract(y[block], simulated[ch])
                squares[ch] = squares.get(ch, 0.0) + float(np.dot(residual, residual))
    errors: dict[str, float] = {}
    fits: dict[str, float] = {}
    with np.errstate(over="ignore", invalid="ignore"):
        for ch, ss in squares.items():
            if ch in spreads:
                fit = 100.0 * (1.0 - math.sqrt(ss) / spreads[ch]) if math.isfinite(ss) else float("-inf")
                fits[ch] = fit if math.isfinite(fit) else float("-inf")
            if ch in deltas:
                err = math.sqrt(ss / n) / deltas[ch] if math.isfinite(ss) else float("inf")
                errors[ch] = err if math.isfinite(err) else float("inf")
    return {ch: errors[ch] for ch in nrmse_channels}, fits


def bic(n_samples: Mapping[str, float], mse: Mapping[str, float], n_params: int) -> float:
    """The Bayesian information criterion of a least-squares fit with Gaussian errors.

    ``Σ_c n_c·log(MSE_c) + p·log(Σ_c n_c)``: each channel's own error variance estimated (its
    mean square residual), ``n_c`` its (effective) number of samples.  One channel of pooled,
    whitened residuals is the output-error fit's case; per-channel variances the Laguerre
    polish's; a normalised step-response error SRIVC's (the normalisation is a constant
    among the structures compared).  Smaller is better; differences matter, not the value.

    Parameters
    ----------
    n_samples : Mapping[str, float]
        Samples of each channel (effective: ``n/inflation`` for correlated residuals).
    mse : Mapping[str, float]
        Mean square residual of each channel (same keys); floored at 1e-300.
    n_params : int
        Fitted parameters.

    Returns
    -------
    float

    Examples
    --------
    >>> round(bic({"velocity": 100}, {"velocity": 0.01}, 3), 3)
    -446.702
    """
    return float(sum(n_samples[c] * math.log(max(mse[c], 1e-300)) for c in n_samples)
                 + n_params * math.log(sum(n_samples.values())))

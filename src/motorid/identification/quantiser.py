"""The error an 8-bit quantiser leaves in a fit: its sawtooth, at an unknown place on the code grid.

A quantiser of step ``q`` returns, for a signal ``s`` plus a dither, samples whose mean is off
by ``e(s) = Σₖ (−1)ᵏ⁺¹ (q/πk)·φₖ·sin(2πks/q)``: the sawtooth error's Fourier series, each
harmonic smoothed by the dither's characteristic function ``φₖ``.  That error does not average
out over samples: it follows the signal.  Where the signal moves slowly (a level, a response's
tail) it is the same on every sample; where it sweeps many codes it changes from sample to
sample.  A fit that treats it as independent noise (``q²/12`` per sample) is too sure of the
gain, of the time constant and of where the response settles.

Where the signal sits on the code grid (its offset against the codes) is not known, so each
harmonic's phase is uniform: ``e(s) = Σₖ aₖ·cos(2πks/q) + bₖ·sin(2πks/q)`` with ``aₖ, bₖ``
independent, of variance ``(q/πk)²·φₖ²/2``.  A least-squares fit moves its parameters by
``G·e`` (``G = (JᵀJ)⁻¹Jᵀ``), so the quantiser adds ``Σₖ vₖ·(G cₖ)(G cₖ)ᵀ + vₖ·(G sₖ)(G sₖ)ᵀ`` to the
parameter covariance, with ``cₖ, sₖ`` the cosine and sine of the fitted signal on the fit's rows.
For a level (``s`` constant) it is the level's error that
:func:`~motorid.identification.stages.quantisation_bias_std` gives.

The dither: Gaussian noise makes ``φ`` vanish once ``σ`` passes ``q/2``; a periodic ripple (a
tacho's) only like ``√(q/A)`` (``φ = J₀(2πkA/q)`` for a sinusoid of amplitude ``A``, whose square
averages ``q/(2π²kA)`` over its oscillation).  The samples do not tell the two apart, so the
ripple's is used (the larger), with ``A = √2·σ``.

Written here because no library states the parameter covariance of a fit to quantised data.
"""

from __future__ import annotations

import numpy as np

__all__ = ["QUANTISER_CLAUSE", "QUANTISER_HARMONICS", "harmonic_variances", "sawtooth_basis"]

#: How the intervals' method (:attr:`~motorid.model.uncertainty.Uncertainty.method`) names the quantiser's
#: error along the record; the channels follow in parentheses.
QUANTISER_CLAUSE = "with the quantiser's error along the record"

#: Harmonics of the sawtooth kept in a fit's covariance: the first twelve hold 95 % of the sum for
#: an undithered signal (the variances fall as ``1/k²``) and over 99 % with a ripple's dither (``1/k³``).
QUANTISER_HARMONICS = 12


def harmonic_variances(quantum: float, dither_rms: float, count: int = QUANTISER_HARMONICS) -> np.ndarray:
    """Variance of each harmonic's amplitude (``aₖ`` and ``bₖ`` alike) of a quantiser's error.

    Parameters
    ----------
    quantum : float
        The quantiser's step ``q`` (one code), in the signal's unit.
    dither_rms : float
        RMS of what dithers the signal (its noise and ripple, without the quantiser's own
        ``q²/12``), in the same unit; 0 for an undithered signal.
    count : int
        Harmonics.

    Returns
    -------
    ndarray
        ``(q/πk)²·φₖ²/2`` for ``k = 1 … count``, with the ripple's ``φₖ² = min(1, q/(2π²kA))``,
        ``A = √2·dither_rms``; empty for a step ``q ≤ 0``.  Their sum over all ``k`` is ``q²/12``
        for an undithered signal.
    """
    if not quantum > 0.0:
        return np.zeros(0)
    k = np.arange(1, count + 1, dtype=float)
    amplitude = np.sqrt(2.0) * max(float(dither_rms), 0.0)
    smooth2 = np.minimum(1.0, quantum / (2.0 * np.pi**2 * k * amplitude)) if amplitude > 0 else np.ones_like(k)
    return (quantum / (np.pi * k)) ** 2 * smooth2 / 2.0


def sawtooth_basis(signal: np.ndarray, quantum: float, count: int = QUANTISER_HARMONICS) -> np.ndarray:
    """The cosines and sines of each harmonic of the code grid along a signal.

    Parameters
    ----------
    signal : ndarray
        The signal as fitted (its offset against the codes does not matter: the phases are free).
    quantum : float
        The quantiser's step, > 0.
    count : int
        Harmonics.

    Returns
    -------
    ndarray
        ``(len(signal), 2·count)``: ``cos(2πks/q)`` and ``sin(2πks/q)`` for ``k = 1 … count``, in
        that order (harmonic ``k`` in columns ``2(k−1)`` and ``2k − 1``).
    """
    s = np.asarray(signal, dtype=float)
    # the harmonics as powers of the first (e^(iθ))^k: one complex exponential per sample, not 2·count
    z = np.exp(2j * np.pi * np.mod(s / quantum, 1.0))
    powers = np.cumprod(np.broadcast_to(z[:, None], (s.size, count)), axis=1)
    out = np.empty((s.size, 2 * count))
    out[:, 0::2] = powers.real
    out[:, 1::2] = powers.imag
    return out

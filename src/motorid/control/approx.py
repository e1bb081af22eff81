"""Second-order approximations of a closed loop (Masoud 2019, section II, eqs. 4–6)."""

from __future__ import annotations

import control
import numpy as np

from motorid.errors import OptionError

__all__ = ["dominant_second_order"]


def dominant_second_order(sys: control.TransferFunction) -> control.TransferFunction:
    """Keep the two slowest poles of a stable SISO transfer function, same DC gain.

    Parameters
    ----------
    sys : control.TransferFunction
        Stable, at least second order, non-zero DC gain.

    Returns
    -------
    control.TransferFunction
        ``g·(s − p1)(s − p2)``-denominator approximation ``b0/(s² + a1 s + a0)`` with ``b0``
        chosen so that the DC gain is unchanged.

    Raises
    ------
    OptionError
        For an unstable or first-order system, or a zero DC gain.

    References
    ----------
    Masoud 2019, eq. 6: the exact 3rd-order loop approximated after closing it
    (``4.761/(s² + 0.499 s + 4.761)``; the paper rounds to 4.762 and 0.5).
    """
    poles = np.asarray(control.poles(sys), dtype=complex)
    if poles.size < 2:
        raise OptionError("a dominant second-order approximation needs at least two poles")
    if np.any(poles.real >= 0):
        raise OptionError("the system is not stable; dominant poles are undefined")
    dc = float(np.real(control.dcgain(sys)))
    if dc == 0.0 or not np.isfinite(dc):
        raise OptionError("the system has zero or infinite DC gain")
    keep = poles[np.argsort(np.abs(poles.real))][:2]
    den = np.real(np.poly(keep))
    return control.tf([dc * den[-1]], den)

"""The lab report's motor model built from physical or step-test parameters.

States ``x1 = θ`` (position-sensor volts) and ``x2 = V_tacho`` (tachogenerator volts); input
``u`` (amplifier volts).  Speeds are in rpm as in the report, so ``km`` is rpm/V, ``kT`` V/rpm
and ``k0`` position volts per (output rpm · s).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from motorid.errors import OptionError
from motorid.model import MotorModel

__all__ = ["MotorParams", "model_from_params", "params_from_step_test", "parse_ratio"]


@dataclass(frozen=True, slots=True)
class MotorParams:
    """Physical constants of the lab report's motor (Tsiolakis 2022, §1.1).

    Attributes
    ----------
    km : float
        Motor gain, rpm per input volt (eq. 19).
    kT : float
        Tachogenerator gain, volts per rpm (eq. 17).
    gear : float
        Reducer ratio kμ = output angle / motor angle (eq. 8), e.g. 1/36.
    k0 : float
        Position sensor gain, volts per (output rpm · s) (eq. 18).
    Tm_s : float
        Mechanical time constant, s (eq. 7).
    """

    km: float
    kT: float
    gear: float
    k0: float
    Tm_s: float

    def __post_init__(self) -> None:
        for name in ("km", "kT", "gear", "k0", "Tm_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                opt = "--Tm" if name == "Tm_s" else f"--{name}"
                raise OptionError(f"{opt} must be a finite number > 0, got {value!r}")


def parse_ratio(text: str, option: str = "--gear") -> float:
    """Parse ``"1/36"``, ``"0.0278"`` or ``"36:1"``-free plain numbers as a float.

    Parameters
    ----------
    text : str
        The ratio as typed.
    option : str
        The option it came from, named in the error (default ``--gear``).

    Returns
    -------
    float
        The ratio.

    Raises
    ------
    OptionError
        If the text is not a number or a fraction ``a/b`` with ``b != 0``.
    """
    s = str(text).strip()
    try:
        if "/" in s:
            a, b = s.split("/", 1)
            value = float(a) / float(b)
        else:
            value = float(s)
    except (ValueError, ZeroDivisionError):
        raise OptionError(f"{option} must be a number or a fraction like 1/36, got {text!r}") from None
    if not math.isfinite(value):
        raise OptionError(f"{option} must be finite, got {text!r}")
    return value


def params_from_step_test(
    *, v_tacho_ss: float, u_step: float, Tm_s: float, delta_theta_v: float, delta_t_s: float, gear: float
) -> MotorParams:
    """The report's parameter calculation from its step-test measurements.

    Parameters
    ----------
    v_tacho_ss : float
        Steady-state tachogenerator volts for the step (eq. 2).
    u_step : float
        Step input volts (eq. 1).
    Tm_s : float
        Time to 63.2 % of ``v_tacho_ss`` (eq. 7).
    delta_theta_v, delta_t_s : float
        Height and period of one tooth of the position sawtooth (one output turn, eqs. 11–12).
    gear : float
        Reducer ratio kμ (eq. 8).

    Returns
    -------
    MotorParams
        ``km·kT = V/U`` (eq. 4), ``ω_out = 60/Δt`` rpm (eq. 14), ``ω = ω_out/kμ`` (eq. 15),
        ``kT = V/ω`` (eq. 17), ``k0 = Δθ/(kμ ω Δt)`` (eq. 18), ``km = (km kT)/kT`` (eq. 19).

    Raises
    ------
    OptionError
        For non-positive or non-finite quantities.

    References
    ----------
    Tsiolakis 2022, eqs. 1–19.
    """
    named = {"--v-tacho-ss": v_tacho_ss, "--u-step": u_step, "--Tm": Tm_s, "--delta-theta": delta_theta_v,
             "--delta-t": delta_t_s, "--gear": gear}
    for opt, value in named.items():
        if not (math.isfinite(float(value)) and float(value) > 0):
            raise OptionError(f"{opt} must be a finite number > 0, got {value!r}")
    kmkT = v_tacho_ss / u_step
    omega_out_rpm = 60.0 / delta_t_s
    omega_rpm = omega_out_rpm / gear
    kT = v_tacho_ss / omega_rpm
    k0 = delta_theta_v / (gear * omega_rpm * delta_t_s)
    return MotorParams(km=kmkT / kT, kT=kT, gear=gear, k0=k0, Tm_s=Tm_s)


def model_from_params(params: MotorParams) -> MotorModel:
    """State equations of the lab report (x1 = θ volts, x2 = tacho volts).

    Parameters
    ----------
    params : MotorParams

    Returns
    -------
    MotorModel
        ``A = [[0, kμk0/kT], [0, −1/Tm]]``, ``B = [0, kT km/Tm]ᵀ``, outputs position
        (``C = [1 0]``, eq. 29) and velocity (tacho volts, ``[0 1]``).

    References
    ----------
    Tsiolakis 2022, eqs. 24–29.
    """
    p = params
    a = np.array([[0.0, p.gear * p.k0 / p.kT], [0.0, -1.0 / p.Tm_s]])
    b = np.array([[0.0], [p.kT * p.km / p.Tm_s]])
    return MotorModel(
        A=a, B=b, C=np.eye(2), D=np.zeros((2, 1)), states=("position", "velocity"),
        outputs=("position", "velocity"), method="from-params",
        settings={"km": p.km, "kT": p.kT, "gear": p.gear, "k0": p.k0, "Tm": p.Tm_s},
    )

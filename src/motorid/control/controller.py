"""A design's controller as one linear system: the signals it reads in, the motor's command out.

:class:`~motorid.control.design.Design` holds gains; a microcontroller runs a system.  This
module writes the controller the design stands for as a python-control ``StateSpace`` with
named signals, the same equations :mod:`.margins` closes the loop with:

- without an observer the controller reads every state it feeds back (by the design's state
  names: ``position``, ``velocity``, …) and ``u = −K x + kr r``;
- with integral action ``ż = y − r`` (``y = C x``, the measured channel) and ``u = −K x − ki z``;
- with an observer it reads the reference and the measured output only; the estimate follows
  ``x̂' = A x̂ + B u + L (y − C x̂)``, fed the controller's own command, and ``u = −K x̂ + kr r``
  (``u = −K x̂ − ki z`` with integral action);
- with a reduced-order observer (:mod:`.reduced_observer`) it reads the reference and the
  sensors; ``ẇ = F w + G z_m + H u`` estimates the other states as ``w + L z_m`` and
  ``u = −K_m z_m − K_u ẑ_u + kr r`` (``− ki z``).

Any controller given in this form (inputs ``r`` then measured signals, output ``u``) can be
discretised and emitted as code by :mod:`.emit`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np

from motorid.control.coordinates import SENSORS
from motorid.model.units import channel_unit

if TYPE_CHECKING:
    import control

    from motorid.control.design import Design
    from motorid.model import MotorModel

__all__ = ["COMMAND", "REFERENCE", "controller_system", "integrator_holds", "loop_parts", "signal_unit"]

#: The controller's output: the motor's command (amplifier input).
COMMAND = "u"
#: The controller's first input: the reference of the measured channel.
REFERENCE = "r"


def integrator_holds(u_raw: float, rails: float, push: float) -> bool:
    """Conditional integration: whether the integrator holds this sample (the simulation's and the emitted code's rule).

    Parameters
    ----------
    u_raw : float
        The command asked for (before the rails).
    rails : float
        The rails ``±rails``.
    push : float
        How the integrator's increment would move the command (its gain on the command × the increment).

    Returns
    -------
    bool
        True while the command is beyond a rail and the increment would push it further.
    """
    return (u_raw > rails and push > 0) or (u_raw < -rails and push < 0)


def signal_unit(name: str, units: Mapping[str, str] | None = None, *, output: str | None = None) -> str:
    """The unit of one controller signal (``rpm`` for a velocity logged in rpm, ``V`` by default).

    Parameters
    ----------
    name : str
        ``u``, ``r``, a channel (``position``, ``velocity``, ``current``) or a derivative of the
        velocity (``acceleration``, ``jerk``).
    units : Mapping[str, str], optional
        The model's channel units (``{"velocity": "rpm"}``; ``input`` for the command).
    output : str, optional
        The measured channel: the reference is in its unit.

    Returns
    -------
    str
        E.g. ``V``, ``rpm``, ``rpm/s``; ``""`` for a state without a physical unit (``x1``).
    """
    units = units or {}
    if name == COMMAND:
        return channel_unit(units, "input")
    if name == REFERENCE:
        return signal_unit(output, units) if output else "V"
    if name in SENSORS:
        channel, _, order = SENSORS[name]
        return channel_unit(units, channel) + ("", "/s", "/s²")[order]
    if name.startswith("velocity_d"):
        return f"{channel_unit(units, 'velocity')}/s^{name[len('velocity_d'):]}"
    return ""


def loop_parts(model: MotorModel, design: Design) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                                                             float | None, float]:
    """What a design's controller is built from: the motor in its coordinates and the gains.

    Parameters
    ----------
    model : MotorModel
        The model the design was made for (re-expressed with
        :func:`~motorid.control.design.design_model`).
    design : Design

    Returns
    -------
    (ndarray, ndarray, ndarray, ndarray, float or None, float)
        ``A``, ``B`` (column), the measured channel's row ``C``, the gain row ``K``, ``ki`` and
        ``kr`` (0 with integral action, which has none).
    """
    from motorid.control.design import design_model, output_row

    work = design_model(model, design)
    a = np.asarray(work.A, dtype=float)
    b = np.asarray(work.B, dtype=float).reshape(-1, 1)
    c = np.asarray(output_row(work, design.output)[1], dtype=float).reshape(1, -1)
    k = np.asarray(design.K, dtype=float).reshape(1, a.shape[0])
    ki = design.ki
    kr = float(design.kr) if ki is None and design.kr is not None else 0.0
    return a, b, c, k, ki, kr


def controller_system(model: MotorModel, design: Design) -> control.StateSpace:
    """The controller of ``design`` as a continuous-time system with named signals.

    Parameters
    ----------
    model : MotorModel
        The model the design was made for (any realisation; re-expressed in the design's
        coordinates with :func:`~motorid.control.design.design_model`).
    design : Design
        State feedback, with integral action and an observer when it has them.

    Returns
    -------
    control.StateSpace
        Inputs ``r`` then, without an observer, the design's states (``position``,
        ``velocity``, …), with one the measured channel (``design.output``), with a
        reduced-order one the sensors; output ``u``; states ``x̂_<state>`` (the estimate) or
        ``w_<state>`` (the reduced observer's), and ``z`` (the integrator), in that order; none
        for plain state feedback (a static gain).

    Raises
    ------
    OptionError
        When the design was made for a model with other states.

    References
    ----------
    Tsiolakis 2022, eqs. 30 (state feedback), 37 (``kr``), 38–41 (integral action), 49–58 (observer).
    """
    import control

    a, b, c, k, ki, kr = loop_parts(model, design)
    n = a.shape[0]
    observer = design.L is not None
    if design.reduced is not None:
        from motorid.control.reduced_observer import command_rows

        red = design.reduced
        kz, kw, _ = command_rows(k, ki, red, tuple(design.states))
        nm, nu = len(red.measured), red.F.shape[0]
        # ẇ = F w + G z_m + H u with u = Kz z_m + Kw w (+ kr r | − ki z)
        a_c = red.F + red.H @ kw
        b_c = np.hstack([red.H * kr, red.G + red.H @ kz])
        c_c = kw
        d_c = np.hstack([[[kr]], kz])
        inputs = [REFERENCE, *red.measured]
        states = [f"w_{s}" for s in red.estimated]
        if ki is not None:
            # ż = y − r, y a measured state; the command's −ki z enters w through H u
            y_row = np.zeros((1, nm))
            y_row[0, list(red.measured).index(design.output)] = 1.0
            a_c = np.block([[a_c, -red.H * ki], [np.zeros((1, nu)), np.zeros((1, 1))]])
            b_c = np.vstack([b_c, np.hstack([[[-1.0]], y_row])])
            c_c = np.hstack([c_c, [[-ki]]])
            states.append("z")
        return control.ss(a_c, b_c, c_c, d_c, inputs=inputs, outputs=[COMMAND], states=states,
                          name="controller")
    if observer:
        l_col = np.asarray(design.L, dtype=float).reshape(n, 1)
        # x̂' = A x̂ + B u + L (y − C x̂) with u = −K x̂ (+ kr r | − ki z)
        a_c = a - b @ k - l_col @ c
        b_c = np.hstack([b * kr, l_col])
        c_c = -k
        d_c = np.array([[kr, 0.0]])
        inputs = [REFERENCE, design.output]
        states = [f"x̂_{s}" for s in design.states]
        if ki is not None:
            # ż = y − r, and the command's −ki z enters the estimate through B u
            a_c = np.block([[a_c, -b * ki], [np.zeros((1, n)), np.zeros((1, 1))]])
            b_c = np.vstack([b_c, [[-1.0, 1.0]]])
            c_c = np.hstack([c_c, [[-ki]]])
            states.append("z")
    else:
        inputs = [REFERENCE, *design.states]
        if ki is None:
            a_c = np.zeros((0, 0))
            b_c = np.zeros((0, n + 1))
            c_c = np.zeros((1, 0))
            d_c = np.hstack([[[kr]], -k])
            states = []
        else:
            # ż = C x − r; u = −K x − ki z
            a_c = np.zeros((1, 1))
            b_c = np.hstack([[[-1.0]], c])
            c_c = np.array([[-ki]])
            d_c = np.hstack([[[0.0]], -k])
            states = ["z"]
    return control.ss(a_c, b_c, c_c, d_c, inputs=inputs, outputs=[COMMAND], states=states or None,
                      name="controller")

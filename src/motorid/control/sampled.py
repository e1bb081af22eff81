"""A design's observer for a controller that runs every ``TS``: placed on the motor as the controller sees it.

A microcontroller reads its sensors every ``TS`` and holds its command between samples (a DAC,
a PWM duty cycle): it sees the motor behind a zero-order hold, ``x[k+1] = Φ x[k] + Γ u[k]``
with ``Φ = e^{A·TS}`` and ``Γ`` exact (:func:`motorid.model.lti.zoh`).  Sampling the continuous
observer instead (python-control's ``c2d`` of the whole controller) holds the *measured*
signals over each interval too, as if they were commands; they are not, and the observer's
large gains turn that hold into an estimate biased by about ``L·TS/2`` times the signals' rate.
With a reduced-order observer of a velocity's derivatives that bias is of the order of the
estimate itself: on a third-order model of the HSLU rig (observer poles −400 and −460 rad/s,
``TS`` = 1 ms) the acceleration came out 1.46 times too large and the loop rose 5 times slower
than its design (0.85 s instead of 0.17 s), and still 40 % slower at ``TS`` = 0.1 ms.

Placed on ``(Φ, Γ)`` with the design's observer poles mapped to ``e^{p·TS}``, the estimate's
error obeys ``e[k+1] = F e[k]`` whatever the motor does: it decays at the design's observer
poles at every sample, and is zero from a motor at rest.  The state-feedback gains and the
integrator are the design's (the sampled loop departs from the design by ``TS·|p|`` of its
poles only, :data:`motorid.control.emit.SAMPLING_RULE`).

- :func:`sampled_observer`: the full-order (Luenberger) observer, predictive form
  ``x̂[k+1] = (Φ − L C) x̂[k] + Γ u[k] + L y[k]``;
- :func:`sampled_reduced_observer`: the reduced-order observer in the same form as the
  continuous one (``w[k+1] = F w[k] + G z_m[k] + H u[k]``, ``ẑ_u = w + L z_m``), the estimate
  using the sample just read;
- :func:`sampled_controller_parts`: the whole controller of a design with an observer as a
  discrete-time system, with the signals of :func:`motorid.control.controller.controller_system`,
  and the column by which its command enters its states (for a controller with rails).

References
----------
Franklin, Powell & Workman, *Digital Control of Dynamic Systems*, 3rd ed. (1998), §8.2
(prediction and reduced-order estimators for the sampled plant).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from motorid.control.controller import COMMAND, REFERENCE, loop_parts
from motorid.control.feedback import place_gains
from motorid.control.reduced_observer import ReducedObserver, command_rows, placed_observer
from motorid.model.lti import zoh

if TYPE_CHECKING:
    import control

    from motorid.control.design import Design
    from motorid.model import MotorModel

__all__ = ["design_observer_poles", "sampled_controller_parts", "sampled_observer", "sampled_reduced_observer"]


def design_observer_poles(design: Design, a: np.ndarray, c: np.ndarray) -> np.ndarray:
    """A full-order observer's poles: the design's, or ``eig(A − L C)`` when it does not carry them.

    Parameters
    ----------
    design : Design
        A design with a full-order observer (``design.L``).
    a : ndarray
        The motor's ``A`` in the design's coordinates.
    c : ndarray
        The measured channel's row.

    Returns
    -------
    ndarray
        Complex poles.
    """
    if design.observer_poles is not None:
        return np.asarray(design.observer_poles, dtype=complex).ravel()
    l_col = np.asarray(design.L, dtype=float).reshape(-1, 1)
    return np.linalg.eigvals(np.asarray(a, float) - l_col @ np.asarray(c, float).reshape(1, -1))


def sampled_observer(a: np.ndarray, b: np.ndarray, c: np.ndarray, poles: np.ndarray, ts: float
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The full-order observer of a controller sampled every ``ts``: ``x̂[k+1] = Φo x̂[k] + Γo [u[k], y[k]]``.

    Parameters
    ----------
    a, b : ndarray
        The motor in the design's coordinates (``A``, ``B``).
    c : ndarray, shape (1, n)
        The measured channel's row.
    poles : ndarray
        The design's (continuous) observer poles; the sampled observer's are ``e^{p·ts}``.
    ts : float
        The control interval, s.

    Returns
    -------
    (ndarray, ndarray)
        ``Φo = Φ − L C`` and ``Γo = [Γ, L]`` (columns on ``u`` then ``y``).
    """
    phi, gam = zoh(np.asarray(a, float), np.asarray(b, float).reshape(-1, 1), ts)
    c = np.asarray(c, float).reshape(1, -1)
    gain = place_gains(phi.T, c.T, np.exp(np.asarray(poles, dtype=complex) * ts)).T
    return phi - gain @ c, np.hstack([gam, gain])


def sampled_reduced_observer(a: np.ndarray, b: np.ndarray, obs: ReducedObserver, states: tuple[str, ...],
                             ts: float) -> ReducedObserver:
    """The reduced-order observer of the same states for a controller sampled every ``ts``.

    Parameters
    ----------
    a, b : ndarray
        The motor in the design's coordinates.
    obs : ReducedObserver
        The design's (continuous) observer: which states are measured, and its poles.
    states : tuple of str
        The design's states.
    ts : float
        The control interval, s.

    Returns
    -------
    ReducedObserver
        ``F``, ``G``, ``H``, ``L`` of ``w[k+1] = F w[k] + G z_m[k] + H u[k]``, ``ẑ_u = w + L z_m``;
        ``poles`` are ``e^{p·ts}``.
    """
    phi, gam = zoh(np.asarray(a, float), np.asarray(b, float).reshape(-1, 1), ts)
    return placed_observer(phi, gam, states, obs.measured, np.exp(np.asarray(obs.poles, dtype=complex) * ts))


def sampled_controller_parts(model: MotorModel, design: Design, ts: float,
                             ) -> tuple[control.StateSpace, np.ndarray]:
    """The controller of a design with an observer, run every ``ts``, and how the command enters its states.

    Its inputs, output and states are :func:`~motorid.control.controller.controller_system`'s;
    the observer is :func:`sampled_observer` or :func:`sampled_reduced_observer`, the command
    ``u = −K x̂ + kr r`` (``− ki z``) computed from the latest estimate and held until the next
    sample, the integrator ``z[k+1] = z[k] + ts·(y[k] − r[k])``.

    Parameters
    ----------
    model : MotorModel
        The model the design was made for.
    design : Design
        A design with an observer (``design.L`` or ``design.reduced``).
    ts : float
        The control interval, s.

    Returns
    -------
    (control.StateSpace, ndarray)
        The discrete-time system (``dt = ts``), and the column by which the command enters its
        next state (the observer's ``H`` or ``Γ``, 0 for the integrator): the system is the
        controller with ``u`` fed back through that column, which a controller with actuator
        rails feeds the clamped command instead.

    Raises
    ------
    ValueError
        For a design without an observer (python-control's ``c2d`` samples a static gain exactly).
    """
    import control

    a, b, c, k, ki, kr = loop_parts(model, design)
    n = a.shape[0]
    states_ = tuple(design.states)
    if design.reduced is not None:
        red = sampled_reduced_observer(a, b, design.reduced, states_, ts)
        kz, kw, _ = command_rows(k, ki, red, states_)
        nm, nu = len(red.measured), red.F.shape[0]
        a_d = red.F + red.H @ kw
        b_d = np.hstack([red.H * kr, red.G + red.H @ kz])
        c_d, d_d = kw, np.hstack([[[kr]], kz])
        inputs = [REFERENCE, *red.measured]
        names = [f"w_{s}" for s in red.estimated]
        y_row = np.zeros((1, nm))
        h_ki = red.H * (ki or 0.0)
        column = np.asarray(red.H, dtype=float).ravel()
        if ki is not None:
            y_row[0, list(red.measured).index(design.output)] = 1.0
    elif design.L is not None:
        phi_o, gam_o = sampled_observer(a, b, c, design_observer_poles(design, a, c), ts)
        g, gain = gam_o[:, :1], gam_o[:, 1:]
        nu = n
        a_d = phi_o - g @ k
        b_d = np.hstack([g * kr, gain])
        c_d, d_d = -k, np.array([[kr, 0.0]])
        inputs = [REFERENCE, design.output]
        names = [f"x̂_{s}" for s in design.states]
        y_row = np.ones((1, 1))
        h_ki = g * (ki or 0.0)
        column = np.asarray(g, dtype=float).ravel()
    else:
        raise ValueError("sampled_controller_parts is for a design with an observer")
    if ki is not None:
        # z[k+1] = z[k] + ts·(y[k] − r[k]); the command's −ki z reaches the estimate through its u
        a_d = np.block([[a_d, -h_ki], [np.zeros((1, nu)), np.ones((1, 1))]])
        b_d = np.vstack([b_d, np.hstack([[[-ts]], ts * y_row])])
        c_d = np.hstack([c_d, [[-ki]]])
        names.append("z")
        column = np.r_[column, 0.0]
    return control.ss(a_d, b_d, c_d, d_d, float(ts), inputs=inputs, outputs=[COMMAND], states=names,
                      name="controller"), column

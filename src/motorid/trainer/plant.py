"""Nonlinear simulation of the servo: amplifier → armature circuit → shaft → gearbox.

Written by hand because no library simulator handles stick-slip friction, a dead-zone and
rail saturation at this speed: python-control's ``input_output_response`` integrates a
Python right-hand side with ``solve_ivp`` (milliseconds per step with friction switching).
Here the linear electro-mechanical part is discretised exactly once (``scipy.linalg.expm``
of the augmented matrix) and only the nonlinearities are evaluated per sub-step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from motorid.errors import OptionError
from motorid.model.lti import zoh
from motorid.trainer.presets import TrainerConfig

__all__ = ["PlantResponse", "simulate_plant"]


@dataclass(frozen=True, slots=True)
class PlantResponse:
    """Physical signals at the sample instants.

    Attributes
    ----------
    time_s : ndarray
        Sample times.
    amp_out_v : ndarray
        Armature voltage (after dead-zone, lead/lag and rails).
    current_a : ndarray
        Armature current.
    motor_speed_rad_s : ndarray
        Motor shaft speed.
    motor_angle_rad : ndarray
        Motor shaft angle.
    output_angle_rad : ndarray
        Output-shaft angle (after the gearbox).
    """

    time_s: np.ndarray
    amp_out_v: np.ndarray
    current_a: np.ndarray
    motor_speed_rad_s: np.ndarray
    motor_angle_rad: np.ndarray
    output_angle_rad: np.ndarray


def _zoh(a: np.ndarray, b: np.ndarray, h: float) -> tuple[list[list[float]], list[list[float]]]:
    """Exact ZOH discretisation (``expm`` of the augmented matrix) as nested Python lists.

    Lists, not arrays: the sub-step loop reads scalars, and list indexing is several times
    faster than numpy scalar indexing there.
    """
    phi, gamma = zoh(a, b, h)
    return phi.tolist(), gamma.tolist()


def simulate_plant(
    config: TrainerConfig,
    time_s: np.ndarray,
    input_v: np.ndarray,
    *,
    substeps: int | None = None,
    initial: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> PlantResponse:
    """Simulate the trainer for an input held constant over each sample (ZOH).

    Parameters
    ----------
    config : TrainerConfig
        The trainer.
    time_s : ndarray
        Uniform sample times (at least 2).
    input_v : ndarray
        Input voltage at each sample (held until the next).
    substeps : int, optional
        Integration sub-steps per sample (default ``config.substeps``).  The linear part is
        exact at any step; sub-steps resolve the friction switching, the rails and the
        amplifier lead/lag.
    initial : (float, float, float)
        Armature current (A), motor speed (rad/s) and motor angle (rad) at ``time_s[0]``;
        the default is the motor at rest.

    Returns
    -------
    PlantResponse
        States at each sample instant.

    Raises
    ------
    OptionError
        For a time axis that is not uniform and increasing, or mismatched lengths.
    """
    c = config
    t = np.asarray(time_s, dtype=float)
    u = np.asarray(input_v, dtype=float)
    if t.ndim != 1 or t.size < 2 or u.shape != t.shape:
        raise OptionError("simulate_plant: time_s and input_v must be 1-D, same length, >= 2 samples")
    dt = float(t[1] - t[0])
    if not dt > 0 or not np.allclose(np.diff(t), dt, rtol=1e-6, atol=0.0):
        raise OptionError("simulate_plant: time_s must be uniformly increasing")
    if not np.all(np.isfinite(u)):
        raise OptionError("simulate_plant: input_v has NaN or inf")
    nsub = c.substeps if substeps is None else int(substeps)
    if nsub < 1:
        raise OptionError(f"simulate_plant: substeps must be >= 1, got {substeps!r}")
    h = dt / nsub
    lead_lag = c.amp_lag_s > 0
    ratio = c.amp_lead_s / c.amp_lag_s if lead_lag else 1.0
    kt, dz, rail, gain = c.k_motor, c.amp_dead_zone_v, c.amp_rail_v, c.amp_gain
    # linear part, states [i, ω, φ, f] (f: the lead/lag's lag state), inputs [x, load torque]
    # with x the amplifier input after the dead-zone; armature volts v = gain·(r·x + (1−r)·f)
    # for the lead/lag (1 + lead·s)/(1 + lag·s), r = lead/lag.  Discretised exactly (ZOH) once;
    # a second set with v itself as the input serves sub-steps where the rails clip v.
    a4 = np.zeros((4, 4))
    a4[0, :2] = -c.ra_ohm / c.la_h, -c.k_motor / c.la_h
    a4[1, :2] = c.k_motor / c.j_kgm2, -c.b_nms / c.j_kgm2
    a4[2, 1] = 1.0
    b4 = np.zeros((4, 2))
    b4[0, 0] = gain * ratio / c.la_h
    b4[1, 1] = -1.0 / c.j_kgm2
    if lead_lag:
        a4[0, 3] = gain * (1.0 - ratio) / c.la_h
        a4[3, 3] = -1.0 / c.amp_lag_s
        b4[3, 0] = 1.0 / c.amp_lag_s
    p4, g4 = _zoh(a4, b4, h)
    b3 = np.zeros((3, 2))
    b3[0, 0] = 1.0 / c.la_h
    b3[1, 1] = -1.0 / c.j_kgm2
    p3, g3 = _zoh(a4[:3, :3], b3, h)
    alpha = 1.0 - float(np.exp(-h / c.amp_lag_s)) if lead_lag else 0.0
    tc, ts, brake = c.coulomb_nm, c.static_nm, c.brake_nm
    e_stuck = float(np.exp(-c.ra_ohm * h / c.la_h))
    g_stuck = (1.0 - e_stuck) / c.ra_ohm
    # speed below which the shaft may stick: the change one sub-step of static torque makes
    w_stick = ts * h / c.j_kgm2
    n = t.size
    out_v = np.empty(n)
    out_i = np.empty(n)
    out_w = np.empty(n)
    out_phi = np.empty(n)
    i, w, ang = (float(x) for x in initial)
    f = 0.0
    for k in range(n):
        x = float(u[k])
        x = x - dz if x > dz else (x + dz if x < -dz else 0.0)
        v0 = gain * (ratio * x + (1.0 - ratio) * f)
        out_v[k] = rail if v0 > rail else (-rail if v0 < -rail else v0)
        out_i[k], out_w[k], out_phi[k] = i, w, ang
        for _ in range(nsub):
            f1 = f + alpha * (x - f)
            v0 = gain * (ratio * x + (1.0 - ratio) * f)
            v1 = gain * (ratio * x + (1.0 - ratio) * f1)
            clipped = abs(v0) > rail or abs(v1) > rail
            if clipped:
                vm = 0.5 * (v0 + v1)
                v = rail if vm > rail else (-rail if vm < -rail else vm)
            else:
                v = v0
            drive = kt * i
            if abs(w) <= w_stick and abs(drive) < ts + brake:
                # stuck (stick-slip): static friction and the brake hold the shaft, only the
                # armature circuit moves, La di/dt = v − Ra i (exact over the sub-step)
                i = e_stuck * i + g_stuck * v
                w = 0.0
                f = f1
                continue
            # sliding: Coulomb friction and the brake oppose the motion (or, when breaking
            # away from rest, the drive torque)
            sgn = (1.0 if w > 0 else -1.0) if abs(w) > w_stick else (1.0 if drive > 0 else -1.0)
            load = sgn * (tc + brake)
            if clipped:
                i, w, ang = (
                    p3[0][0] * i + p3[0][1] * w + g3[0][0] * v + g3[0][1] * load,
                    p3[1][0] * i + p3[1][1] * w + g3[1][0] * v + g3[1][1] * load,
                    p3[2][0] * i + p3[2][1] * w + p3[2][2] * ang + g3[2][0] * v + g3[2][1] * load,
                )
            else:
                i, w, ang = (
                    p4[0][0] * i + p4[0][1] * w + p4[0][3] * f + g4[0][0] * x + g4[0][1] * load,
                    p4[1][0] * i + p4[1][1] * w + p4[1][3] * f + g4[1][0] * x + g4[1][1] * load,
                    p4[2][0] * i + p4[2][1] * w + ang + p4[2][3] * f + g4[2][0] * x + g4[2][1] * load,
                )
            f = f1
    return PlantResponse(t, out_v, out_i, out_w, out_phi, out_phi * c.gear_ratio)

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
import scipy.linalg

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


def simulate_plant(config: TrainerConfig, time_s: np.ndarray, input_v: np.ndarray) -> PlantResponse:
    """Simulate the trainer from rest for an input held constant over each sample (ZOH).

    Parameters
    ----------
    config : TrainerConfig
        The trainer.
    time_s : ndarray
        Uniform sample times.
    input_v : ndarray
        Input voltage at each sample (held until the next).

    Returns
    -------
    PlantResponse
        States at each sample instant.
    """
    c = config
    t = np.asarray(time_s, dtype=float)
    u = np.asarray(input_v, dtype=float)
    dt = float(t[1] - t[0])
    h = dt / c.substeps
    # linear part, states [i, ω, φ], inputs [v_armature, load torque]
    a = np.array([
        [-c.ra_ohm / c.la_h, -c.k_motor / c.la_h, 0.0],
        [c.k_motor / c.j_kgm2, -c.b_nms / c.j_kgm2, 0.0],
        [0.0, 1.0, 0.0],
    ])
    b = np.array([[1.0 / c.la_h, 0.0], [0.0, -1.0 / c.j_kgm2], [0.0, 0.0]])
    aug = np.zeros((5, 5))
    aug[:3, :3], aug[:3, 3:] = a, b
    e = scipy.linalg.expm(aug * h)
    phi, gam = e[:3, :3], e[:3, 3:]
    p = [[float(x) for x in row] for row in phi]
    g = [[float(x) for x in row] for row in gam]
    lead_lag = c.amp_lag_s > 0
    alpha = 1.0 - np.exp(-h / c.amp_lag_s) if lead_lag else 1.0
    ratio = c.amp_lead_s / c.amp_lag_s if lead_lag else 1.0
    kt, dz, rail, gain = c.k_motor, c.amp_dead_zone_v, c.amp_rail_v, c.amp_gain
    tc, ts, brake = c.coulomb_nm, c.static_nm, c.brake_nm
    # speed below which the shaft may stick: the change one sub-step of static torque makes
    w_stick = ts * h / c.j_kgm2
    n = t.size
    out_v = np.empty(n)
    out_i = np.empty(n)
    out_w = np.empty(n)
    out_phi = np.empty(n)
    i = w = ang = f = 0.0
    v = 0.0
    for k in range(n):
        out_v[k], out_i[k], out_w[k], out_phi[k] = v, i, w, ang
        x = float(u[k])
        x = x - dz if x > dz else (x + dz if x < -dz else 0.0)
        for _ in range(c.substeps):
            f += alpha * (x - f)
            y = ratio * x + (1.0 - ratio) * f if lead_lag else x
            v = gain * y
            v = rail if v > rail else (-rail if v < -rail else v)
            drive = kt * i
            if abs(w) <= w_stick and abs(drive) <= ts + brake:
                # stuck: static friction and the brake hold the shaft
                load = drive - c.b_nms * w
                w = 0.0
            else:
                sgn = 1.0 if (w > 0 or (w == 0 and drive > 0)) else -1.0
                load = sgn * (tc + brake)
            i, w, ang = (
                p[0][0] * i + p[0][1] * w + g[0][0] * v + g[0][1] * load,
                p[1][0] * i + p[1][1] * w + g[1][0] * v + g[1][1] * load,
                p[2][0] * i + p[2][1] * w + p[2][2] * ang + g[2][0] * v + g[2][1] * load,
            )
    return PlantResponse(t, out_v, out_i, out_w, out_phi, out_phi * c.gear_ratio)

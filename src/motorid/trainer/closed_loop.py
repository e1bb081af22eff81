"""The virtual trainer as the plant of a closed-loop run.

:mod:`motorid.simulation.closed_loop` takes any
:class:`~motorid.simulation.closed_loop.ClosedLoopPlant`; this is the trainer's.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from motorid.control.design import Design
from motorid.control.pid import PidDesign
from motorid.model import MotorModel
from motorid.simulation.closed_loop import SimulationResult, SimulationSettings, simulate_closed_loop
from motorid.trainer.plant import simulate_plant
from motorid.trainer.presets import TrainerConfig, preset
from motorid.trainer.truth import truth_of
from motorid.errors import OptionError

__all__ = ["TrainerLoop", "simulate_on_trainer"]


class TrainerLoop:
    """The virtual trainer stepped one control interval at a time via ``simulate_plant``.

    Each call restarts the plant from the previous (current, speed, angle); the amplifier's
    lead/lag state is not carried over (``simulate_plant`` has no argument for it), so presets
    with a lead/lag get a warning.

    Parameters
    ----------
    config : TrainerConfig, optional
        The trainer to run (its noise-free ``quiet()`` variant); default: the settings'
        ``trainer_preset``.
    """

    def __init__(self, config: TrainerConfig | None = None) -> None:
        self._config = config

    def start(self, model: MotorModel, s: SimulationSettings, x0: np.ndarray) -> list[str]:
        """Start from the model-state vector ``x0`` (see :class:`ClosedLoopPlant`).

        Parameters
        ----------
        model : MotorModel
            The model in the design's states (position, velocity, ...).
        s : SimulationSettings
            The run's settings (preset, disturbance, control interval).
        x0 : ndarray
            Initial state in the model's states.

        Returns
        -------
        list of str
            Warnings about the run.
        """
        warnings: list[str] = []
        self.cfg = (preset(s.trainer_preset) if self._config is None else self._config).quiet()
        warnings += _same_motor(model, self.cfg, s.trainer_preset)
        if s.saturation_v is None:
            self.cfg = self.cfg  # the trainer's own rails still act
        if self.cfg.amp_lag_s > 0:
            warnings.append(f"trainer preset {s.trainer_preset!r} has an amplifier lead/lag whose state "
                            "restarts each control interval in this closed-loop run")
        self.brake_nm = abs(s.disturbance_v) * self.cfg.amp_gain * self.cfg.k_motor / self.cfg.ra_ohm
        self.dist_start = s.disturbance_start_s
        self.dt = s.dt_s
        self.names = model.states
        self.pos_per_rad = self.cfg.pot_span_v / (2 * math.pi) * self.cfg.gear_ratio
        x0d = dict(zip(model.states, x0, strict=False))
        self.offset = float(x0d.get("position", 0.0))
        w0 = float(x0d.get("velocity", 0.0)) / self.cfg.tacho_v_per_rad_s
        self.state = (0.0, w0, 0.0)
        return warnings

    def measured(self) -> np.ndarray:
        """The measured states (position, velocity; others 0), in the model's state order.

        Returns
        -------
        ndarray
            One value per model state.
        """
        _, w, ang = self.state
        vals = {"position": self.offset + self.pos_per_rad * ang, "velocity": self.cfg.tacho_v_per_rad_s * w}
        return np.array([vals.get(name, 0.0) for name in self.names])

    def output(self, name: str) -> float:
        """The measured channel ``name`` (volts).

        Parameters
        ----------
        name : str
            ``position`` or ``velocity``.

        Returns
        -------
        float
            The channel's reading in volts.
        """
        _, w, ang = self.state
        return self.offset + self.pos_per_rad * ang if name == "position" else self.cfg.tacho_v_per_rad_s * w

    def advance(self, u: float, t: float) -> None:
        """Hold ``u`` for one control interval from ``t`` (the brake acts after its instant).

        Parameters
        ----------
        u : float
            The control input in volts.
        t : float
            The interval's start time in s.
        """
        cfg = self.cfg if t < self.dist_start or self.brake_nm == 0 else replace(self.cfg, brake_nm=self.brake_nm)
        resp = simulate_plant(cfg, np.array([0.0, self.dt]), np.array([u, u]), initial=self.state)
        self.state = (float(resp.current_a[1]), float(resp.motor_speed_rad_s[1]), float(resp.motor_angle_rad[1]))


#: A model is of the trainer's motor when its DC gain and mean residence time are within these
#: fractions of the trainer's linearised ones (an identified model of the trainer lands well inside:
#: its dead-zone and friction lower the gain by ~2 %, its lags move τ by a few %).
SAME_MOTOR_GAIN_REL, SAME_MOTOR_TAU_REL = 0.25, 0.35


def _same_motor(model: MotorModel, cfg: TrainerConfig, name: str) -> list[str]:
    """Refuse a model of another motor on the trainer's plant; a note when they differ noticeably.

    ``--plant trainer`` runs the trainer's own motor: a design made on another motor's model (a
    rig logged in rpm) would be tried on a plant it was not designed for, and its numbers
    (rise time ``nan``) would say nothing about that rig.
    """
    truth = truth_of(cfg)
    fo = model.first_order()
    units = {u for u in (model.units or {}).values() if u and u != "V"}
    gain_rel = abs(fo.dc_gain - truth.dc_gain) / abs(truth.dc_gain)
    tau_rel = abs(model.residence_time_s() - truth.time_constant_s) / truth.time_constant_s
    what = (f"dc gain {fo.dc_gain:.4g} {model.dc_gain_unit} and τ + dead time {model.residence_time_s():.4g} s against "
            f"the trainer's {truth.dc_gain:.4g} V/V and {truth.time_constant_s:.4g} s")
    if units or not (gain_rel <= SAME_MOTOR_GAIN_REL and tau_rel <= SAME_MOTOR_TAU_REL):
        raise OptionError(f"this model is not of the virtual trainer's motor (preset {name!r}): {what}; "
                          "--plant trainer runs the trainer's own motor — use --plant linear to simulate on the "
                          "model, or --preset for another trainer")
    if max(gain_rel, tau_rel) > 0.1:
        return [f"the model differs from the trainer preset {name!r} it runs on: {what}"]
    return []


def simulate_on_trainer(model: MotorModel, design: Design | PidDesign, settings: SimulationSettings, *,
                        config: TrainerConfig | None = None) -> SimulationResult:
    """Run the design in closed loop on the trainer's nonlinear plant (``settings.plant='trainer'``).

    Parameters
    ----------
    model : MotorModel
        The observer's model (the design's states).
    design : Design or PidDesign
        The controller.
    settings : SimulationSettings
        Its ``trainer_preset`` names the plant (noise-free ``quiet()`` variant).
    config : TrainerConfig, optional
        A trainer configuration instead of the preset (e.g. a multi-level experiment's).

    Returns
    -------
    SimulationResult
    """
    return simulate_closed_loop(model, design, replace(settings, plant="trainer"), plant=TrainerLoop(config))

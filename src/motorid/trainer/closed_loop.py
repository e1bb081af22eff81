"""The virtual trainer as the plant of a closed-loop run.

:mod:`motorid.simulate.closed_loop` takes any
:class:`~motorid.simulate.closed_loop.ClosedLoopPlant`; this is the trainer's.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from motorid.control.design import Design
from motorid.model import MotorModel
from motorid.simulate.closed_loop import SimulationResult, SimulationSettings, simulate_closed_loop
from motorid.trainer.plant import simulate_plant
from motorid.trainer.presets import TrainerConfig, preset

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


def simulate_on_trainer(model: MotorModel, design: Design, settings: SimulationSettings, *,
                        config: TrainerConfig | None = None) -> SimulationResult:
    """Run the design in closed loop on the trainer's nonlinear plant (``settings.plant='trainer'``).

    Parameters
    ----------
    model : MotorModel
        The observer's model (the design's states).
    design : Design
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

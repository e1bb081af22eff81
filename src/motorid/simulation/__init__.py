"""Closed-loop prediction: simulation of a design (:mod:`.closed_loop`) and the modes map (:mod:`.modes`)."""

from motorid.simulation.closed_loop import (
    REFERENCE_KINDS,
    ReferenceSignal,
    ResponseMetrics,
    SimulationResult,
    SimulationSettings,
    plot_simulation,
    reference_values,
    response_metrics,
    simulate_closed_loop,
)
from motorid.simulation.reference import ReferenceLevel, default_reference_level
from motorid.simulation.modes import (
    MODES,
    ModeCriteria,
    ModeMap,
    ServoPlant,
    classify_grid,
    mode_map,
    modes_json,
    parse_range,
    plot_mode_maps,
    servo_plants,
    simulate_servo_grid,
)

__all__ = [
    "MODES",
    "REFERENCE_KINDS",
    "ModeCriteria",
    "ModeMap",
    "ReferenceLevel",
    "ReferenceSignal",
    "ResponseMetrics",
    "ServoPlant",
    "SimulationResult",
    "SimulationSettings",
    "classify_grid",
    "default_reference_level",
    "mode_map",
    "modes_json",
    "parse_range",
    "plot_mode_maps",
    "plot_simulation",
    "reference_values",
    "response_metrics",
    "servo_plants",
    "simulate_closed_loop",
    "simulate_servo_grid",
]

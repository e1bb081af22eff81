"""The virtual servo trainer: a physically honest stand-in for the paper's bench.

Nonlinear armature/shaft/gearbox plant (:mod:`.plant`), servo amplifier with dead-zone,
lead/lag and rails, sensors with ripple, wrap glitches and PWM noise (:mod:`.sensors`),
TDS2000 acquisition (:mod:`.scope`), presets (:mod:`.presets`) and the exact linearised
transfer functions as ground truth (:mod:`.truth`).
"""

from motorid.trainer.experiment import CaptureTruth, TrainerExperiment, run_experiment
from motorid.trainer.plant import PlantResponse, simulate_plant
from motorid.trainer.presets import PRESET_NAMES, TrainerConfig, preset
from motorid.trainer.scope import ScopeSettings, acquire
from motorid.trainer.signals import TEST_SIGNALS, step_signal, test_signal
from motorid.trainer.truth import FirstOrder, Truth, step_residence_time, truth_of

__all__ = [
    "PRESET_NAMES",
    "TEST_SIGNALS",
    "CaptureTruth",
    "FirstOrder",
    "PlantResponse",
    "ScopeSettings",
    "TrainerConfig",
    "TrainerExperiment",
    "Truth",
    "acquire",
    "preset",
    "run_experiment",
    "simulate_plant",
    "step_residence_time",
    "step_signal",
    "test_signal",
    "truth_of",
]

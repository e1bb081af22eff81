"""A model with a dead time through design and simulate (every model the
identification produces goes on through the chain).  The model is the one `identify` gives
with default options on the 100 Hz dead-time rig preset, not a hand-made one."""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.control.design import DesignSettings, design_controller
from motorid.identification.pipeline import identify_experiment
from motorid.simulation.closed_loop import SimulationSettings, simulate_closed_loop
from motorid.trainer.realsetups import write_real_setup


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    rec = write_real_setup("daq-deadtime", tmp_path_factory.mktemp("daq") / "rec", seed=0)
    m = identify_experiment(rec.read_captures()).model
    assert m.delay_s == pytest.approx(rec.truth.delay_s, abs=0.01)  # the dead time was found
    return m


def _delay_margin(model, design) -> float:
    """Independent computation: the loop at the plant input on the model's own realisation."""
    loop = control.ss(model.A, model.B, np.asarray(design.K_model).reshape(1, -1), 0.0)
    _, pm, _, _, wp, _ = control.stability_margins(loop)
    return float(np.deg2rad(pm) / wp) if np.isfinite(wp) and wp > 0 else float("inf")


def test_design_reports_what_the_dead_time_does(model) -> None:
    slow = design_controller(model, DesignSettings(damping=0.7, wn=5.0))
    assert any("dead time" in w and "pole placement" in w for w in slow.warnings)
    fast = design_controller(model, DesignSettings(damping=0.7, wn=40.0))
    margin = _delay_margin(model, fast)
    assert margin < model.delay_s  # python-control agrees: this loop cannot take the dead time
    assert any(w.startswith("UNSTABLE with the model's dead time") for w in fast.warnings)


def test_simulate_applies_the_dead_time(model) -> None:
    slow = design_controller(model, DesignSettings(damping=0.7, wn=5.0))
    res = simulate_closed_loop(model, slow, SimulationSettings(duration_s=4.0))
    assert any("dead time" in w and "applied" in w for w in res.warnings)
    undelayed = simulate_closed_loop(model.replace(delay_s=0.0), slow, SimulationSettings(duration_s=4.0))
    # the delayed loop answers later, and both settle on the reference
    assert np.argmax(res.output_v > 0.5 * res.reference_v[-1]) > np.argmax(undelayed.output_v > 0.5 * res.reference_v[-1])
    assert abs(res.output_v[-1] - res.reference_v[-1]) < 1e-3 * abs(res.reference_v[-1])
    fast = design_controller(model, DesignSettings(damping=0.7, wn=40.0))
    res = simulate_closed_loop(model, fast, SimulationSettings(duration_s=2.0))
    assert any("diverged" in w for w in res.warnings)

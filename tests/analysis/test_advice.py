"""The experiment advisor on trainer captures recorded well and badly (one seed each; the Monte Carlo is bench/advice.py)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from motorid.analysis.advice import (
    Advice,
    AdviceSettings,
    advise,
    time_per_div_ladder,
    volts_per_div_ladder,
)
from motorid.errors import OptionError
from motorid.identification.pipeline import identify_experiment
from motorid.trainer.experiment import run_experiment

#: How the bench records the paper's trainer (velocity τ ≈ 0.43 s, tacho 5.36 V at 5.92 V).
CASES = {
    # the velocity at 5 V/div: about one of the eight divisions, the quantiser's step 0.2 V
    "two divisions": dict(volts_per_div={"velocity": 5.0}, sec_per_div=0.5, trigger_position_pct=10.0),
    # 100 ms/div with 30 % before the trigger: 0.7 s after the step, about 1.6 τ
    "short record": dict(sec_per_div=0.1, trigger_position_pct=30.0),
    # 5 s/div: 20 ms samples, about 20 per τ
    "coarse sampling": dict(sec_per_div=5.0, trigger_position_pct=10.0),
    # 250 ms/div, 2 V/div, 10 % before the trigger
    "well recorded": dict(sec_per_div=0.25, trigger_position_pct=10.0),
}


def _advice(case: str, seed: int = 0, roles: tuple[str, ...] = ("velocity",)) -> tuple[Advice, object]:
    exp = run_experiment("paper", seed=seed, roles=roles, validation=False, **CASES[case])
    ident = identify_experiment(exp.captures)
    return advise(ident, exp.captures), ident


def _reported_width(ident, key: str) -> float:
    """The identification's own 95 % width over the estimate, without the structures' spread (not predicted)."""
    u = ident.model.uncertainty[key]
    std = math.sqrt(u["std"] ** 2 - u.get("structure_std", 0.0) ** 2)
    return 2 * 1.96 * std / abs(u["value"])


def test_ladders_are_the_tds_ones():
    assert volts_per_div_ladder() == (0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0)
    assert volts_per_div_ladder(10.0)[-1] == 50.0
    tpd = time_per_div_ladder()
    assert tpd[0] == pytest.approx(2.5e-9) and tpd[-1] == 50.0
    assert {0.1, 0.25, 0.5, 1.0, 2.5, 5.0} <= set(tpd) and 0.2 not in tpd


@pytest.mark.parametrize("case,roles", [("well recorded", ("velocity",)), ("short record", ("velocity",)),
                                        ("well recorded", ("velocity", "current"))])
def test_now_is_what_identify_reports(case, roles):
    # the prediction for the capture's own settings is the identification's Fisher interval: the same
    # residuals, noise model, step-level errors; within 25 % (it is exact up to the refit's tolerance)
    adv, ident = _advice(case, roles=roles)
    assert adv.now.dc_gain == pytest.approx(_reported_width(ident, "dc_gain"), rel=0.25)
    assert adv.now.time_constant == pytest.approx(_reported_width(ident, "time_constant"), rel=0.25)


@pytest.mark.parametrize("case,setting,channel", [
    ("two divisions", "volts_per_div", "velocity"),
    ("short record", "time_per_div_s", None),
    ("coarse sampling", "time_per_div_s", None),
])
def test_a_bad_capture_names_the_setting_that_matters_most(case, setting, channel):
    adv, _ = _advice(case)
    assert adv.worth_changing
    first = adv.most_important
    assert (first.setting, first.channel) == (setting, channel)
    assert first.predicted.time_constant < (1 - adv.threshold) * adv.now.time_constant
    assert adv.combined_predicted.time_constant < (1 - adv.threshold) * adv.now.time_constant


def test_a_well_recorded_capture_needs_nothing():
    adv, _ = _advice("well recorded")
    assert not adv.worth_changing
    assert adv.combined == adv.settings
    assert adv.summary_line().startswith("nothing worth changing")


def test_never_a_setting_that_clips():
    # the tacho reads 5.36 V: 1 V/div would clip it (±5.1 divisions on screen), 2 V/div is the smallest
    adv, _ = _advice("two divisions")
    assert adv.combined.volts_per_div["velocity"] == 2.0
    assert all(s.suggested >= 2.0 for s in adv.suggestions if s.setting == "volts_per_div")


def test_advice_json_is_the_documented_document():
    adv, _ = _advice("short record")
    doc = json.loads(json.dumps(adv.to_dict(), allow_nan=False))
    assert {"dc_gain_ci95_width_rel", "time_constant_ci95_width_rel"} <= set(doc["now"])
    item = doc["suggestions"][0]
    assert set(item) >= {"setting", "channel", "now", "suggested", "why", "predicted"}
    assert set(doc["combined"]["settings"]) == {"volts_per_div", "time_per_div_s", "trigger_position_pct",
                                                "sample_interval_s", "step_volts", "averages"}
    assert doc["combined"]["settings"]["volts_per_div"]["velocity"] > 0


def test_threshold_is_a_fraction():
    with pytest.raises(OptionError):
        AdviceSettings(threshold=20)


def test_a_capture_without_a_scope_header_is_refused():
    from dataclasses import replace

    from motorid.capture import ScopeInfo

    exp = run_experiment("paper", seed=0, roles=("velocity",), validation=False, **CASES["well recorded"])
    cap = replace(exp.captures["velocity"], scope=ScopeInfo())
    ident = identify_experiment({"velocity": cap})
    with pytest.raises(OptionError, match="header"):
        advise(ident, {"velocity": cap})


def test_averaging_is_offered_with_its_cost():
    # a noisy trace (10× the trainer's front-end noise): averaging is what narrows it, at N steps' cost
    from dataclasses import replace

    from motorid.trainer.presets import preset

    cfg = replace(preset("paper"), noise_v=0.1)
    exp = run_experiment(config=cfg, seed=0, roles=("velocity",), validation=False, **CASES["well recorded"])
    adv = advise(identify_experiment(exp.captures), exp.captures)
    avg = [s for s in adv.suggestions if s.setting == "averages"]
    assert avg and avg[0].cost and avg[0].suggested in (4, 16, 64, 128)
    assert adv.combined.averages == 1
    assert np.isfinite(avg[0].predicted.time_constant)

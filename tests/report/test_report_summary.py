"""The plain-text summary (:mod:`motorid.report.summary`) of models that were not identified from a step."""

from __future__ import annotations

import jsonschema
import numpy as np
import pytest

from motorid.model import model_from_velocity_tf
from motorid.report.summary import model_summary
from motorid.schemas import schema


def test_a_model_built_from_a_transfer_function_is_summarised_without_a_step():
    """A model made from ``K/(τs + 1)`` has no step of its own: before, the summary raised
    ``TypeError: float() argument must be … not 'NoneType'``; now its header omits the step."""
    m = model_from_velocity_tf(np.array([10.0]), np.array([1.0, 5.0]))
    lines = model_summary(m)
    assert lines[0].startswith("identified model: method") and "step" not in lines[0]
    assert any(ln.startswith("first order:") and "dc gain 2 " in ln for ln in lines)  # 10/5, unit follows
    stepped = model_summary(model_from_velocity_tf(np.array([10.0]), np.array([1.0, 5.0]), step_volts=3.0))
    assert stepped[0].endswith("step 3 V")


def test_the_summary_says_when_its_intervals_hold_the_quantisers_error():
    # a scope's 8-bit codes (the trainer's velocity at 2 V/div): the line names the channel; the same
    # capture unquantised has no such line
    import motorid as mi
    from motorid.trainer import run_experiment

    for quantised, expected in ((True, "intervals: they hold the quantiser's error along the record (velocity)"),
                                (False, None)):
        rec = run_experiment("first-order", seed=0, validation=False, roles=("velocity",), quantised=quantised)
        model = mi.identify(mi.Experiment(captures=dict(rec.captures))).model
        held = [ln for ln in model_summary(model) if ln.startswith("intervals:")]
        assert (held[0].startswith(expected) if expected else not held), held
        # the model JSON says the same, with the code step: 2 V/div over the scope's 25 codes a division
        doc = model.to_dict()
        jsonschema.Draft202012Validator(schema("model")).validate(doc)
        steps = doc["uncertainty"].get("quantiser", {})
        assert steps == ({"velocity": pytest.approx(2.0 / 25, rel=1e-6)} if quantised else {}), steps

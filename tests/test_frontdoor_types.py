"""A Python caller's wrong type is a message naming the option, never a traceback from inside.

Found by passing each keyword of the front door's functions values of the wrong kind (text,
containers, None, objects): 145 of them ended in a ``TypeError``, ``ValueError``,
``AttributeError`` or ``KeyError`` from deep inside (``'int' object is not iterable``,
``dictionary update sequence element #0 has length 1``). The command line's parser never lets
such values through; Python and the web form's callers met them.
"""

from __future__ import annotations

import json

import pytest

import motorid as mi
from motorid.errors import OptionError


@pytest.fixture(scope="module")
def demo(demo_run):
    model = mi.MotorModel.from_json(json.loads((demo_run.folder / "model.json").read_text()))
    return demo_run.folder, model, mi.design(model, damping=1.0, wn=5.0, robust_samples=0)


CASES = [
    ("read_experiment", {"velocity": 5}, "velocity=: give a capture file"),
    ("read_experiment", {"columns": 5}, "columns: give ROLE=COLUMN text or a mapping"),
    ("read_experiment", {"units": 5}, "units: give CHANNEL=VALUE text or a mapping"),
    ("simulate", {"duration_s": "5"}, "duration_s must be a number, got '5'"),
    ("simulate", {"level_v": [1, 2]}, "level_v must be a number"),
    ("simulate", {"saturation": True}, "saturation must be a number, got True"),
    ("simulate", {"x0": "2,0"}, "x0 must be a sequence of numbers, got '2,0'"),
    ("simulate", {"xhat0": [1, "a"]}, "xhat0 must be a number, got 'a'"),
    ("validate", {"warmup_s": None}, "warmup_s must be a number, got None"),
    ("validate", {"step_volts": "6"}, "step_volts must be a number, got '6'"),
    ("validate", {"captures": 5}, "give the validation capture(s)"),
    ("identify_levels", {"step_volts": 6.0}, "step_volts must be a sequence of numbers, got 6.0"),
    ("design", {"integral": True, "integral_pole": "abc"}, "integral_pole must be a finite number, got 'abc'"),
    ("write_report", {"design": "abc"}, "design='abc' is not a Design, PidDesign or Mapping"),
    ("write_report", {"truth": 5}, "truth=5 is not a Mapping"),
    ("write_report", {"validation": None}, "validation=None is not a"),
]


@pytest.mark.parametrize("function, kwargs, said", CASES, ids=[f"{c[0]}-{next(iter(c[1]))}" for c in CASES])
def test_a_wrong_type_is_named(function, kwargs, said, demo, tmp_path):
    folder, model, design = demo
    vel = folder / "ALL0001"
    calls = {
        "read_experiment": lambda kw: mi.read_experiment(**{"velocity": vel, **kw}),
        "simulate": lambda kw: mi.simulate(model, design, **kw),
        "validate": lambda kw: mi.validate(model, kw.pop("captures", folder / "ALL0003"), **kw),
        "identify_levels": lambda kw: mi.identify_levels([vel, vel], **kw),
        "design": lambda kw: mi.design(model, damping=1.0, wn=5.0, robust_samples=0, **kw),
        "write_report": lambda kw: mi.write_report(tmp_path / "r.html", fit, **kw),
    }
    fit = None
    if function == "write_report":
        fit = mi.identify(mi.read_experiment(velocity=vel))
    with pytest.raises(OptionError) as err:
        calls[function](dict(kwargs))
    assert said in str(err.value)

"""Results with time series as pandas DataFrames: the same numbers, time as the index, units kept."""

from __future__ import annotations

import json

import numpy as np
import pytest

import motorid as mi

pd = pytest.importorskip("pandas")


@pytest.fixture(scope="module")
def model(demo_run):
    return mi.MotorModel.from_json(json.loads((demo_run.folder / "model.json").read_text()))


def test_a_closed_loop_run_as_a_dataframe(model):
    sim = mi.simulate(model, mi.design(model, damping=1.0, wn=8.0, robust_samples=0), duration_s=1.0)
    df = sim.to_dataframe()
    cols = sim.columns()
    np.testing.assert_array_equal(df.index.to_numpy(), cols["time"])
    assert df.index.name == "time_s"
    for name in ("reference", "output", "u"):
        np.testing.assert_array_equal(df[name].to_numpy(), cols[name])
    assert df.attrs["units"]["u"] == "V" and df.attrs["units"]["output"] == sim.output_unit


def test_a_validation_as_a_dataframe(model, demo_run):
    from motorid.analysis.validation import validate_capture
    from motorid.io import read_capture

    res = validate_capture(model, read_capture(demo_run.folder / "ALL0003"))
    df = res.to_dataframe()
    np.testing.assert_array_equal(df["simulated"].to_numpy(), res.simulated_v)
    np.testing.assert_array_equal(df.index.to_numpy(), res.time_s)
    assert list(df.columns) == ["input", "measured", "simulated"]


def test_without_pandas_the_error_says_how_to_get_it(monkeypatch):
    import sys

    from motorid.errors import MotorIdError
    from motorid.frames import to_dataframe

    monkeypatch.setitem(sys.modules, "pandas", None)  # import pandas → ImportError
    with pytest.raises(MotorIdError, match="pip install pandas"):
        to_dataframe({"time": np.arange(3.0), "y": np.ones(3)}, {"y": "V"})

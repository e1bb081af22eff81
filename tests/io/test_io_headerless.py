"""A log with no header row (an Arduino sketch printing ``millis(),volts,rpm`` and nothing else).

Before, such a file was refused as "not a capture: neither a Tektronix CSV nor a table with a
header row naming time and channels", and nothing could read it.  Now it is recognised, refused
without ``--columns`` with the mapping its first rows suggest, and read with its columns named
by position (``--columns time=1,input=2,velocity=3``) into the same model as with a header.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import motorid as mi
from motorid.errors import CaptureFormatError
from motorid.io import read_capture

COLUMNS = "time=1,input=2,velocity=3"


@pytest.fixture(scope="module")
def rig(tmp_path_factory):
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("l298n-rpm", tmp_path_factory.mktemp("l298n"), seed=0)
    headed = Path(rec.files["log"])
    bare = headed.with_name("bare.csv")
    bare.write_text("\n".join(headed.read_text().splitlines()[1:]) + "\n")
    return headed, bare


@pytest.mark.parametrize("extra", [(), ("--time-unit", "s")])
def test_without_columns_it_is_refused_with_the_mapping_to_give(rig, run_cli, extra):
    """``--time-unit`` travels in the column map but names no column: still refused, the same way."""
    _, bare = rig
    res = run_cli("identify", "--velocity", str(bare), *extra)
    assert res.code == 2 and len(res.err.strip().splitlines()) == 1
    assert f"{bare}:1: no header row: the first line is already numbers (3 columns)" in res.err
    assert f"e.g. --columns {COLUMNS}" in res.err
    assert "column 1 increases on every line" in res.err and "column 2 holds 2 levels" in res.err


def test_with_columns_it_gives_the_model_of_the_headed_log(rig, run_cli, tmp_path):
    headed, bare = rig
    models = []
    for f, extra in ((headed, ()), (bare, ("--columns", COLUMNS, "--units", "velocity=rpm"))):
        out = tmp_path / f"{f.stem}.json"
        res = run_cli("identify", "--velocity", str(f), *extra, "--json", str(out))
        assert res.code == 0, res.err
        models.append(json.loads(out.read_text()))
    assert models[1]["first_order"] == models[0]["first_order"]
    assert models[1]["dc_gain_unit"] == "rpm/V"


def test_python_and_the_careful_reader_read_it_alike(rig, tmp_path):
    """The fast reader (numpy's parser) and the careful one (a decimal comma sends the file there)
    give the same samples; the Python call names the columns the same way."""
    _, bare = rig
    exp = mi.read_experiment(velocity=bare, columns={"time": "1", "input": "2", "velocity": "3"})
    fast = exp.captures["velocity"]
    euro = tmp_path / "euro.csv"
    euro.write_text("\n".join(line.replace(",", ";").replace(".", ",") for line in bare.read_text().splitlines()))
    careful = read_capture(euro, columns={"time": "1", "input": "2", "velocity": "3"})
    assert np.array_equal(careful.time_s, fast.time_s) and np.array_equal(careful.output_v, fast.output_v)
    assert np.array_equal(careful.input_v, fast.input_v)


def test_a_bad_row_of_a_headerless_log_is_named(tmp_path):
    lines = [f"{0.01 * i:.2f},{6.0 if i >= 50 else 0.0},{0.1 * i:.1f}" for i in range(200)]
    lines[120] = "1.20,6.0,oops"
    f = tmp_path / "bad.csv"
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(CaptureFormatError) as err:
        read_capture(f, columns={"time": "1", "input": "2", "velocity": "3"})
    assert err.value.row == 121 and "oops" in str(err.value)


def test_python_takes_the_command_lines_column_text_too(rig):
    """``mi.read_experiment(..., columns="time=t,…")`` ended in "ValueError: dictionary update
    sequence element #0 has length 1; 2 is required" (a traceback): the front door took a mapping
    only, and the command line, batch, the web form and the rig demo each parsed the text with
    their own copy. One parser now serves all of them."""
    from motorid.errors import OptionError

    headed, bare = rig
    as_text = mi.read_experiment(velocity=bare, columns=COLUMNS)
    as_map = mi.read_experiment(velocity=bare, columns={"time": "1", "input": "2", "velocity": "3"})
    assert np.array_equal(as_text.captures["velocity"].output_v, as_map.captures["velocity"].output_v)
    assert mi.read_experiment(velocity=headed, columns="time=time,input=voltage,velocity=rpm").captures
    with pytest.raises(OptionError, match=r"^columns: 'time' is not ROLE=COLUMN"):
        mi.read_experiment(velocity=bare, columns="time")
    with pytest.raises(OptionError, match="a mapping of text to text"):
        mi.read_experiment(velocity=bare, columns=5)


def test_the_no_header_rig_runs_as_a_user_runs_it(tmp_path, run_cli):
    """The trainer's ``no-header`` preset (an Arduino sketch's ``millis(),volts,rpm``): the rig demo
    reads it with the arguments a user types (its ``--units velocity=rpm`` was an internal
    AttributeError: the front door took units as a mapping only), and the model is right."""
    out = tmp_path / "d"
    res = run_cli("demo", "--rig", "no-header", "--out", str(out), "--seed", "2")
    assert res.code == 0, res.err
    truth = json.loads((out / "truth.json").read_text())
    model = json.loads((out / "model.json").read_text())
    assert truth["identify_args"][2:] == ["--columns", COLUMNS, "--units", "velocity=rpm"]
    assert model["dc_gain_unit"] == "rpm/V"
    assert model["first_order"]["dc_gain"] == pytest.approx(truth["dc_gain"], rel=0.01)
    assert model["first_order"]["residence_time_s"] == pytest.approx(truth["residence_time_s"], rel=0.05)
    text = " ".join(res.out.split())
    assert "column '1' holds whole numbers stepping by 10, no unit in its name: read as milliseconds" in text
    # the same in Python, with the command line's texts
    exp = mi.read_experiment(velocity=out / "sketch_log.csv", columns=COLUMNS, units="velocity=rpm")
    assert exp.units == {"velocity": "rpm"}

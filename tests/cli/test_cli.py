"""The command line: exit codes, one-line errors, inspect JSON per docs/formats.md, demo round trip."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

INSPECT_KEYS = {"file", "format", "sample_interval", "n_samples", "step", "role", "wraps"}


def _one_line_error(res, *names: str) -> None:
    assert res.code == 2, (res.code, res.err)
    lines = [ln for ln in res.err.splitlines() if ln.strip()]
    assert len(lines) == 1, res.err
    assert "Traceback" not in res.err
    for n in names:
        assert n in lines[0], (n, lines[0])


def test_no_arguments_prints_help(run_cli):
    res = run_cli()
    assert res.code in (0, 2)
    assert "inspect" in res.out + res.err


def test_inspect_missing_file_is_exit_2(run_cli, tmp_path):
    missing = tmp_path / "nope.csv"
    _one_line_error(run_cli("inspect", missing), "nope.csv")


def test_inspect_text_file_is_not_a_capture(run_cli, tmp_path):
    f = tmp_path / "notes.txt"
    f.write_text("dear diary,\ntoday the motor turned.\n")
    _one_line_error(run_cli("inspect", f), "notes.txt")


def test_inspect_bad_columns_option(run_cli, tmp_path):
    f = tmp_path / "log.csv"
    f.write_text("t,u,rpm\n" + "".join(f"{k*0.01},{5 if k < 50 else 15},{k}\n" for k in range(100)))
    _one_line_error(run_cli("inspect", f, "--columns", "time"), "--columns")
    _one_line_error(run_cli("inspect", f, "--columns", "time=t,input=u,velocity=speed"), "speed")


def test_inspect_plain_csv_with_column_map(run_cli, tmp_path):
    f = tmp_path / "log.csv"
    rows = "".join(f"{k*0.01:.2f},{5 if k < 50 else 15},{1000 + (k >= 50) * 500 * (1 - 0.9 ** (k - 49))}\n" for k in range(200))
    f.write_text("t,u,rpm\n" + rows)
    res = run_cli("inspect", f, "--columns", "time=t,input=u,velocity=rpm", "--json")
    assert res.code == 0, res.err
    (obj,) = json.loads(res.out)
    assert obj["format"] == "plain-csv"
    assert obj["role"] == "velocity"
    # the input switches between samples 49 (t=0.49) and 50 (t=0.50): the 50 % crossing is at 0.495
    assert obj["step"]["time"] == pytest.approx(0.495, abs=0.01)
    assert obj["step"]["volts"] == pytest.approx(10.0, rel=1e-6)


def test_inspect_real_tektronix_samples(run_cli, real_dir):
    files = sorted((real_dir / "tek-tds2000-format-samples").glob("*.CSV"))
    assert len(files) == 3
    res = run_cli("inspect", "--json", *files)
    assert res.code == 0, res.err
    objs = json.loads(res.out)
    assert len(objs) == 3
    for obj in objs:
        assert set(obj) >= INSPECT_KEYS
        assert obj["format"] == "tds2000-csv"
        assert obj["n_samples"] == 2500
    by_name = {Path(o["file"]).name: o for o in objs}
    # sample intervals printed in the files' headers (PROVENANCE.md)
    assert by_name["TDS2012B_Wazurim-Design2_F0000CH1.CSV"]["sample_interval"] == pytest.approx(2e-5, rel=1e-6)
    assert by_name["TDS2014C_AdrianSolo-ECE425L_PWM_ALL0000_F0000CH1.CSV"]["sample_interval"] == pytest.approx(4e-5, rel=1e-6)


def test_inspect_real_hslu_step_from_nonzero_baseline(run_cli, real_dir):
    f = real_dir / "hslu-rtl-dcmotor" / "csv" / "06_dc_step_5_15_00.csv"
    res = run_cli("inspect", "--json", f)
    assert res.code == 0, res.err
    (obj,) = json.loads(res.out)
    assert obj["format"] == "plain-csv"
    assert obj["role"] == "velocity"
    # PROVENANCE.md: the input steps 5 V -> 15 V between t = 3.24 s and 3.25 s
    assert 3.24 <= obj["step"]["time"] <= 3.25
    assert obj["step"]["volts"] == pytest.approx(10.0, rel=0.01)


def test_inspect_human_table(run_cli, real_dir):
    f = real_dir / "hslu-rtl-dcmotor" / "csv" / "06_dc_step_5_15_00.csv"
    res = run_cli("inspect", f)
    assert res.code == 0, res.err
    assert "plain-csv" in res.out and "velocity" in res.out


def test_every_user_error_is_a_motorid_error_and_its_builtin() -> None:
    """All error classes in motorid.errors, each a MotorIdError and the matching
    built-in, and still importable where they used to live."""
    import motorid.conditioning.edge as edge
    import motorid.control.feedback as feedback
    import motorid.errors as errors
    import motorid.identification.result as result
    import motorid.io.atomic as atomic
    import motorid.model as model

    assert edge.ResponseNotStepError is errors.ResponseNotStepError
    assert feedback.ControlDesignError is errors.ControlDesignError
    assert result.IdentificationError is errors.IdentificationError
    assert atomic.OutputWriteError is errors.OutputWriteError
    assert model.ModelFormatError is errors.ModelFormatError
    builtin = {"OutputExistsError": FileExistsError, "OutputWriteError": OSError,
               # the oscilloscope: an instrument that cannot be reached is an OSError,
               # one that never triggers a TimeoutError
               "InstrumentError": OSError, "AcquisitionTimeoutError": TimeoutError}
    for name in errors.__all__:
        cls = getattr(errors, name)
        assert issubclass(cls, errors.MotorIdError)
        if name != "MotorIdError":
            assert issubclass(cls, builtin.get(name, ValueError)), name
    err = errors.OutputWriteError("cannot write", file="x.json")
    assert str(err) == "x.json: cannot write" and isinstance(err, OSError)

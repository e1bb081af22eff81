"""Wrong inputs to identify/inspect/demo/report/sweep: refused before any work, one line, exit 2.

Every case asserts exit 2, exactly one line on stderr that names the option (or the file and
the role), no traceback, and that nothing was written.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from motorid.capture import ChannelInfo


@pytest.fixture(scope="module")
def caps(tmp_path_factory) -> Path:
    """The paper preset's three captures as the scope writes them (as ``motorid demo`` does)."""
    from motorid.io import write_tds_capture
    from motorid.trainer import run_experiment

    out = tmp_path_factory.mktemp("caps")
    exp = run_experiment("paper", seed=0)
    for i, role in enumerate(("position", "velocity", "current")):
        write_tds_capture(out, exp.captures[role], index=i)
    # a tacho + current-shunt pair on one acquisition: CH1 is the tacho (a response, no step)
    v, c = exp.captures["velocity"], exp.captures["current"]
    pair = replace(v, input_v=v.output_v, input_info=ChannelInfo("CH1"), output_v=c.output_v)
    write_tds_capture(out / "pair", pair, index=0)
    return out


def _refused(res, *names: str) -> str:
    assert res.code == 2, (res.code, res.out, res.err)
    assert "Traceback" not in res.err and "internal error" not in res.err
    lines = [ln for ln in res.err.splitlines() if ln.strip()]
    assert len(lines) == 1, res.err
    for n in names:
        assert n in lines[0], (n, lines[0])
    return lines[0]


def _files(folder: Path) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


# --- option values: refused before any file is read or written --------------------------------

BAD_IDENTIFY_OPTIONS = [
    (("--derivative", "foo"), "--derivative"),
    (("--derivative", "bogus"), "--derivative"),
    (("--structure", "bogus"), "--structure"),
    (("--method", "magic"), "--method"),
    (("--order", "5"), "--order"),
    (("--reduction", "median"), "--reduction"),
    (("--sync", "nearest"), "--sync"),
    (("--record-length", "0"), "--record-length"),
    (("--record-length", "-1"), "--record-length"),
    (("--record-length", "1e-9"), "--record-length"),
    (("--record-length", "nan"), "--record-length"),
    (("--sample-interval", "0"), "--sample-interval"),
    (("--sample-interval", "nan"), "--sample-interval"),
    (("--step-volts", "0"), "--step-volts"),
    (("--step-volts", "nan"), "--step-volts"),
    (("--step-volts", "inf"), "--step-volts"),
    (("--step-volts", "-5"), "--step-volts"),  # contradicts the +5.92 V step on CH1
    (("--step-volts", "59.2"), "--step-volts"),  # a 10x probe setting contradicts CH1 too
    (("--markov-window", "0"), "--markov-window"),
    (("--markov-window", "-1"), "--markov-window"),
    (("--markov-params", "2"), "--markov-params"),
    (("--ratio", "0"), "--ratio"),
    (("--t0", "nan"), "--t0"),
    (("--sample-interval", "2.0", "--record-length", "2.9"), "--record-length"),
]


@pytest.mark.parametrize("args, option", BAD_IDENTIFY_OPTIONS, ids=lambda a: " ".join(a) if isinstance(a, tuple) else a)
def test_identify_refuses_a_bad_option_before_any_work(caps, run_cli, tmp_path, args, option):
    out = tmp_path / "model.json"
    res = run_cli("identify", "--velocity", caps / "ALL0001", *args, "--json", out, "--report", tmp_path / "r.html")
    _refused(res, option)
    assert _files(tmp_path) == set()


@pytest.mark.parametrize("args, option", [
    (("--method", "magic"), "--method"),
    (("--sample-interval", "-0.1"), "--sample-interval"),
    (("--step-volts", "0"), "--step-volts"),
])
def test_report_refuses_a_bad_option(caps, run_cli, tmp_path, args, option):
    res = run_cli("report", "--out", tmp_path / "r.html", "--velocity", caps / "ALL0001", *args)
    _refused(res, option)
    assert _files(tmp_path) == set()


@pytest.mark.parametrize("args, option", [
    (("--order", "4"), "--order"),
    (("--reduction", "x"), "--reduction"),
    (("--lengths", "1.9,inf"), "--lengths"),
    (("--intervals", "nan"), "--intervals"),
    (("--step-volts", "nan"), "--step-volts"),
])
def test_sweep_refuses_a_bad_option(caps, run_cli, tmp_path, args, option):
    res = run_cli("sweep", "--velocity", caps / "ALL0001", *args, "--json", tmp_path / "t.json")
    _refused(res, option)
    assert _files(tmp_path) == set()


def test_inspect_step_volts_nan_is_refused_not_printed_as_bare_nan(caps, run_cli):
    res = run_cli("inspect", caps / "ALL0001", "--json", "--step-volts", "nan")
    _refused(res, "--step-volts")
    assert "NaN" not in res.out


def test_demo_refuses_an_unknown_preset_and_a_bad_step(run_cli, tmp_path):
    _refused(run_cli("demo", "--out", tmp_path / "d", "--preset", "nope"), "--preset")
    _refused(run_cli("demo", "--out", tmp_path / "d", "--step-volts", "inf"), "--step-volts")
    assert _files(tmp_path) == set()


# --- output paths: checked before the work, with or without --force -------------------------

@pytest.mark.parametrize("force", [False, True])
def test_outputs_onto_a_folder_or_into_a_missing_folder(caps, run_cli, tmp_path, force):
    f = ("--force",) if force else ()
    v = ("--velocity", caps / "ALL0001")
    (tmp_path / "folder").mkdir()
    before = _files(tmp_path)
    _refused(run_cli("identify", *v, "--json", tmp_path / "folder", *f), "--json", "folder")
    _refused(run_cli("identify", *v, "--report", tmp_path / "folder", *f), "--report", "folder")
    _refused(run_cli("identify", *v, "--json", tmp_path / "missing" / "m.json", *f), "--json", "does not exist")
    _refused(run_cli("identify", *v, "--report", tmp_path / "missing" / "r.html", *f), "--report", "does not exist")
    _refused(run_cli("identify", *v, "--matlab", tmp_path / "missing" / "m.m", *f), "--matlab")
    _refused(run_cli("identify", *v, "--json", tmp_path / "x", "--report", tmp_path / "x", *f), "--json", "--report")
    _refused(run_cli("report", *v, "--out", tmp_path / "folder", *f), "--out", "folder")
    _refused(run_cli("report", *v, "--out", tmp_path / "missing" / "r.html", *f), "--out", "does not exist")
    _refused(run_cli("sweep", *v, "--json", tmp_path / "folder", *f), "--json", "folder")
    _refused(run_cli("sweep", *v, "--json", tmp_path / "missing" / "t.json", *f), "--json", "does not exist")
    assert _files(tmp_path) == before


@pytest.mark.parametrize("force", [False, True])
def test_demo_out_that_is_a_file(run_cli, tmp_path, force):
    readme = tmp_path / "README.md"
    readme.write_text("# my project\n")
    f = ("--force",) if force else ()
    _refused(run_cli("demo", "--out", readme, *f), "--out", "README.md", "not a folder")
    _refused(run_cli("demo", "--out", readme / "sub", *f), "--out", "README.md")
    assert readme.read_text() == "# my project\n"
    assert _files(tmp_path) == {"README.md"}


def test_check_writable_library_behaviour(tmp_path):
    from motorid.errors import OptionError, OutputExistsError
    from motorid.io import check_writable

    (tmp_path / "f.txt").write_text("x")
    # writers that create their folders (the scope-folder writers) still may
    check_writable([tmp_path / "new" / "ALL0000" / "F0000CH1.CSV"], force=False)
    with pytest.raises(OptionError, match="does not exist"):
        check_writable({"--json": tmp_path / "new" / "m.json"}, force=True, create_parents=False)
    with pytest.raises(OutputExistsError, match="already exists"):
        check_writable([tmp_path / "f.txt"], force=False)
    check_writable([tmp_path / "f.txt"], force=True)
    with pytest.raises(OptionError, match="is a folder"):
        check_writable([tmp_path], force=True)
    check_writable([tmp_path], force=False, folder=True)


# --- one capture per role -------------------------------------------------------------------

@pytest.mark.parametrize("command", ["report", "sweep"])
def test_a_role_given_twice_is_refused(caps, run_cli, tmp_path, command):
    out = ("--out", tmp_path / "r.html") if command == "report" else ()
    res = run_cli(command, *out, "--velocity", caps / "ALL0001", "--velocity", caps / "ALL0001", "--current",
                  caps / "ALL0002")
    line = _refused(res, "--velocity", "2 times", "several step levels")
    assert "several step levels are identified from velocity captures" in line
    assert _files(tmp_path) == set()


def test_identify_with_one_level_given_twice_says_two_moving_levels_are_needed(caps, run_cli, tmp_path):
    # --velocity twice is the several-levels path; one level twice cannot show a dead-zone
    res = run_cli("identify", "--velocity", caps / "ALL0001", "--velocity", caps / "ALL0001",
                  "--json", tmp_path / "m.json")
    assert res.code == 2, res.out
    assert res.err.count("\n") == 1 and "at least two step levels that move the motor" in res.err
    assert _files(tmp_path) == set()
    res = run_cli("identify", "--position", caps / "ALL0000", "--position", caps / "ALL0000")
    assert res.code == 2 and "--position given 2 times" in res.err


# --- the role check -------------------------------------------------------------------------

@pytest.mark.parametrize("flags, file, looks", [
    (("--velocity", "ALL0000"), "ALL0000", "position"),  # position sawtooth given as velocity
    (("--velocity", "ALL0002"), "ALL0002", "current"),
    (("--position", "ALL0002", "--velocity", "ALL0001"), "ALL0002", "current"),
    (("--position", "ALL0001", "--velocity", "ALL0000"), "ALL000", ""),  # swapped captures
    (("--position", "ALL0000", "--velocity", "ALL0001", "--current", "ALL0000"), "ALL0000", "position"),
])
@pytest.mark.parametrize("command", ["identify", "report", "sweep"])
def test_a_capture_that_looks_like_another_role_is_refused(caps, run_cli, tmp_path, command, flags, file, looks):
    args = [caps / a if a.startswith("ALL") else a for a in flags]
    out = ("--out", tmp_path / "r.html") if command == "report" else ()
    line = _refused(run_cli(command, *out, *args), file, "looks like a", "--force-role")
    assert f"looks like a {looks}" in line
    assert _files(tmp_path) == set()


def test_force_role_keeps_the_flag(caps, run_cli, tmp_path):
    out = tmp_path / "m.json"
    res = run_cli("identify", "--velocity", caps / "ALL0002", "--force-role", "--method", "pinv",
                  "--sample-interval", "0.1", "--json", out)
    assert res.code == 0, res.err
    assert json.loads(out.read_text())["schema"] == "motorid.model/1"


def test_the_right_roles_pass_the_check(caps, run_cli, tmp_path):
    out = tmp_path / "m.json"
    res = run_cli("identify", "--position", caps / "ALL0000", "--velocity", caps / "ALL0001", "--current",
                  caps / "ALL0002", "--method", "pinv", "--sample-interval", "0.1", "--json", out)
    assert res.code == 0, res.err
    assert out.exists()


# --- CH1 that is a response, a step early in a long log --------------------------------------

def test_a_ch1_that_is_a_response_is_refused_with_the_fix(caps, run_cli):
    line = _refused(run_cli("identify", "--velocity", caps / "pair" / "ALL0000"), "ALL0000")
    assert "looks like a response" in line and "--step-volts" in line and "--t0" in line


def test_plain_csv_log_with_the_step_at_half_a_second_of_thirty(run_cli, tmp_path):
    t = np.arange(3000) * 0.01
    u = np.where(t >= 0.5, 15.0, 5.0)
    tau, gain = 0.16, 245.0
    y = 1000.0 + gain * 10.0 * (1 - np.exp(-np.clip(t - 0.5, 0, None) / tau))
    f = tmp_path / "log.csv"
    np.savetxt(f, np.c_[t, u, y], delimiter=",", header="time_s,motor_voltage_V,speed_rpm", comments="")
    res = run_cli("inspect", f, "--json")
    assert res.code == 0, res.err
    (obj,) = json.loads(res.out)
    # the input switches between samples 49 (0.49 s) and 50 (0.50 s)
    assert obj["step"]["time"] == pytest.approx(0.5, abs=0.01)
    assert obj["step"]["volts"] == pytest.approx(10.0)
    res = run_cli("identify", "--velocity", f, "--method", "pinv", "--order", "1", "--sample-interval", "0.02",
                  "--json", tmp_path / "m.json")
    assert res.code == 0, res.err
    fo = json.loads((tmp_path / "m.json").read_text())["first_order"]
    # noiseless first-order data: the analytic gain and τ within 2 % (20 ms reduction, Euler-free pinv)
    assert fo["dc_gain"] == pytest.approx(gain, rel=0.02)
    assert fo["time_constant"] == pytest.approx(tau, rel=0.02)


# --- sweep with every cell failing; --strict ------------------------------------------------

def test_sweep_exits_2_when_every_cell_fails(caps, run_cli, tmp_path):
    out = tmp_path / "t.json"
    line = _refused(run_cli("sweep", "--velocity", caps / "ALL0001", "--lengths", "100,200", "--intervals", "0.1",
                            "--json", out), "every one of the 2 cells")
    assert "longer than" in line
    assert not out.exists()


def test_strict_exits_3_after_writing_the_outputs(caps, run_cli, tmp_path, monkeypatch):
    import motorid.identification.pipeline as ident

    real = ident.identify_experiment

    class Failing:
        """The real result, plus a sanity verdict that failed (the lead's gate may not exist yet)."""

        def __init__(self, result):
            self._r = result
            self.sanity = SimpleNamespace(passed=False, failures=("pole at +1.465 (unstable)", "fit 256 %"))

        def __getattr__(self, name):
            return getattr(self._r, name)

    monkeypatch.setattr(ident, "identify_experiment", lambda *a, **k: Failing(real(*a, **k)))
    common = ("--velocity", caps / "ALL0001", "--method", "pinv", "--sample-interval", "0.1")
    out = tmp_path / "m.json"
    res = run_cli("identify", *common, "--json", out, "--strict")
    assert res.code == 3, res.err
    lines = [ln for ln in res.err.splitlines() if ln.strip()]
    assert lines == ["motorid: the model failed the sanity checks: pole at +1.465 (unstable); fit 256 %"]
    assert out.exists()  # written before the exit: graders' scripts want both
    res = run_cli("identify", *common, "--json", out, "--force")
    assert res.code == 0, res.err


def test_sweep_grid_comes_from_the_data_for_a_fast_motor(tmp_path, run_cli):
    """For the sweep: the paper's grid (1.9–2.9 s × 0.04–0.12 s) has no cell a
    0.35 s record of a 16 ms motor allows; the default grid is the data's own."""
    from motorid.analysis.sweep import PAPER_LENGTHS_S, data_grid
    from motorid.trainer.realsetups import write_real_setup

    rec = write_real_setup("fast-tbs1000", tmp_path / "rec", seed=1)
    args = [str(a) for a in rec.cli_args]
    lengths, intervals, note = data_grid(rec.read_captures(), step_volts=rec.step_volts)
    record = max(lengths)
    assert max(lengths) < min(PAPER_LENGTHS_S) and min(lengths) == pytest.approx(0.65 * record, rel=1e-3)
    assert all(i >= rec.sample_interval_s * (1 - 1e-9) for i in intervals)
    assert "--lengths paper" in note
    res = run_cli("sweep", *args, "--method", "classic")
    assert res.code == 0, res.err
    assert "grid from the data" in res.out
    res = run_cli("sweep", *args, "--method", "classic", "--lengths", "paper", "--intervals", "paper")
    assert res.code == 2 and "every one of the 15 cells" in res.err


def test_an_existing_output_names_the_flag_on_the_command_line_and_the_keyword_in_python(caps, run_cli, tmp_path):
    """The same refusal, in each caller's words: ``--force`` in a terminal, ``force=True`` in Python."""
    from motorid.errors import OutputExistsError
    from motorid.io import check_writable

    out = tmp_path / "m.json"
    out.write_text("{}")
    res = run_cli("identify", "--velocity", str(caps / "ALL0001"), "--json", str(out))
    _refused(res, "m.json", "use --force to overwrite it")
    assert "force=True" not in res.err
    with pytest.raises(OutputExistsError, match="use force=True to overwrite it"):
        check_writable([out], force=False)

"""Discovery of experiment folders and role assignment (no identification: fast)."""

from __future__ import annotations


import pytest

from motorid.batch import discover_experiments
from motorid.batch.task import assign_roles
from motorid.errors import MotorIdError, OptionError


def test_every_layout_of_the_class_is_found(class_root):
    root, _ = class_root
    specs = {s.name: s for s in discover_experiments([root])}
    assert sorted(specs) == ["bad", "s00", "s01", "s02", "s03/run1"]
    assert specs["s00"].captures == (("ALL0000",), ("ALL0001",), ("ALL0002",))
    # loose Tektronix channel files are paired by their Fnnnn prefix
    assert specs["s01"].captures == (("F0000CH1.CSV", "F0000CH2.CSV"), ("F0001CH1.CSV", "F0001CH2.CSV"))
    # the manifest names the roles and the validation capture
    assert dict(specs["s02"].roles) == {"position": ("ALL0000",), "velocity": ("ALL0001",), "current": ("ALL0002",)}
    assert specs["s02"].validate == (("ALL0003",),)
    assert "manifest.csv" in specs["s02"].files
    assert specs["s03/run1"].captures == (("log.csv",),)
    assert not specs["s00"].roles


def test_output_folder_under_a_root_is_not_searched(tmp_path, class_root):
    import shutil

    root, _ = class_root
    shutil.copytree(root / "s00", tmp_path / "s00")
    out = tmp_path / "out"
    shutil.copytree(root / "s00", out / "s00")  # outputs that look like captures
    names = [s.name for s in discover_experiments([tmp_path], skip=out)]
    assert names == ["s00"]


def test_a_root_that_is_the_experiment_is_named_by_its_folder(class_root):
    root, _ = class_root
    (spec,) = discover_experiments([root / "s00"])
    assert spec.name == "s00"


def test_same_names_under_two_roots_get_their_root_prefixed(tmp_path, class_root):
    import shutil

    root, _ = class_root
    for section in ("monday", "tuesday"):
        shutil.copytree(root / "s00", tmp_path / section / "s00")
    names = [s.name for s in discover_experiments([tmp_path / "monday", tmp_path / "tuesday"])]
    assert names == ["monday/s00", "tuesday/s00"]


def test_experiment_toml_names_roles_and_options(tmp_path, class_root):
    import shutil

    root, _ = class_root
    shutil.copytree(root / "s00", tmp_path / "e")
    (tmp_path / "e" / "experiment.toml").write_text(
        'velocity = "ALL0001"\nposition = "ALL0000"\nstep_volts = 5.92\ncolumns = {time = "t"}\n', encoding="utf-8")
    (spec,) = discover_experiments([tmp_path])
    assert dict(spec.roles) == {"position": ("ALL0000",), "velocity": ("ALL0001",)}
    assert spec.step_volts == 5.92 and dict(spec.columns) == {"time": "t"}
    assert spec.captures == (("ALL0000",), ("ALL0001",))  # ALL0002 is not named: not an input
    assert spec.segment is None
    plain_hash = spec.content_hash({})
    (tmp_path / "e" / "experiment.toml").write_text('velocity = "ALL0001"\nposition = "ALL0000"\nstep_volts = 5.92\n'
                                                    'columns = {time = "t"}\nsegment = 2\n', encoding="utf-8")
    (spec,) = discover_experiments([tmp_path])
    assert spec.segment == 2 and spec.content_hash({}) != plain_hash  # a rerun with another segment is not skipped
    assert not spec.counted_velocity
    segment_hash = spec.content_hash({})
    (tmp_path / "e" / "experiment.toml").write_text('velocity = "ALL0001"\nposition = "ALL0000"\nstep_volts = 5.92\n'
                                                    'columns = {time = "t"}\nsegment = 2\ncounted_velocity = true\n',
                                                    encoding="utf-8")
    (spec,) = discover_experiments([tmp_path])
    assert spec.counted_velocity and spec.content_hash({}) != segment_hash


@pytest.mark.parametrize(("text", "words"), [
    ('velocity = "ALL0009"\n', "ALL0009, which does not exist"),
    ('velocity = "ALL0001"\nspeed = 3\n', "unknown key(s) speed"),
    ('current = "ALL0002"\n', "no velocity or position"),
    ("velocity = \n", "not valid TOML"),
    ('velocity = "ALL0001"\nsegment = 0\n', "segment = 0: give a whole number"),
    ('velocity = "ALL0001"\nsegment = "2"\n', "segment = '2': give a whole number"),
    ('velocity = "ALL0001"\ncounted_velocity = "yes"\n', "counted_velocity = 'yes': give true or false"),
    ('position = "ALL0000"\ncounted_velocity = true\n', "counted_velocity = true describes a velocity capture"),
])
def test_bad_experiment_toml_is_one_line_naming_the_file(tmp_path, class_root, text, words):
    import shutil

    root, _ = class_root
    shutil.copytree(root / "s00", tmp_path / "e")
    (tmp_path / "e" / "experiment.toml").write_text(text, encoding="utf-8")
    with pytest.raises(OptionError) as err:
        discover_experiments([tmp_path])
    msg = str(err.value)
    assert words in msg and "experiment.toml" in msg and "\n" not in msg


def test_bad_manifest_row_is_named(tmp_path, class_root):
    import shutil

    root, _ = class_root
    shutil.copytree(root / "s00", tmp_path / "e")
    (tmp_path / "e" / "manifest.csv").write_text("role,path\nvelocity,ALL0001\nspeed,ALL0000\n", encoding="utf-8")
    with pytest.raises(OptionError, match=r"manifest\.csv:3: role 'speed'"):
        discover_experiments([tmp_path])


def test_nothing_found_and_missing_root_are_user_errors(tmp_path):
    (tmp_path / "notes.txt").write_text("hello", encoding="utf-8")
    with pytest.raises(OptionError, match="no experiments found"):
        discover_experiments([tmp_path])
    with pytest.raises(MotorIdError, match="no such folder"):
        discover_experiments([tmp_path / "nowhere"])


def test_content_hash_follows_file_content_and_settings(tmp_path, class_root):
    import shutil

    root, _ = class_root
    shutil.copytree(root / "s00", tmp_path / "e")
    (spec,) = discover_experiments([tmp_path])
    h = spec.content_hash({"method": "auto"})
    assert spec.content_hash({"method": "auto"}) == h
    assert spec.content_hash({"method": "oe"}) != h
    f = tmp_path / "e" / "ALL0002" / "F0002CH2.CSV"
    f.write_bytes(f.read_bytes().replace(b"0", b"1", 1))
    assert spec.content_hash({"method": "auto"}) != h


def test_roles_are_guessed_and_the_rest_left_for_validation(class_root):
    from motorid.io import read_capture

    root, _ = class_root
    folder = root / "s02"  # position, velocity, current and a sine capture
    (spec,) = [s for s in discover_experiments([root]) if s.name == "s02"]
    caps = {key: read_capture(folder / key[0]) for key in spec.captures}
    roles, others = assign_roles(caps)
    # the trainer wrote them in the paper's order: ALL0000 position, ALL0001 velocity, ALL0002 current
    assert roles == {"position": ("ALL0000",), "velocity": ("ALL0001",), "current": ("ALL0002",)}
    assert others == [("ALL0003",)]


def test_two_captures_of_one_role_are_refused(class_root):
    from motorid.io import read_capture

    root, _ = class_root
    vel = read_capture(root / "s00" / "ALL0001")
    caps = {("ALL0001",): vel, ("copy",): vel}
    with pytest.raises(OptionError, match=r"2 captures look like velocity \(ALL0001, copy\)"):
        assign_roles(caps)


def test_settings_check_options_and_fingerprint_what_changes_a_result():
    from motorid.batch import BatchSettings

    base = BatchSettings().fingerprint()
    assert BatchSettings(identify={"method": "auto"}).fingerprint() == base  # the default, spelt out
    assert BatchSettings(identify={"method": "oe"}).fingerprint() != base
    assert BatchSettings(report=False).fingerprint() != base
    with pytest.raises(OptionError, match="unknown identify option"):
        BatchSettings(identify={"mehtod": "oe"})
    with pytest.raises(OptionError, match="order"):
        BatchSettings(identify={"order": 7})


def test_specs_settings_and_outcomes_survive_pickling(class_root):
    """Tasks and results cross process boundaries (loky, Dask) as pickles."""
    import pickle

    from motorid.batch import BatchSettings, ExperimentOutcome

    root, _ = class_root
    spec = next(s for s in discover_experiments([root]) if s.name == "s02")
    settings = BatchSettings(identify={"method": "oe"}, columns={"time": "t"}, design={"damping": 0.7, "wn": 5.0})
    outcome = ExperimentOutcome("s02", "ok", row={"dc_gain": 0.9, "warnings": []}, roles={"velocity": "ALL0001"})
    for obj in (spec, settings, outcome):
        assert pickle.loads(pickle.dumps(obj)) == obj


def test_of_two_velocity_looking_captures_the_step_from_rest_is_taken(class_root):
    """The demo's slow square wave shows one edge (+6.4 V → −6.35 V) and a settling velocity:
    it looks like a velocity step too; the step experiment is the one starting from 0 V."""
    from dataclasses import replace

    import numpy as np

    from motorid.io import read_capture

    root, _ = class_root
    vel = read_capture(root / "s00" / "ALL0001")
    square = replace(vel, input_v=np.where(vel.input_v > 0.5 * vel.input_v.max(), -6.35, 6.4))
    roles, others = assign_roles({("ALL0001",): vel, ("ALL0005",): square})
    assert roles == {"velocity": ("ALL0001",)} and others == [("ALL0005",)]
    # neither from rest: still refused, as two steps from rest are
    shifted = replace(vel, input_v=vel.input_v + 3.0)
    with pytest.raises(OptionError, match="2 captures look like velocity"):
        assign_roles({("ALL0001",): shifted, ("ALL0005",): square})


def test_a_text_log_is_a_capture_and_a_note_is_not(tmp_path):
    """A serial monitor's log saved as ``.txt`` was passed over without a word (the class's summary
    simply had one experiment fewer); now a ``.txt``/``.log``/``.dat`` file whose content reads as a
    log is a capture, and a student's notes are still left alone."""
    folder = tmp_path / "class" / "dana"
    folder.mkdir(parents=True)
    (folder / "serial.txt").write_text("".join(f"t:{0.01 * k:.2f},u:{6.0 * (k >= 50):.1f},rpm:{k:.1f}\n"
                                               for k in range(200)))
    (folder / "notes.txt").write_text("the motor got warm after the third run\n")
    (folder / "run.log").write_text("time,voltage,speed\n" + "".join(f"{0.01 * k:.2f},{6.0 * (k >= 50):.1f},{k}\n"
                                                                     for k in range(200)))
    (spec,) = discover_experiments([tmp_path / "class"])
    assert spec.captures == (("run.log",), ("serial.txt",))


def test_folders_with_files_but_no_capture_are_named(tmp_path):
    """A student who handed in a photo of the scope was missing from the summary without a word."""
    from motorid.batch.discover import folders_without_captures

    root = tmp_path / "class"
    (root / "erin").mkdir(parents=True)
    (root / "erin" / "log.csv").write_text("time,voltage,speed\n" + "".join(
        f"{0.01 * k:.2f},{6.0 * (k >= 50):.1f},{k}\n" for k in range(200)))
    (root / "finn").mkdir()
    (root / "finn" / "scope.jpg").write_bytes(b"\xff\xd8\xff")
    (root / "finn" / "notes.txt").write_text("forgot to save the CSV\n")
    (root / "week2" / "gus").mkdir(parents=True)  # an empty folder is nobody's hand-in
    (root / "instructions.pdf").write_bytes(b"%PDF")  # the root's own files are not a folder of it
    assert folders_without_captures([root]) == [("finn", ("notes.txt", "scope.jpg"))]
    assert [s.name for s in discover_experiments([root])] == ["erin"]


@pytest.mark.slow
def test_a_class_of_counted_speed_logs_with_one_flag(tmp_path, run_cli):
    """``motorid batch --counted-velocity``: every experiment with a velocity log is fitted as counted (the
    model JSON's ``timing.velocity.window_s``), an experiment with only a position is identified as it is,
    and a rerun without the flag is not served from the counted results."""
    import json

    from motorid.trainer.realsetups import write_real_setup

    root = tmp_path / "class"
    for name, rig in (("ann", "l298n-rpm"), ("bob", "l298n-rpm"), ("cem", "host-loop")):
        rec = write_real_setup(rig, tmp_path / "rigs" / name, seed=len(name) + ord(name[0]) % 3)
        (root / name).mkdir(parents=True)
        log = rec.files["log"]
        (root / name / log.name).write_bytes(log.read_bytes())
        role = "velocity" if rig == "l298n-rpm" else "position"
        (root / name / "experiment.toml").write_text(f'{role} = "{log.name}"\n', encoding="utf-8")
    out = tmp_path / "out"
    res = run_cli("batch", root, "--out", out, "--jobs", "1", "--no-report", "--counted-velocity")
    assert res.code == 0, res.err
    windows = {name: json.loads((out / name / "model.json").read_text())["timing"]
               .get("velocity", {}).get("window_s") for name in ("ann", "bob", "cem")}
    assert windows["ann"] == pytest.approx(0.01) and windows["bob"] == pytest.approx(0.01)
    assert windows["cem"] is None
    res = run_cli("batch", root, "--out", out, "--jobs", "1", "--no-report")
    assert res.code == 0, res.err
    model = json.loads((out / "ann" / "model.json").read_text())
    assert "window_s" not in model["timing"]["velocity"]  # recomputed, not served from the counted run

"""Atomic outputs: all of a command's files appear together, or none does."""

from __future__ import annotations

import errno
import io

import pytest

from motorid.io import OutputWriteError, atomic_folder, atomic_outputs

PARAMS = ["model", "from-params", "--km", "249.3", "--kT", "3.61e-3", "--gear", "1/36", "--k0", "0.25", "--Tm", "0.55"]


def test_commit_writes_all_and_leaves_no_temporaries(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.html"
    with atomic_outputs() as outs:
        outs.write_text(a, "A")
        outs.write_text(b, "B")
        assert not a.exists() and not b.exists()  # nothing visible before the commit
    assert a.read_text() == "A" and b.read_text() == "B"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json", "b.html"]


def test_failure_leaves_targets_untouched(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.html"
    a.write_text("old")
    with pytest.raises(RuntimeError), atomic_outputs() as outs:
        outs.write_text(a, "new")
        raise RuntimeError("the report failed")
    assert a.read_text() == "old" and not b.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["a.json"]


def test_disk_full_is_one_error_and_no_partial_file(tmp_path, monkeypatch):
    a = tmp_path / "a.json"

    real_open = open

    class Full(io.StringIO):
        def write(self, s):
            raise OSError(errno.ENOSPC, "No space left on device")

    def fake_open(path, mode="r", *args, **kw):
        if "w" in mode and str(path).startswith(str(tmp_path)):
            real_open(path, mode, *args, **kw).close()  # the file exists, then the disk is full
            return Full()
        return real_open(path, mode, *args, **kw)

    monkeypatch.setattr("builtins.open", fake_open)
    with pytest.raises(OutputWriteError, match="disk is full"), atomic_outputs() as outs:
        outs.write_text(a, "x" * 1000)
    assert list(tmp_path.iterdir()) == []


def test_cli_disk_full_exit_2_one_line_nothing_written(tmp_path, monkeypatch, run_cli):
    import motorid.io.atomic as atomic

    def full(self, target, text, encoding="utf-8"):
        tmp = self.path(target)
        tmp.write_text(text[: len(text) // 2])  # a partial temporary file, then ENOSPC
        self.discard()
        raise atomic.write_error(target, OSError(errno.ENOSPC, "No space left on device"))

    monkeypatch.setattr(atomic.AtomicOutputs, "write_text", full)
    out = tmp_path / "m.json"
    res = run_cli(*PARAMS, "--json", str(out))
    assert res.code == 2, res
    lines = [ln for ln in res.err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "disk is full" in lines[0] and "m.json" in lines[0]
    assert list(tmp_path.iterdir()) == []


def test_cli_png_failure_removes_csv_and_json(tmp_path, monkeypatch, run_cli):
    """simulate: the plot fails after the CSV and JSON were rendered: none of the three appears."""
    model = tmp_path / "m.json"
    design = tmp_path / "d.json"
    assert run_cli(*PARAMS, "--json", str(model)).code == 0
    assert run_cli("design", str(model), "--k2", "8.5", "--damping", "1", "--json", str(design)).code == 0
    import motorid.simulation.closed_loop as cl

    def boom(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(cl, "plot_simulation", boom)
    before = sorted(p.name for p in tmp_path.iterdir())
    res = run_cli("simulate", str(model), str(design), "--duration", "1", "--csv", str(tmp_path / "s.csv"),
                  "--json", str(tmp_path / "s.json"), "--png", str(tmp_path / "s.png"))
    assert res.code == 2 and "s.png" in res.err and "disk is full" in res.err, res
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def test_atomic_folder_restores_on_failure(tmp_path):
    out = tmp_path / "demo"
    out.mkdir()
    (out / "model.json").write_text("old model")
    (out / "keep.txt").write_text("not a target")
    with pytest.raises(OutputWriteError), atomic_folder(out, [out / "model.json", out / "ALL0000"]):
        (out / "ALL0000").mkdir()
        (out / "ALL0000" / "F0000CH1.CSV").write_text("partial")
        (out / "model.json").write_text("new model")
        raise OSError(errno.ENOSPC, "No space left on device")
    assert (out / "model.json").read_text() == "old model"
    assert sorted(p.name for p in out.iterdir()) == ["keep.txt", "model.json"]


def test_atomic_folder_removes_a_folder_it_created(tmp_path):
    out = tmp_path / "new"
    with pytest.raises(KeyboardInterrupt), atomic_folder(out, [out / "truth.json"]):
        (out / "truth.json").write_text("{}")
        raise KeyboardInterrupt
    assert not out.exists()


def test_demo_disk_full_puts_back_the_previous_demo(tmp_path, monkeypatch, run_cli):
    """demo --force over an earlier demo, failing at the report: the earlier files are back."""
    out = tmp_path / "demo"
    out.mkdir()
    (out / "model.json").write_text("earlier model")
    import motorid.report.assemble as rep

    def boom(*a, **k):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(rep, "make_report", boom)
    res = run_cli("demo", "--out", str(out), "--force")
    assert res.code == 2 and "disk is full" in res.err, res
    assert sorted(p.name for p in out.iterdir()) == ["model.json"]
    assert (out / "model.json").read_text() == "earlier model"


def test_an_output_that_is_not_a_regular_file_is_refused_and_left_alone(tmp_path, run_cli):
    """A rename at commit replaces whatever is at the target: as root, `--json /dev/full
    --force` turned the device node into a regular file.  A FIFO stands in for a device here
    (a test must not risk the machine's /dev if the code regresses)."""
    import os
    import stat

    from motorid.trainer.experiment import run_experiment
    from motorid.io import write_tds_capture

    fifo = tmp_path / "out.json"
    os.mkfifo(fifo)
    with pytest.raises(OutputWriteError, match="named pipe"), atomic_outputs() as outs:
        outs.write_text(fifo, "{}")
    assert stat.S_ISFIFO(os.stat(fifo).st_mode)
    e = run_experiment("second-order", seed=1, roles=("velocity",), validation=False)
    cap = write_tds_capture(tmp_path / "ALL0001", e.captures["velocity"], index=1)
    for option in ("--json", "--report", "--matlab"):
        res = run_cli("identify", "--velocity", cap, option, fifo, "--force")
        assert res.code == 2 and "not a file" in res.err and len(res.err.strip().splitlines()) == 1
        assert stat.S_ISFIFO(os.stat(fifo).st_mode)

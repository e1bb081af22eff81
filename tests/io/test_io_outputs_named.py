"""Outputs are what the user named: a symlink is refused without --force, and of two runs that
write the same file without --force one gets the one-line "exists" error."""

from __future__ import annotations

import os
import threading

import pytest

from motorid.errors import OutputExistsError
from motorid.io import atomic_outputs, check_writable


@pytest.mark.parametrize("kind", ["dangling", "looping", "to a file"])
def test_a_symlink_output_is_refused_without_force(tmp_path, kind):
    link = tmp_path / "m.json"
    if kind == "dangling":
        link.symlink_to(tmp_path / "nowhere.json")
    elif kind == "looping":
        link.symlink_to(link)
    else:
        (tmp_path / "real.json").write_text("{}")
        link.symlink_to(tmp_path / "real.json")
    with pytest.raises(OutputExistsError, match="symbolic link"):
        check_writable({"--json": link}, force=False, create_parents=False)
    check_writable({"--json": link}, force=True, create_parents=False)
    with atomic_outputs() as outs:  # --force: the file replaces the link, not what it points to
        outs.write_text(link, "new")
    assert not link.is_symlink() and link.read_text() == "new"
    if kind == "to a file":
        assert (tmp_path / "real.json").read_text() == "{}"


def test_the_command_line_refuses_a_dangling_symlink(tmp_path, demo_run, run_cli):
    link = tmp_path / "m.json"
    link.symlink_to(tmp_path / "nowhere.json")
    res = run_cli("identify", "--velocity", demo_run.folder / "ALL0001", "--method", "classic", "--json", link)
    assert res.code == 2 and "symbolic link" in res.err
    assert link.is_symlink() and not (tmp_path / "nowhere.json").exists()


def test_of_two_writers_without_force_one_is_refused(tmp_path):
    target = tmp_path / "m.json"
    check_writable([target], force=False)  # both runs checked before either wrote
    results: list[str] = []
    barrier = threading.Barrier(2)

    def run(text: str) -> None:
        try:
            with atomic_outputs(exclusive=True) as outs:
                outs.write_text(target, text)
                barrier.wait()
            results.append("written")
        except OutputExistsError as exc:
            results.append(str(exc))

    threads = [threading.Thread(target=run, args=(t,)) for t in ("a", "b")]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert sorted(r == "written" for r in results) == [False, True], results
    assert "another run wrote it meanwhile" in next(r for r in results if r != "written")
    assert target.read_text() in ("a", "b")
    assert [p.name for p in tmp_path.iterdir()] == ["m.json"]  # no .part left


def test_an_exclusive_commit_is_all_or_nothing(tmp_path):
    (tmp_path / "b.m").write_text("someone else's")
    with pytest.raises(OutputExistsError), atomic_outputs(exclusive=True) as outs:
        outs.write_text(tmp_path / "a.json", "mine")
        outs.write_text(tmp_path / "b.m", "mine")
    assert sorted(os.listdir(tmp_path)) == ["b.m"] and (tmp_path / "b.m").read_text() == "someone else's"

"""The JSON API (POST /api/identify, /api/design, /api/simulate) against the front
door, and every kind of bad upload: HTTP 422, one line (the CLI's), nothing left behind."""

from __future__ import annotations

import io
import multiprocessing.util
import stat
import tempfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
from webhelpers import multipart, open_tab

import motorid as mi


def _pairs(demo_run, *roles_idx):
    d = demo_run.folder
    out = []
    for role, i in roles_idx:
        out += multipart(role, [d / f"ALL{i:04d}" / f"F{i:04d}CH1.CSV", d / f"ALL{i:04d}" / f"F{i:04d}CH2.CSV"])
    return out


def test_api_identify_is_the_front_door_on_the_same_files(client, demo_run):
    files = _pairs(demo_run, ("position", 0), ("velocity", 1))
    res = client.post("/api/identify", files=files, data={"method": "pinv", "order": "2"})
    assert res.status_code == 200, res.text
    d = demo_run.folder
    want = mi.identify(mi.read_experiment(position=d / "ALL0000", velocity=d / "ALL0001"), method="pinv",
                       order=2).to_json()
    got = res.json()
    assert got["schema"] == "motorid.model/1" and got["method"] == "pinv" and got["order"] == 2
    np.testing.assert_allclose(got["state_space"]["A"], want["state_space"]["A"], rtol=1e-9)
    assert got["first_order"]["dc_gain"] == pytest.approx(want["first_order"]["dc_gain"], rel=1e-9)


def test_api_identify_zip_of_a_scope_folder(client, demo_run):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for p in sorted((demo_run.folder / "ALL0001").iterdir()):
            zf.write(p, f"ALL0001/{p.name}")
    res = client.post("/api/identify", files=[("velocity", ("ALL0001.zip", buf.getvalue(), "application/zip"))],
                      data={"method": "classic"})
    assert res.status_code == 200, res.text
    want = mi.identify(mi.read_experiment(velocity=demo_run.folder / "ALL0001"), method="classic").to_json()
    assert res.json()["first_order"] == pytest.approx(want["first_order"], rel=1e-9)


def test_api_design_and_simulate_are_the_front_door(client, demo_run):
    model_json = demo_run.result.identification.model.to_json()
    res = client.post("/api/design", json={"model": model_json, "damping": 0.7, "wn": 5.0, "integral": True,
                                           "observer_poles": "-40,-45,-50,-55", "robust_samples": 0})
    assert res.status_code == 200, res.text
    model = mi.MotorModel.from_json(model_json)
    want = mi.design(model, damping=0.7, wn=5.0, integral=True, observer_poles=[-40, -45, -50, -55],
                     robust_samples=0)
    got = res.json()
    assert got["schema"] == "motorid.design/1"
    np.testing.assert_allclose(got["K"], want.K, rtol=1e-9)
    assert got["ki"] == pytest.approx(want.ki, rel=1e-9)
    np.testing.assert_allclose(got["L"], want.L, rtol=1e-9)

    res = client.post("/api/simulate", json={"model": model_json, "design": got, "duration_s": 2.0,
                                             "saturation": 10.0, "level_v": 3.0})
    assert res.status_code == 200, res.text
    sim = mi.simulate(model, want, duration_s=2.0, saturation=10.0, level_v=3.0)
    body = res.json()
    assert body["schema"] == "motorid.simulation/1"
    assert body["metrics"]["overshoot_pct"] == pytest.approx(sim.metrics.overshoot_pct, rel=1e-9, abs=1e-12)
    np.testing.assert_allclose(body["series"]["output"], sim.output_v, rtol=1e-9, atol=1e-12)


# ------------------------------------------------------------------------------ bad input


def _one_line_422(res, *needles: str) -> str:
    assert res.status_code == 422, res.text
    line = res.json()["detail"] if res.headers["content-type"].startswith("application/json") else res.text
    assert "\n" not in line
    assert "motorid: error: " in line
    for n in needles:
        assert n in line, line
    return line


@pytest.fixture
def sealed_tmp(tmp_path, monkeypatch):
    """The system temp folder of this process, redirected to an empty folder that must stay
    empty: nothing of an upload may be spooled outside the app's own folder.

    The process's own multiprocessing folder (``pymp-…``, where the web worker's forkserver
    keeps its socket) is made first, in the real temp folder: whichever test starts the
    forkserver first (another file's, or none under ``pytest -n``), its socket is not an upload
    and its path must stay short enough for AF_UNIX."""
    multiprocessing.util.get_temp_dir()
    sys_tmp = tmp_path / "system-tmp"
    sys_tmp.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(sys_tmp))
    yield sys_tmp
    assert list(sys_tmp.iterdir()) == []


def _only_open_tabs(web_root: Path) -> list[Path]:
    """Every file under the app's root (refused uploads must have left nothing)."""
    return sorted(p for p in web_root.rglob("*") if p.is_file())


def _zip(members: dict[str, bytes], links: dict[str, str] | None = None) -> bytes:
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED) as zf:
        for name, data in members.items():
            zf.writestr(name, data)
        for name, target in (links or {}).items():
            info = zipfile.ZipInfo(name)
            info.external_attr = (stat.S_IFLNK | 0o777) << 16
            zf.writestr(info, target)
    return buf.getvalue()


@pytest.mark.parametrize(("case", "needle"), [
    ("not-a-capture", "not a capture"),
    ("no-files", "no capture in the fields velocity or position"),
    ("not-a-capture-file", "field velocity: truth.json is not a capture file"),
    ("stray-field", "files in field 'voltage'"),
    ("two-captures", "field velocity holds 2 captures"),
    ("unknown-option", "unknown field 'colour'"),
    ("bad-number", "step_volts='five'"),
    ("bad-method", "method"),
    ("broken-zip", "not a readable zip archive"),
    ("json-body", "multipart/form-data"),
])
def test_api_identify_refuses_bad_uploads(client, demo_run, web_root, sealed_tmp, case, needle):
    d = demo_run.folder
    good = _pairs(demo_run, ("velocity", 1))
    kw: dict = {}
    if case == "not-a-capture":
        kw = {"files": [("velocity", ("scope.csv", b"\x00\x01 this is no capture\n" * 50, "text/csv"))]}
    elif case == "no-files":
        kw = {"data": {"method": "auto"}, "files": [("current", ("x.csv", (d / "ALL0002/F0002CH2.CSV").read_bytes()))]}
    elif case == "not-a-capture-file":
        kw = {"files": [("velocity", ("truth.json", (d / "truth.json").read_bytes(), "application/json"))]}
    elif case == "stray-field":
        kw = {"files": [*good, ("voltage", ("F0009CH1.CSV", b"1,2\n"))]}
    elif case == "two-captures":
        kw = {"files": [*good, *multipart("velocity", [d / "ALL0002/F0002CH1.CSV"], ["other.csv"])]}
    elif case == "unknown-option":
        kw = {"files": good, "data": {"colour": "red"}}
    elif case == "bad-number":
        kw = {"files": good, "data": {"step_volts": "five"}}
    elif case == "bad-method":
        kw = {"files": good, "data": {"method": "magic"}}
    elif case == "broken-zip":
        kw = {"files": [("velocity", ("ALL0001.zip", b"PK\x03\x04 broken", "application/zip"))]}
    elif case == "json-body":
        kw = {"json": {"velocity": "/etc/passwd"}}
    line = _one_line_422(client.post("/api/identify", **kw), needle)
    assert str(web_root) not in line  # no server path in the message
    assert _only_open_tabs(web_root) == []


def test_upload_limits_size_and_count(make_client, demo_files, web_root, sealed_tmp):
    small = make_client(max_upload_mb=0.1, max_files=3)
    tab = open_tab(small)
    big = demo_files[:2]  # 2 × 78 kB > 0.1 MB
    res = small.post(f"/tab/{tab}/upload", files=multipart("files", big))
    _one_line_422(res, "more than the limit of 0.1 MB", "--max-upload-mb")
    many = [("files", (f"F{i:04d}CH1.CSV", b"x\n")) for i in range(4)]
    _one_line_422(small.post(f"/tab/{tab}/upload", files=many), "more than 3 files")
    _one_line_422(small.post("/api/identify", files=many), "more than 3 files")
    # a zip that unpacks past 4 × the upload limit, and one holding more members than allowed
    bomb = _zip({"ALL0000/F0000CH1.CSV": b"0" * 600_000})
    assert len(bomb) < 0.1 * 2**20
    _one_line_422(small.post(f"/tab/{tab}/upload", files=[("files", ("b.zip", bomb))]), "b.zip", "unpacks to more")
    crowd = _zip({f"f{i}.csv": b"1" for i in range(5)})
    _one_line_422(small.post(f"/tab/{tab}/upload", files=[("files", ("c.zip", crowd))]), "more than 3 files")
    assert _only_open_tabs(web_root) == []  # every refused upload was removed, nothing else written


def test_zip_slip_links_and_traversing_names_stay_inside(client, demo_run, web_root, tmp_path, sealed_tmp):
    d = demo_run.folder
    ch1, ch2 = (d / "ALL0001/F0001CH1.CSV").read_bytes(), (d / "ALL0001/F0001CH2.CSV").read_bytes()
    evil = _zip({"../../../../escaped/F0001CH1.CSV": ch1, "/abs/F0001CH2.CSV": ch2, "..\\..\\win.csv": ch1},
                links={"ALL0009/F0009CH1.CSV": "/etc/passwd"})
    tab = open_tab(client)
    files = [("files", ("evil.zip", evil, "application/zip")),
             ("files", ("../../../outside/F0003CH1.CSV", ch1, "text/csv")),
             ("files", ("/etc/cron.d/F0003CH2.CSV", ch2, "text/csv"))]
    res = client.post(f"/tab/{tab}/upload", files=files)
    assert res.status_code == 200, res.text
    stored = _only_open_tabs(web_root)
    tab_dir = next(web_root.iterdir()) / f"tab-{tab}"
    assert stored and all(tab_dir in p.parents for p in stored)
    assert not any(p.is_symlink() for p in tab_dir.rglob("*"))
    assert not any("F0009" in p.name for p in stored)  # the link was skipped
    # nothing appeared beside the root or anywhere up the tree the names pointed at
    assert sorted(p.name for p in tmp_path.iterdir()) == ["root", "system-tmp"]
    for p in (Path("/escaped"), Path("/abs"), Path("/outside"), tmp_path / "escaped"):
        assert not p.exists()
    # and the captures are usable: the pair sent with traversing names is one capture
    assert "outside/F0003CH1.CSV + F0003CH2.CSV" not in res.text  # folders of other names do not pair
    assert res.text.count("<tr id=\"row-") >= 3


@pytest.mark.parametrize(("body", "needle"), [
    (b"{not json", "not JSON"),
    (b"[1, 2]", "must be a JSON object"),
    (b'{"damping": 0.7, "wn": 5}', '"model"'),
    (b'{"model": {"schema": "x"}, "damping": 0.7, "wn": 5}', "schema"),
])
def test_api_design_refuses_bad_bodies(client, body, needle):
    _one_line_422(client.post("/api/design", content=body, headers={"content-type": "application/json"}), needle)


def test_api_design_and_simulate_refuse_bad_options(client, demo_run):
    model_json = demo_run.result.identification.model.to_json()
    _one_line_422(client.post("/api/design", json={"model": model_json, "damping": "high", "wn": 5}), "damping")
    _one_line_422(client.post("/api/design", json={"model": model_json, "zeta": 0.7}), "unknown field 'zeta'")
    # the message names the fields as the client sent them, not the command line's flags
    msg = _one_line_422(client.post("/api/design", json={"model": model_json, "damping": 0.7}),
                        "damping needs exactly one of k2 (the report's design) or wn")
    assert "--" not in msg, msg
    des = client.post("/api/design", json={"model": model_json, "damping": 0.7, "wn": 5}).json()
    _one_line_422(client.post("/api/simulate", json={"model": model_json}), '"design"')
    _one_line_422(client.post("/api/simulate", json={"model": model_json, "design": des, "duration_s": -1}),
                  "duration_s")
    _one_line_422(client.post("/api/simulate", json={"model": model_json, "design": {"K": [1]}}), "design")
    _one_line_422(client.post("/api/simulate", json={"model": model_json, "design": des, "anti_windup": "yes"}),
                  "anti_windup")
    _one_line_422(client.post("/api/simulate", json={"model": model_json, "design": des | {"margins": {"ms": "big"}}}),
                  "margins.ms")

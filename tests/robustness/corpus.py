"""The robustness corpus: malformed and unusual inputs, built into a folder.

Every :class:`Case` is one command line as a new user or a careless script would type it,
with the files it needs built by :func:`build` into ``root/<case id>/``.  ``{d}`` in an
argument is the case's own folder (every output goes there), ``{b}`` the shared base folder of
valid captures and model/design files (:func:`build_base`).

Expectations (checked by ``test_corpus.py``):

- ``refuse``: exit 2, 1–3 lines on stderr, the first naming ``names`` (file or option);
- ``ok``: exit 0, and each of ``warns`` somewhere in the output;
- ``clean``: exit 0 or 2 (the input is odd but may be legal), never an internal error;
- always: no traceback or "internal error", nothing in the case folder written or changed on
  a failure, inside the time limit.

``hang`` cases (FIFOs, devices) run one per subprocess with a hard timeout.
"""

from __future__ import annotations

import json
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

#: The trainer preset and seed behind every valid base capture.
PRESET, SEED, STEP_V = "paper", 0, 5.92


@dataclass(frozen=True)
class Case:
    """One command line of the corpus and what it must do."""

    id: str
    group: str
    argv: tuple[str, ...]
    expect: str = "refuse"  # refuse | ok | clean
    names: tuple[str, ...] = ()
    warns: tuple[str, ...] = ()
    make: Callable[[Path, Path], None] | None = field(default=None, compare=False, repr=False)
    hang: bool = False

    def args(self, case_dir: Path, base: Path) -> list[str]:
        return [a.replace("{d}", str(case_dir)).replace("{b}", str(base)) for a in self.argv]


# --- the valid base ---------------------------------------------------------------------------

def build_base(base: Path) -> None:
    """Valid captures (TDS folders, plain CSV), a model JSON and a design JSON."""
    from motorid.control.design import DesignSettings, design_controller
    from motorid.control.params import MotorParams, model_from_params
    from motorid.io import write_tds_capture
    from motorid.trainer import run_experiment

    base.mkdir(parents=True, exist_ok=True)
    exp = run_experiment(PRESET, seed=SEED, step_volts=STEP_V)
    for i, role in enumerate(("position", "velocity", "current")):
        write_tds_capture(base, exp.captures[role], index=i)
    write_tds_capture(base, exp.validation["sine"], index=3)
    v = exp.captures["velocity"]
    np.save(base / "vel_t.npy", v.time_s)
    np.save(base / "vel_u.npy", v.input_v)
    np.save(base / "vel_y.npy", v.output_v)
    (base / "vel.csv").write_text(plain_csv(v.time_s, v.input_v, v.output_v), encoding="utf-8")
    model = model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))
    (base / "model.json").write_text(model.to_json_text() + "\n", encoding="utf-8")
    d = design_controller(model, DesignSettings(damping=1.0, k2=8.5))
    (base / "design.json").write_text(d.to_json_text() + "\n", encoding="utf-8")


def plain_csv(t, u, y, *, sep: str = ",", newline: str = "\n", header: str = "time,input,velocity") -> str:
    rows = [header.replace(",", sep)] + [f"{a:.6f}{sep}{b:.6g}{sep}{c:.6g}" for a, b, c in zip(t, u, y, strict=False)]
    return newline.join(rows) + newline


def _vel(base: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return np.load(base / "vel_t.npy"), np.load(base / "vel_u.npy"), np.load(base / "vel_y.npy")


# --- file-level inputs: each is given to identify, inspect and validate ------------------------

def _tds_text(base: Path, ch: int = 2) -> str:
    return (base / "ALL0001" / f"F0001CH{ch}.CSV").read_text(encoding="utf-8")


def _copy_pair(base: Path, d: Path) -> Path:
    dst = d / "ALL0001"
    shutil.copytree(base / "ALL0001", dst)
    return dst


def _f_write(name: str, content: Callable[[Path], str | bytes]) -> Callable[[Path, Path], None]:
    def make(d: Path, base: Path) -> None:
        data = content(base)
        p = d / name
        if isinstance(data, bytes):
            p.write_bytes(data)
        else:
            p.write_text(data, encoding="utf-8", newline="")
    return make


def _rows(base: Path, edit: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple], **kw) -> str:
    t, u, y = _vel(base)
    return plain_csv(*edit(t.copy(), u.copy(), y.copy()), **kw)


def _nan_row(t, u, y):
    y[1000] = np.nan
    return t, u, y


def _inf_row(t, u, y):
    y[1200] = np.inf
    return t, u, y


def _dup_time(t, u, y):
    t[500] = t[499]
    return t, u, y


def _desc_time(t, u, y):
    return t[::-1], u, y


def _const_time(t, u, y):
    return np.zeros_like(t), u, y


def _huge(t, u, y):
    return t, np.full_like(u, 1e300), np.full_like(y, 1e300)


def _spike(t, u, y):
    y[1500] = 1e300
    return t, u, y


def _truncated(d: Path, base: Path) -> None:
    dst = _copy_pair(base, d)
    text = (dst / "F0001CH2.CSV").read_text(encoding="utf-8")
    (dst / "F0001CH2.CSV").write_text(text[: int(0.4 * len(text))], encoding="utf-8", newline="")


def _letter_in_tds(d: Path, base: Path) -> None:
    dst = _copy_pair(base, d)
    lines = (dst / "F0001CH2.CSV").read_text(encoding="utf-8").splitlines(keepends=True)
    lines[1000] = lines[1000].rsplit(",", 2)[0] + ",  abc,\n"
    (dst / "F0001CH2.CSV").write_text("".join(lines), encoding="utf-8", newline="")


def _pair_lengths(d: Path, base: Path) -> None:
    dst = _copy_pair(base, d)
    lines = (dst / "F0001CH2.CSV").read_text(encoding="utf-8").splitlines(keepends=True)
    (dst / "F0001CH2.CSV").write_text("".join(lines[:1500]), encoding="utf-8", newline="")


def _empty_dir(d: Path, base: Path) -> None:
    (d / "empty").mkdir()


def _fifo(d: Path, base: Path) -> None:
    os.mkfifo(d / "fifo.csv")


def _unreadable(d: Path, base: Path) -> None:
    p = d / "locked.csv"
    shutil.copy(base / "vel.csv", p)
    p.chmod(0)


def _xlsx_bomb(d: Path, base: Path) -> None:
    """A zip whose directory claims a huge sharedStrings.xml (it is really small)."""
    import zipfile

    p = d / "bomb.xlsx"
    with zipfile.ZipFile(p, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("[Content_Types].xml", "<Types/>")
        z.writestr("xl/workbook.xml", "<workbook/>")
        z.writestr("xl/sharedStrings.xml", "<sst>" + "<si><t>x</t></si>" * 200_000 + "</sst>")


def _xlsx_not_zip(d: Path, base: Path) -> None:
    shutil.copy(base / "vel.csv", d / "sheet.xlsx")


#: (id, file name given on the command line, builder, expectation).
FILE_INPUTS: list[tuple[str, str, Callable[[Path, Path], None] | None, str]] = [
    ("empty", "empty.csv", _f_write("empty.csv", lambda b: ""), "refuse"),
    ("binary", "binary.csv", _f_write("binary.csv", lambda b: bytes(np.random.default_rng(1).integers(0, 256, 4096, dtype=np.uint8))), "refuse"),
    ("text", "notes.csv", _f_write("notes.csv", lambda b: "hello world\nthis is not a capture\n"), "refuse"),
    ("header-only", "header.csv", _f_write("header.csv", lambda b: "time,input,velocity\n"), "refuse"),
    ("one-row", "one.csv", _f_write("one.csv", lambda b: "time,input,velocity\n0.0,0,0"), "refuse"),
    ("five-rows", "five.csv", _f_write("five.csv", lambda b: _rows(b, lambda t, u, y: (t[:5], u[:5], y[:5]))), "clean"),
    ("semicolon", "semi.csv", _f_write("semi.csv", lambda b: _rows(b, lambda *a: a, sep=";")), "clean"),
    ("tab", "tab.csv", _f_write("tab.csv", lambda b: _rows(b, lambda *a: a, sep="\t")), "clean"),
    ("bom", "bom.csv", _f_write("bom.csv", lambda b: "\ufeff" + _rows(b, lambda *a: a)), "ok"),
    ("crlf", "crlf.csv", _f_write("crlf.csv", lambda b: _rows(b, lambda *a: a, newline="\r\n")), "ok"),
    # Excel's "Unicode text": read whatever its size (beyond 64 KiB its head was cut inside a character)
    ("utf16", "utf16.csv", _f_write("utf16.csv", lambda b: _rows(b, lambda *a: a).encode("utf-16")), "ok"),
    ("huge-values", "huge.csv", _f_write("huge.csv", lambda b: _rows(b, _huge)), "refuse"),
    ("spike-1e300", "spike.csv", _f_write("spike.csv", lambda b: _rows(b, _spike)), "refuse"),
    ("nan-row", "nan.csv", _f_write("nan.csv", lambda b: _rows(b, _nan_row)), "refuse"),
    ("inf-row", "inf.csv", _f_write("inf.csv", lambda b: _rows(b, _inf_row)), "refuse"),
    ("dup-time", "dup.csv", _f_write("dup.csv", lambda b: _rows(b, _dup_time)), "refuse"),
    ("desc-time", "desc.csv", _f_write("desc.csv", lambda b: _rows(b, _desc_time)), "refuse"),
    ("const-time", "ctime.csv", _f_write("ctime.csv", lambda b: _rows(b, _const_time)), "refuse"),
    ("no-velocity-col", "cols.csv", _f_write("cols.csv", lambda b: _rows(b, lambda *a: a, header="time,input,other")), "clean"),
    ("long-line", "long.csv", _f_write("long.csv", lambda b: "time,input,velocity\n" + "1," * 300_000 + "\n"), "refuse"),
    ("truncated-tds", "ALL0001", _truncated, "refuse"),
    ("letter-in-tds", "ALL0001", _letter_in_tds, "refuse"),
    ("pair-lengths", "ALL0001", _pair_lengths, "refuse"),
    ("tds-ch1-only", "F0001CH1.CSV", _f_write("F0001CH1.CSV", lambda b: _tds_text(b, 1)), "clean"),
    ("empty-folder", "empty", _empty_dir, "refuse"),
    ("missing", "missing.csv", None, "refuse"),
    ("xlsx-not-zip", "sheet.xlsx", _xlsx_not_zip, "clean"),
    ("xlsx-garbage", "junk.xlsx", _f_write("junk.xlsx", lambda b: b"PK\x03\x04" + bytes(500)), "refuse"),
    ("xlsx-shared-strings", "bomb.xlsx", _xlsx_bomb, "refuse"),
    ("unreadable", "locked.csv", _unreadable, "clean"),  # root may read anything
    ("fifo", "fifo.csv", _fifo, "refuse"),
]
HANG_INPUTS = {"fifo"}


def file_cases() -> list[Case]:
    cases = []
    for fid, name, make, expect in FILE_INPUTS:
        target = "{d}/" + name
        names = (name,)
        for cmd, argv in (
            ("identify", ("identify", "--velocity", target, "--method", "pinv")),
            ("inspect", ("inspect", target)),
            ("validate", ("validate", "{b}/model.json", target, "--step-volts", str(STEP_V))),
        ):
            exp = expect
            if cmd == "validate" and expect == "ok":
                exp = "clean"  # the lab-report model need not fit the paper's motor
            cases.append(Case(f"file-{fid}-{cmd}", "file", argv, exp, names, make=make, hang=fid in HANG_INPUTS))
    # devices: a character device never ends (/dev/zero) or is empty (/dev/null)
    for dev in ("/dev/zero", "/dev/null", "/dev/urandom"):
        for cmd, argv in (("identify", ("identify", "--velocity", dev)), ("inspect", ("inspect", dev))):
            cases.append(Case(f"file-{Path(dev).name}-{cmd}", "file", argv, "refuse", (dev,), hang=True))
    return cases


# --- signal-level inputs: readable captures that cannot (or can barely) give a model ----------

def _tds_signal(edit: Callable[[np.ndarray, np.ndarray, np.ndarray], tuple], scale: float | None = None,
                csv: bool = False) -> Callable[[Path, Path], None]:
    def make(d: Path, base: Path) -> None:
        from motorid.io import write_tds_capture
        from motorid.io.tektronix import read_tds_capture

        t, u, y = _vel(base)
        t2, u2, y2 = edit(t.copy(), u.copy(), y.copy())
        if csv:
            (d / "sig.csv").write_text(plain_csv(t2, u2, y2), encoding="utf-8")
            return
        cap = read_tds_capture(base / "ALL0001")
        info = cap.output_info if scale is None else replace(cap.output_info, vertical_scale=scale)
        write_tds_capture(d, replace(cap, time_s=t2, input_v=u2, output_v=y2, output_info=info), index=1)
    return make


def _edge(t, u):
    return t[int(np.argmax(u > 0.5 * u.max()))]


SIGNALS: list[tuple[str, Callable, float | None, str, tuple[str, ...]]] = [
    # id, edit, volts/div override, expectation, warning (ok) or message words (refuse)
    ("stalled", lambda t, u, y: (t, u, np.zeros_like(y)), None, "refuse", ("does not move",)),
    ("stalled-offset", lambda t, u, y: (t, u, np.full_like(y, 1.2)), None, "refuse", ("does not move",)),
    ("noise-only", lambda t, u, y: (t, u, np.random.default_rng(3).normal(0, 0.1, y.size)), None, "refuse", ("does not move",)),
    ("sine-as-step", lambda t, u, y: (t, u, 2 * np.sin(2 * np.pi * 2 * t)), None, "refuse", ("does not move",)),
    ("flat-jump", lambda t, u, y: (t, u, np.where(t >= _edge(t, u), 3.0, 0.0)), None, "refuse", ("one sample",)),
    ("ch1-as-ch2", lambda t, u, y: (t, u, u.copy()), None, "refuse", ()),
    ("clipped-rail", lambda t, u, y: (t, u, np.minimum(y, 2.54)), 0.5, "refuse", ("clipped", "V/div")),
    ("clipped-no-rail", lambda t, u, y: (t, u, np.minimum(y, 3.0)), None, "ok", ("looks clipped",)),
    ("no-step", lambda t, u, y: (t, np.zeros_like(u), y), None, "refuse", ()),
    ("ramp", lambda t, u, y: (t, u, np.where(t >= _edge(t, u), 2.0 * (t - _edge(t, u)), 0.0)), None, "clean", ()),
    ("step-down", lambda t, u, y: (t, -u, -y), None, "ok", ()),
    ("inverted-output", lambda t, u, y: (t, u, -y), None, "clean", ()),
    ("tiny-response", lambda t, u, y: (t, u, 1e-3 * y + np.random.default_rng(4).normal(0, 0.02, y.size)), None, "refuse", ("does not move",)),
    ("settled-at-rail-free", lambda t, u, y: (t, u, y), None, "ok", ()),
]


def signal_cases() -> list[Case]:
    cases = []
    for sid, edit, scale, expect, words in SIGNALS:
        for kind, target, csv in (("tds", "{d}/ALL0001", False), ("csv", "{d}/sig.csv", True)):
            if csv and scale is not None:
                continue  # the rail needs the scope's metadata; the no-rail case covers CSV
            name = "ALL0001" if not csv else "sig.csv"
            warns = words if expect == "ok" else ()
            names = (name, *words) if expect == "refuse" else ()
            # --force-role: past the role check (tested below), into the signal checks
            cases.append(Case(f"signal-{sid}-{kind}", "signal",
                              ("identify", "--velocity", target, "--method", "pinv", "--force-role"),
                              expect, names, warns, make=_tds_signal(edit, scale, csv)))
    # the sanity gate speaks for the wrong roles that pass the role check
    cases.append(Case("signal-ramp-force-role", "signal",
                      ("identify", "--velocity", "{d}/ALL0001", "--force-role"), "clean",
                      make=_tds_signal(SIGNALS[9][1])))
    # a position capture given as velocity, and a current as velocity: the role check
    cases.append(Case("signal-position-as-velocity", "signal", ("identify", "--velocity", "{b}/ALL0000"), "refuse",
                      ("ALL0000", "--position")))
    cases.append(Case("signal-current-as-velocity", "signal", ("identify", "--velocity", "{b}/ALL0002"), "clean"))
    return cases


# --- option-level: every option with bad values ------------------------------------------------

V = ("--velocity", "{b}/ALL0001")
M, D = "{b}/model.json", "{b}/design.json"

BAD_OPTIONS: list[tuple[str, tuple[str, ...], str]] = [
    # identify
    *[(f"identify{i}", ("identify", *V, *opt), opt[0]) for i, opt in enumerate([
        ("--derivative", "bogus"), ("--structure", "bogus"), ("--method", "magic"), ("--order", "5"),
        ("--order", "0"), ("--reduction", "median"), ("--sync", "nearest"), ("--record-length", "0"),
        ("--record-length", "-1"), ("--record-length", "1e-9"), ("--record-length", "nan"),
        ("--sample-interval", "0"), ("--sample-interval", "-0.1"), ("--sample-interval", "nan"),
        ("--sample-interval", "inf"), ("--step-volts", "0"), ("--step-volts", "nan"), ("--step-volts", "inf"),
        ("--step-volts", "-5"), ("--step-volts", "59.2"), ("--markov-window", "0"), ("--markov-window", "-1"),
        ("--markov-params", "2"), ("--markov-params", "-3"), ("--ratio", "0"), ("--ratio", "-2"),
        ("--t0", "nan"), ("--t0", "inf"), ("--columns", "time"), ("--columns", "=x"),
        ("--sample-interval", "2.0", "--record-length", "2.9"), ("--ratio", "abc"), ("--step-volts", "five"),
    ])],
    ("identify-no-capture", ("identify", "--method", "pinv"), "--velocity"),
    ("identify-twice", ("identify", *V, *V), "--velocity"),
    ("identify-validate-no-report", ("identify", *V, "--validate", "{b}/ALL0003"), "--report"),
    ("identify-unknown-option", ("identify", *V, "--bogus"), "--bogus"),
    # inspect
    ("inspect-step-volts-nan", ("inspect", "{b}/ALL0001", "--step-volts", "nan"), "--step-volts"),
    ("inspect-columns", ("inspect", "{b}/vel.csv", "--columns", "velocity"), "--columns"),
    # validate
    ("validate-channel", ("validate", M, "{b}/ALL0003", "--channel", "bogus"), "--channel"),
    ("validate-max-nrmse", ("validate", M, "{b}/ALL0003", "--max-nrmse", "-1"), "--max-nrmse"),
    ("validate-warmup", ("validate", M, "{b}/ALL0003", "--warmup", "-1"), "--warmup"),
    ("validate-step-volts", ("validate", M, "{b}/ALL0003", "--step-volts", "0"), "--step-volts"),
    ("validate-model-missing", ("validate", "{d}/none.json", "{b}/ALL0003"), "none.json"),
    # report / sweep / demo
    ("report-sample-interval", ("report", "--out", "{d}/r.html", *V, "--sample-interval", "0"), "--sample-interval"),
    ("report-method", ("report", "--out", "{d}/r.html", *V, "--method", "magic"), "--method"),
    ("sweep-lengths", ("sweep", *V, "--lengths", "a,b"), "--lengths"),
    ("sweep-intervals", ("sweep", *V, "--intervals", "-0.1"), "--intervals"),
    ("sweep-order", ("sweep", *V, "--order", "9"), "--order"),
    ("demo-preset", ("demo", "--out", "{d}/demo", "--preset", "bogus"), "--preset"),
    ("demo-step-volts", ("demo", "--out", "{d}/demo", "--step-volts", "0"), "--step-volts"),
    # model from-params
    *[(f"from-params{i}", ("model", "from-params", *args), key) for i, (args, key) in enumerate([
        (("--km", "0", "--kT", "3.61e-3", "--gear", "1/36", "--k0", "0.25", "--Tm", "0.55"), "--km"),
        (("--km", "nan", "--kT", "3.61e-3", "--gear", "1/36", "--k0", "0.25", "--Tm", "0.55"), "--km"),
        (("--km", "249.3", "--kT", "-1", "--gear", "1/36", "--k0", "0.25", "--Tm", "0.55"), "--kT"),
        (("--km", "249.3", "--kT", "3.61e-3", "--gear", "1/0", "--k0", "0.25", "--Tm", "0.55"), "--gear"),
        (("--km", "249.3", "--kT", "3.61e-3", "--gear", "abc", "--k0", "0.25", "--Tm", "0.55"), "--gear"),
        (("--km", "249.3", "--kT", "3.61e-3", "--gear", "1/36", "--k0", "inf", "--Tm", "0.55"), "--k0"),
        (("--km", "249.3", "--kT", "3.61e-3", "--gear", "1/36", "--k0", "0.25", "--Tm", "-1"), "--Tm"),
        (("--km", "249.3", "--kT", "3.61e-3", "--gear", "1/36", "--k0", "0.25", "--Tm", "0"), "--Tm"),
    ])],
    # design
    *[(f"design{i}", ("design", M, *opt), opt[0]) for i, opt in enumerate([
        ("--poles", "a,b"), ("--poles", "1e308,-1e308"), ("--poles", "nan,-1"), ("--poles", "-1"),
        ("--poles", "-1,-2,-3,-4"), ("--poles", "-1+2j,-3"), ("--damping", "-1", "--wn", "5"),
        ("--damping", "nan", "--wn", "5"), ("--wn", "0", "--damping", "0.7"), ("--wn", "-5", "--damping", "0.7"),
        ("--settling-time", "0", "--overshoot", "5"), ("--overshoot", "200", "--settling-time", "1"),
        ("--observer-poles", "x", "--poles", "-3,-4"), ("--ki", "nan", "--integral", "--poles", "-3,-4"),
        ("--output", "bogus", "--poles", "-3,-4"), ("--k2", "inf", "--damping", "0.7"),
    ])],
    ("design-nothing", ("design", M), "--poles"),
    # simulate
    *[(f"simulate{i}", ("simulate", M, D, *opt), opt[0]) for i, opt in enumerate([
        ("--duration", "0"), ("--duration", "-1"), ("--duration", "nan"), ("--dt", "0"), ("--dt", "nan"),
        ("--reference", "bogus"), ("--frequency", "-1", "--reference", "sine"), ("--saturation", "0"), ("--x0", "a,b"),
        ("--x0", "1,2,3"), ("--plant", "bogus"), ("--preset", "bogus", "--plant", "trainer"),
        ("--level", "inf"), ("--amplitude", "nan"), ("--xhat0", "1"), ("--dt", "10"),
    ])],
    # modes
    *[(f"modes{i}", ("modes", M, *opt), key) for i, (opt, key) in enumerate([
        (("--kp", "bad", "--kv", "0:10:5"), "--kp"), (("--kp", "0:1:0", "--kv", "0:10:5"), "--kp"),
        (("--kp", "0:10:5", "--kv", "1:0:5"), "--kv"), (("--kp", "0:10:5", "--kv", "0:10:5", "--step", "nan"), "--step"),
        (("--kp", "0:10:5", "--kv", "0:10:5", "--duration", "-1"), "--duration"),
        (("--kp", "0:10:5", "--kv", "0:10:5", "--saturation", "0"), "--saturation"),
        (("--kp", "0:10:1e9", "--kv", "0:10:5"), "--kp"),
    ])],
]


def option_cases() -> list[Case]:
    return [Case(f"option-{oid}", "option", argv, "refuse", (key,)) for oid, argv, key in BAD_OPTIONS]


# --- output-level: where outputs cannot or must not go -----------------------------------------

def _existing(name: str) -> Callable[[Path, Path], None]:
    def make(d: Path, base: Path) -> None:
        (d / name).write_text("precious\n", encoding="utf-8")
    return make


def _folder(name: str) -> Callable[[Path, Path], None]:
    def make(d: Path, base: Path) -> None:
        (d / name).mkdir()
    return make


def _truncated_design(d: Path, base: Path) -> None:
    text = (base / "design.json").read_text(encoding="utf-8")
    (d / "design.json").write_text(text[: len(text) // 2], encoding="utf-8")


def _bad_validation(d: Path, base: Path) -> None:
    (d / "bad.csv").write_text("time,input,velocity\n0,0,0\n", encoding="utf-8")


#: (command, output option, extension, the command's other arguments)
OUTPUTS: list[tuple[str, str, str, tuple[str, ...]]] = [
    ("identify", "--json", ".json", ("identify", *V, "--method", "pinv")),
    ("identify", "--matlab", ".m", ("identify", *V, "--method", "pinv")),
    ("identify", "--report", ".html", ("identify", *V, "--method", "pinv")),
    ("report", "--out", ".html", ("report", *V, "--method", "pinv")),
    ("sweep", "--json", ".json", ("sweep", *V, "--lengths", "2.4", "--intervals", "0.1")),
    ("design", "--json", ".json", ("design", M, "--poles", "-3,-4")),
    ("simulate", "--csv", ".csv", ("simulate", M, D, "--duration", "1")),
    ("simulate", "--json", ".json", ("simulate", M, D, "--duration", "1")),
    ("simulate", "--png", ".png", ("simulate", M, D, "--duration", "1")),
    ("modes", "--json", ".json", ("modes", M, "--kp", "0:50:3", "--kv", "0:5:3")),
    ("modes", "--png", ".png", ("modes", M, "--kp", "0:50:3", "--kv", "0:5:3")),
    ("from-params", "--json", ".json", ("model", "from-params", "--km", "249.3", "--kT", "3.61e-3", "--gear", "1/36",
                                        "--k0", "0.25", "--Tm", "0.55")),
]


def output_cases() -> list[Case]:
    cases = []
    for cmd, opt, ext, argv in OUTPUTS:
        tag = f"{cmd}{opt}"
        out = f"out{ext}"
        cases += [
            Case(f"output-{tag}-folder", "output", (*argv, opt, "{d}/" + out), "refuse", (out,), make=_folder(out)),
            Case(f"output-{tag}-folder-force", "output", (*argv, opt, "{d}/" + out, "--force"), "refuse", (out,),
                 make=_folder(out)),
            Case(f"output-{tag}-missing-folder", "output", (*argv, opt, "{d}/nodir/" + out), "refuse", ("nodir",)),
            Case(f"output-{tag}-exists", "output", (*argv, opt, "{d}/" + out), "refuse", (out, "--force"),
                 make=_existing(out)),
            Case(f"output-{tag}-below-file", "output", (*argv, opt, "{d}/afile/" + out), "refuse", ("afile",),
                 make=_existing("afile")),
        ]
    # the file matplotlib would really write (out/plot.png) must not be overwritten silently
    for cmd, argv in (("simulate", ("simulate", M, D, "--duration", "1")),
                      ("modes", ("modes", M, "--kp", "0:50:3", "--kv", "0:5:3"))):
        cases.append(Case(f"output-{cmd}-png-no-suffix", "output", (*argv, "--png", "{d}/plot"), "refuse",
                          ("--png",), make=_existing("plot.png")))
    # the same file for two outputs
    cases.append(Case("output-identify-same-file", "output",
                      ("identify", *V, "--method", "pinv", "--json", "{d}/x", "--report", "{d}/x"), "refuse", ("x",)))
    # failures after partial work leave nothing behind
    cases += [
        Case("output-identify-bad-validate", "output",
             ("identify", *V, "--method", "pinv", "--json", "{d}/m.json", "--matlab", "{d}/m.m", "--report",
              "{d}/r.html", "--validate", "{d}/bad.csv"), "refuse", ("bad.csv",), make=_bad_validation),
        Case("output-identify-truncated-design", "output",
             ("identify", *V, "--method", "pinv", "--json", "{d}/m.json", "--report", "{d}/r.html", "--design",
              "{d}/design.json"), "refuse", ("design.json",), make=_truncated_design),
        Case("output-report-truncated-design", "output",
             ("report", *V, "--method", "pinv", "--out", "{d}/r.html", "--design", "{d}/design.json"), "refuse",
             ("design.json",), make=_truncated_design),
        Case("output-simulate-truncated-design", "output",
             ("simulate", M, "{d}/design.json", "--csv", "{d}/s.csv", "--json", "{d}/s.json", "--png",
              "{d}/s.png"), "refuse", ("design.json",), make=_truncated_design),
        Case("output-demo-out-is-file", "output", ("demo", "--out", "{d}/afile"), "refuse", ("afile",),
             make=_existing("afile")),
        # the successful outputs: everything written, exit 0
        Case("output-identify-all-ok", "output",
             ("identify", *V, "--method", "pinv", "--json", "{d}/m.json", "--matlab", "{d}/m.m", "--report",
              "{d}/r.html"), "ok"),
        Case("output-simulate-all-ok", "output",
             ("simulate", M, D, "--duration", "1", "--csv", "{d}/s.csv", "--json", "{d}/s.json", "--png",
              "{d}/s.png"), "ok"),
    ]
    return cases


def all_cases() -> list[Case]:
    """Every case of the corpus, ids unique."""
    cases = file_cases() + signal_cases() + option_cases() + output_cases()
    ids = [c.id for c in cases]
    assert len(ids) == len(set(ids)), "duplicate case ids"
    return cases


def build(root: Path, cases: list[Case]) -> Path:
    """Build the base and every case's folder under ``root``; return the base folder."""
    base = root / "_base"
    if not base.exists():
        build_base(base)
    for c in cases:
        d = root / c.id
        d.mkdir(parents=True, exist_ok=True)
        if c.make is not None:
            c.make(d, base)
    return base


def snapshot(folder: Path) -> dict[str, tuple[int, int]]:
    """Every path under ``folder`` with its size and modification time (ns)."""
    out = {}
    for p in sorted(folder.rglob("*")):
        try:
            st = p.lstat()
        except OSError:
            continue
        out[str(p.relative_to(folder))] = (st.st_size, st.st_mtime_ns)
    return out


def to_json(cases: list[Case], root: Path, base: Path) -> str:
    return json.dumps([{"id": c.id, "dir": str(root / c.id), "argv": c.args(root / c.id, base)} for c in cases])

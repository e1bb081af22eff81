"""A real lab DC motor whose licence allows copying: the UNDCMotor kit's open-loop speed steps (MIT).

``../shared/real/undcmotor-steps`` and ``../shared/real/dcmotor-jl-step`` (their PROVENANCE.md
give the source commits, the licences and the rig): three 50 Hz plain-CSV logs ``t,u,y`` (s, V,
deg/s) of the kit's motor, each one voltage step from a running speed, two with the authors'
own first-order numbers beside them. Every check compares motorid with something it cannot
influence: the raw text, a first-order-plus-dead-time least squares fit done here with scipy,
and the authors' gain.
"""

from __future__ import annotations

import functools
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import curve_fit

# name: (folder in ../shared/real, file in it, samples). The Python package's authors overwrote
# one path with a new experiment, so that folder has one subfolder per source commit.
LOGS = {
    "undcmotor-63f2237": ("undcmotor-steps", "63f2237/DCmotor_step_open_exp.csv", 502),
    "undcmotor-1e8ecc9": ("undcmotor-steps", "1e8ecc9/DCmotor_step_open_exp.csv", 252),
    # a motor fast against the 20 ms grid: τ ≈ 2 samples, a 1.25 V step
    "dcmotor-jl-e7733c2": ("dcmotor-jl-step", "DCmotor_step_open_exp.csv", 302),
}
AUTHORS = ("undcmotor-63f2237", "undcmotor-1e8ecc9")  # the logs with the authors' own numbers


def _log(real_dir: Path, name: str) -> Path:
    """The log's path; the test skips with the reason when it is not there."""
    folder, rel, _ = LOGS[name]
    path = real_dir / folder / rel
    if not path.is_file():
        pytest.skip(f"the UNDCMotor recording {path} is not there (the recordings live beside the repo)")
    return path


def _raw(path: Path) -> np.ndarray:
    """The log's rows as written, header ``t,u,y`` checked, parsed by numpy (not by motorid)."""
    with path.open() as f:
        assert f.readline().strip() == "t,u,y"
    return np.loadtxt(path, delimiter=",", skiprows=1)


@functools.cache
def _fopdt(path: Path) -> dict[str, float]:
    """Least-squares y₀ + K·Δu·(1 − exp(−(t − t₀ − L)/τ)) on every sample, t₀ the first sample
    at the new input level, y₀ the mean before it: an estimate motorid takes no part in."""
    t, u, y = _raw(path).T
    k = int(np.argmax(np.diff(u))) + 1
    t0, du, y0 = t[k], u[k:].mean() - u[:k].mean(), y[:k].mean()

    def model(tt, K, tau, L):
        return y0 + K * du * (1 - np.exp(-np.clip(tt - t0 - L, 0, None) / tau))

    p, _ = curve_fit(model, t, y, p0=[(y[-50:].mean() - y0) / du, 0.3, 0.02], bounds=([0, 1e-3, 0], [1e5, 5, 1]))
    return {"K": p[0], "tau": p[1], "L": p[2], "du": du}


@functools.cache
def _identified(path: Path):
    import motorid as mi

    return mi.identify(mi.read_experiment(velocity=path))


def _authors(log: Path) -> tuple[float, float]:
    """The authors' ``alpha, tau`` written beside the log by their own fit (PROVENANCE.md)."""
    lines = (log.parent / "DCmotor_fomodel_step.csv").read_text().split()
    assert lines[0] == "alpha," and lines[1] == "tau"
    alpha, tau = map(float, lines[2].split(","))
    return alpha, tau


@pytest.mark.parametrize("name", LOGS)
def test_plain_csv_reader_keeps_the_log_as_written(real_dir, name):
    from motorid.io import read_capture

    path = _log(real_dir, name)
    raw = _raw(path)
    cap = read_capture(path)
    assert cap.format == "plain-csv" and not cap.warnings
    assert cap.n_samples == raw.shape[0] == LOGS[name][2]
    # `t` is seconds on a 20 ms grid (the firmware's SAMPLING_TIME): nothing resampled or shifted
    np.testing.assert_array_equal(cap.time_s, raw[:, 0])
    np.testing.assert_array_equal(cap.input_v, raw[:, 1])
    np.testing.assert_array_equal(cap.output_v, raw[:, 2])
    assert cap.sample_interval_s == pytest.approx(0.02, rel=1e-9)
    assert (cap.input_info.name, cap.output_info.name) == ("u", "y")


@pytest.mark.parametrize("name", LOGS)
def test_identify_agrees_with_an_independent_dead_time_fit(real_dir, name):
    path = _log(real_dir, name)
    ref = _fopdt(path)
    r = _identified(path)
    # the step found on its own is the log's: Δu from the raw input column
    assert r.model.step_volts == pytest.approx(ref["du"], rel=1e-6)
    gain = r.params["dc_gain"]
    # the speed is quantised to 6.43 deg/s on a change of 90, 92 or 202 deg/s; the scipy fit's
    # standard error is at most 0.3 % of K: 1.5 % is five of them (seen: 0.2, 0.0, 0.1 %)
    assert gain.value == pytest.approx(ref["K"], rel=0.015)
    assert gain.ci95[0] <= ref["K"] <= gain.ci95[1]
    # mean residence time τ + dead time (τ by moments on motorid's side, τ + L of the first-order
    # fit here): the same quantity whatever the structure; its standard error is up to 3 % of
    # it, 8 % is between two and three (seen: 3.0, 0.0, 0.9 %)
    assert r.params["residence_time_s"].value == pytest.approx(ref["tau"] + ref["L"], rel=0.08)


@pytest.mark.parametrize("name", AUTHORS)
def test_gain_agrees_with_the_authors_own_fit(real_dir, name):
    path = _log(real_dir, name)
    alpha, tau = _authors(path)
    r = _identified(path)
    # the authors' gain is Δy/Δu from two one-second means of the quantised speed (steady-state
    # sd ≈ 3 deg/s, so ≈ 0.7 % of Δy for the difference of two 50-sample means): 2 % is about
    # three of those (seen: 0.4 %, 0.5 %)
    assert r.params["dc_gain"].value == pytest.approx(alpha, rel=0.02)
    # their τ averages read-offs at 20, 40, 63.2 and 80 % measured from the step instant (so the
    # dead time is inside it) on a pchip through the quantised samples: a loose reference for
    # the 63 % time, 20 % (seen: 10 % and 8 %, theirs the longer)
    assert r.params["t63_s"].value == pytest.approx(tau, rel=0.20)


def test_cli_identifies_the_log_as_a_user_runs_it(real_dir, tmp_path):
    """``python -m motorid identify --velocity LOG --json OUT`` in a fresh process, default options."""
    path = _log(real_dir, "undcmotor-63f2237")
    out = tmp_path / "m.json"
    res = subprocess.run([sys.executable, "-m", "motorid", "identify", "--velocity", str(path), "--json", str(out)],
                         capture_output=True, text=True, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    doc = json.loads(out.read_text())
    raw = _raw(path)
    assert doc["step_volts"] == pytest.approx(raw[-1, 1] - raw[0, 1], rel=1e-6)
    assert doc["first_order"]["dc_gain"] == pytest.approx(_authors(path)[0], rel=0.02)
    assert doc["first_order"]["dc_gain"] == pytest.approx(_fopdt(path)["K"], rel=0.015)


# before: the residence time's interval was widened by the BIC-weighted spread of the candidate
# structures, with 0.97 of the weight on the 2-pole/1-zero candidate the pipeline itself rejects
# as unresolved (pole −0.236 against zero −0.271): 0.221 ± 1.02 s (95 % [−0.80, 1.25] s) while the
# 63 % time of the same model got [0.157, 0.285] s.  Only supported structures are averaged now;
# tests/identification/test_timing_honest.py shows the same on a log the test writes.
def test_residence_time_interval_stays_physical(real_dir):
    r = _identified(_log(real_dir, "undcmotor-1e8ecc9"))
    res, t63 = r.params["residence_time_s"], r.params["t63_s"]
    assert res.value == pytest.approx(t63.value, rel=1e-3)  # no zero left: the same number
    lo, hi = res.ci95
    # a time's interval does not reach below zero, and the same number is not (as now) 16× less
    # sure under one name than under the other
    assert lo > 0
    assert hi - lo < 2 * (t63.ci95[1] - t63.ci95[0])

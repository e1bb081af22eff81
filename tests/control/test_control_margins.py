"""Margins of a design against the same loop built independently, as python-control users do:
the controller as a transfer function from the measured output to the command, times the motor."""

from __future__ import annotations

import json
import math

import control
import numpy as np
import pytest

import motorid as mi
from motorid.control.design import design_model, output_row
from motorid.control.margins import loop_margins


@pytest.fixture(scope="module")
def model(demo_run):
    return mi.MotorModel.from_json(json.loads((demo_run.folder / "model.json").read_text()))


def _independent(model, des):
    """Stability margins and bandwidth from transfer functions: L = C_ctrl(s)·G(s)."""
    work = design_model(model, des)
    a, b = work.A, work.B.reshape(-1, 1)
    c = output_row(work, des.output)[1].reshape(1, -1)
    n = a.shape[0]
    k = des.K.reshape(1, n)
    motor = control.ss(a, b, c, 0.0)
    if des.reduced is not None:  # the reduced observer reads the sensors: controller from z_m to u
        red = des.reduced
        idx = {s: i for i, s in enumerate(des.states)}
        k_m, k_u = k[:, [idx[x] for x in red.measured]], k[:, [idx[x] for x in red.estimated]]
        kz, kw = -(k_m + k_u @ red.L), -k_u
        sel = np.eye(n)[[idx[x] for x in red.measured]]
        sensors = control.ss(a, b, sel, np.zeros((sel.shape[0], 1)))
        nu = red.F.shape[0]
        if des.ki is None:
            ctrl = control.ss(red.F + red.H @ kw, red.G + red.H @ kz, -kw, -kz)
        else:  # states [w, z]: ż = y (r = 0), y a measured state
            y_row = np.zeros((1, len(red.measured)))
            y_row[0, list(red.measured).index(des.output)] = 1.0
            a_c = np.block([[red.F + red.H @ kw, -red.H * des.ki], [np.zeros((1, nu)), np.zeros((1, 1))]])
            b_c = np.vstack([red.G + red.H @ kz, y_row])
            ctrl = control.ss(a_c, b_c, np.hstack([-kw, [[des.ki]]]), -np.hstack([kz]))
        loop = ctrl * sensors
    elif des.L is None:  # every state measured: the loop is K (sI − A)⁻¹ B (+ ki/s · G)
        loop = control.tf(control.ss(a, b, k, 0.0))
        if des.ki is not None:
            loop = loop + control.tf([des.ki], [1, 0]) * control.tf(motor)
    else:  # the observer (fed the command) and the integrator form a controller from y to u
        l_col = des.L.reshape(n, 1)
        a_c = a - b @ k - l_col @ c
        if des.ki is None:
            ctrl = control.ss(a_c, l_col, k, 0.0)
        else:
            a_c = np.block([[a_c, -b * des.ki], [np.zeros((1, n)), np.zeros((1, 1))]])
            ctrl = control.ss(a_c, np.vstack([l_col, [[1.0]]]), np.hstack([k, [[des.ki]]]), 0.0)
        loop = control.tf(ctrl) * control.tf(motor)
    gm, pm, sm, _, wgc, _ = control.stability_margins(loop)
    if not math.isfinite(sm):  # |1 + L| has no minimum inside: its smallest value on a wide grid
        omega = np.logspace(-4, 5, 20000)
        sm = float(np.min(np.abs(1 + np.ravel(loop(1j * omega)))))
    at_infinity = complex(np.ravel(loop(1j * 1e9))[0])  # L(jω) far above every pole: its limit
    return gm, pm, sm, wgc, at_infinity


@pytest.mark.parametrize("options", [
    {"damping": 1.0, "wn": 8.0},
    {"damping": 0.7, "wn": 5.0, "integral": True},
    {"damping": 0.7, "wn": 5.0, "observer_poles": [-30, -32, -34, -36]},
    {"damping": 0.7, "wn": 5.0, "integral": True, "observer_poles": [-30, -32, -34, -36]},
])
def test_margins_equal_the_loop_built_from_transfer_functions(model, options):
    des = mi.design(model, **options, robust_samples=0)
    got = des.margins
    gm, pm, sm, wgc, at_infinity = _independent(model, des)
    assert got.phase_deg == pytest.approx(pm, rel=1e-6, abs=1e-6)
    assert got.crossover_rad_s == pytest.approx(wgc, rel=1e-6)
    assert got.delay_s == pytest.approx(math.radians(pm) / wgc, rel=1e-6)
    # the peak of |S| includes its limit as ω → ∞, 1/|1 + L(j∞)|: 1 for these strictly proper loops,
    # which python-control's stationary points leave out (it gave 1/sm = 0.897, an impossible Ms)
    limit = 1.0 / abs(1.0 + at_infinity)
    assert got.ms == pytest.approx(max(1 / sm, limit), rel=1e-4)
    assert got.ms >= 1.0 - 1e-12
    if math.isfinite(gm):
        assert got.gain_db == pytest.approx(20 * math.log10(gm), rel=1e-6, abs=1e-6)
    else:
        assert math.isinf(got.gain_db)
    # the JSON carries them, and reads back
    back = type(des).from_json(des.to_json())
    assert back.margins.to_json() == got.to_json()


def test_bandwidth_is_the_closed_loop_s(model):
    des = mi.design(model, damping=1.0, wn=8.0, robust_samples=0)
    work = design_model(model, des)
    a, b = work.A, work.B.reshape(-1, 1)
    c = output_row(work, des.output)[1].reshape(1, -1)
    closed = control.ss(a - b @ des.K.reshape(1, -1), b * des.kr, c, 0.0)
    assert des.margins.bandwidth_rad_s == pytest.approx(float(control.bandwidth(closed)), rel=1e-4)


def test_the_model_s_dead_time_eats_phase_margin(model):
    """A dead time τ at the motor's input turns the phase at the crossover by ω_c·τ: the phase
    margin drops by that much (within the Padé approximant's error) and so does the delay margin."""
    des = mi.design(model, damping=1.0, wn=8.0, robust_samples=0)
    base = des.margins
    tau = 0.2 * base.delay_s
    late = loop_margins(model.replace(delay_s=tau), des)
    assert late.dead_time_s == tau
    assert late.crossover_rad_s == pytest.approx(base.crossover_rad_s, rel=1e-3)
    assert late.phase_deg == pytest.approx(base.phase_deg - math.degrees(base.crossover_rad_s * tau), abs=0.05)
    assert late.delay_s == pytest.approx(base.delay_s - tau, rel=2e-3)


def test_the_design_printout_says_the_margins(demo_run, run_cli):
    res = run_cli("design", str(demo_run.folder / "model.json"), "--damping", "1", "--wn", "8", "--robust-samples", "0")
    assert res.code == 0, res.err
    line = next(ln for ln in res.out.splitlines() if ln.startswith("margins: "))
    assert "gain margin" in line and "phase margin" in line and "delay margin" in line and "Ms " in line
    assert "bandwidth" in line and "rad/s" in line


@pytest.mark.parametrize("delay_s", [0.0, 0.01])
def test_the_plotted_loop_crosses_where_the_margins_say(model, delay_s):
    """The report's Bode/Nyquist data: |L| = 1 at the crossover and the phase there is −180° + the
    phase margin (the dead time exact on the plot, a Padé approximant in the margins)."""
    from motorid.control.margins import loop_frequency_response

    m = model.replace(delay_s=delay_s)
    des = mi.design(m, damping=1.0, wn=8.0, robust_samples=0)
    omega, resp = loop_frequency_response(m, des, points=4000)
    mg = loop_margins(m, des)
    i = int(np.argmin(np.abs(np.log(omega / mg.crossover_rad_s))))
    assert abs(resp[i]) == pytest.approx(1.0, rel=5e-3)
    assert math.degrees(np.angle(resp[i])) == pytest.approx(-180.0 + mg.phase_deg, abs=0.3)


@pytest.mark.parametrize(("margins", "needle"), [("wide", "'margins' must be an object"),
                                                 ({"phase_deg": "60"}, "margins.phase_deg")])
def test_a_design_json_with_bad_margins_is_one_line(demo_run, run_cli, tmp_path, margins, needle):
    model = demo_run.folder / "model.json"
    d = tmp_path / "d.json"
    assert run_cli("design", model, "--damping", "1", "--wn", "8", "--robust-samples", "0", "--json", d).code == 0
    d.write_text(json.dumps(json.loads(d.read_text()) | {"margins": margins}))
    res = run_cli("simulate", model, d)
    assert res.code == 2 and needle in res.err, res.err
    assert len([ln for ln in res.err.splitlines() if ln.strip()]) == 1 and "Traceback" not in res.err


def test_an_integrator_with_zero_gain_prints_no_numpy_warning(model, recwarn):
    """``--integral --ki 0`` (a student's first point of a Routh–Hurwitz sweep) leaves a closed-loop
    pole at the origin; python-control's margins compared NaN responses and numpy printed
    "RuntimeWarning: invalid value encountered in less_equal" twice above the design."""
    des = mi.design(model, damping=1.0, wn=8.0, integral=True, ki=0.0, robust_samples=0)
    assert any(abs(p) < 1e-9 for p in des.closed_loop_poles)
    assert not [w for w in recwarn if issubclass(w.category, RuntimeWarning)], [str(w.message) for w in recwarn]

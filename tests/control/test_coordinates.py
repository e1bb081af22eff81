"""Scale-free controllability/observability and measurable coordinates.

Checked against python-control (``tf2ss``, ``ss2tf``, ``place``, ``acker``, ``ctrb``) and
numpy eigenvalues, never against numbers copied from motorid's output.
"""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.control import (
    UNCONTROLLABLE_TOL,
    ControlDesignError,
    DesignSettings,
    check_controllable,
    design_controller,
    measurable_realisation,
    pbh_margins,
)
from motorid.control.design import Design
from motorid.control.observer import check_observable
from motorid.model import MotorModel

#: A motor like the demo's: velocity (228 s + 5088)/((s + 2.31)(s + 36.2)(s + 67.3)) in a
#: controllable-canonical (companion) realisation with a position integrator, and a current row.
VEL_NUM = [228.235, 5088.27]
VEL_DEN = np.poly([-2.31, -36.16, -67.29])
CUR_NUM = [44.89, 1027.97, 1135.73]


def _companion_model(with_current: bool = True) -> MotorModel:
    sys_v = control.tf2ss(control.tf(VEL_NUM, VEL_DEN))
    a3, b3, cv = (np.asarray(x, dtype=float) for x in (sys_v.A, sys_v.B, sys_v.C))
    # current row in the same realisation: solve C (sI − A)⁻¹ B = CUR_NUM / VEL_DEN on 3 points
    s_pts = [1j, 3.0 + 0j, 10j]
    g = np.array([np.linalg.solve(s * np.eye(3) - a3, b3[:, 0]) for s in s_pts])
    h = np.array([np.polyval(CUR_NUM, s) / np.polyval(VEL_DEN, s) for s in s_pts])
    ci = np.linalg.solve(g, h).real
    a = np.zeros((4, 4))
    a[0, 1:] = 1.0004 * cv[0]  # the position channel's scale differs slightly, as identified
    a[1:, 1:] = a3
    b = np.vstack([[[0.0]], b3])
    rows = [np.r_[1.0, 0, 0, 0], np.r_[0.0, cv[0]]]
    outputs = ["position", "velocity"]
    if with_current:
        rows.append(np.r_[0.0, ci])
        outputs.append("current")
    return MotorModel(A=a, B=b, C=np.vstack(rows), D=np.zeros((len(rows), 1)),
                      states=("position", "x1", "x2", "x3"), outputs=tuple(outputs), method="test")


def test_raw_ctrb_rank_is_unit_dependent_but_pbh_is_not():
    m = _companion_model()
    # the old test: rank of ctrb with a 1e-9 relative threshold refuses this model ...
    sv = np.linalg.svd(control.ctrb(m.A, m.B), compute_uv=False)
    old_rank = int(np.sum(sv > sv[0] * 1e-9))
    # ... rescale the states (units) and the same system looks even worse, or better
    d = np.diag([1.0, 1e-3, 1e-1, 1e2])
    a2, b2 = np.linalg.solve(d, m.A @ d), np.linalg.solve(d, m.B)
    sv2 = np.linalg.svd(control.ctrb(a2, b2), compute_uv=False)
    assert int(np.sum(sv2 > sv2[0] * 1e-9)) != 4 or old_rank != 4  # the raw rank depends on units
    check_controllable(m.A, m.B)  # accepted
    check_controllable(a2, b2)  # accepted in any units
    m1, _ = pbh_margins(m.A, m.B)
    m2, _ = pbh_margins(a2, b2)
    assert np.min(m1) > 1e3 * UNCONTROLLABLE_TOL and np.min(m2) > 1e3 * UNCONTROLLABLE_TOL


@pytest.mark.parametrize("units", [np.ones(3), np.array([1e-4, 1.0, 1e4])])
def test_genuinely_uncontrollable_model_is_refused(units):
    # the third state is a mode the input cannot reach (B has no component, no coupling)
    a = np.array([[0.0, 1.0, 0.0], [0.0, -2.0, 0.0], [0.0, 0.0, -5.0]])
    b = np.array([[0.0], [3.0], [0.0]])
    d = np.diag(units)
    a2, b2 = np.linalg.solve(d, a @ d), np.linalg.solve(d, b)
    # independent confirmation: the mode at −5 is unreachable (PBH with numpy by hand)
    assert np.linalg.matrix_rank(np.hstack([-5.0 * np.eye(3) - a, b])) == 2
    with pytest.raises(ControlDesignError, match=r"not controllable \(rank of \[B AB \.\.\.\] is 2 < 3"):
        check_controllable(a2, b2)


def test_observability_is_scale_free_and_refuses_a_hidden_mode():
    m = _companion_model()
    check_observable(m.A, m.C[:1], "position")
    a = np.diag([-1.0, -2.0])
    with pytest.raises(ControlDesignError, match="not observable"):
        check_observable(a, np.array([[1.0, 0.0]]), "velocity")


def _freqresp(a, b, c, w):
    return np.array([(c @ np.linalg.solve(1j * x * np.eye(a.shape[0]) - a, b))[:, 0] for x in w])


def test_measurable_coordinates_keep_the_system():
    m = _companion_model()
    mr = measurable_realisation(m)
    assert mr.states == ("position", "velocity", "current", "acceleration")
    z = mr.model
    # measured channels are the states themselves
    np.testing.assert_array_equal(z.C, np.eye(4)[:3])
    # the same system: poles and every channel's frequency response (python-control's ss)
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(z.A)), np.sort_complex(np.linalg.eigvals(m.A)),
                               atol=1e-9 * 67.3)
    w = np.array([0.3, 2.0, 20.0, 200.0])
    ref = np.array([control.ss(m.A, m.B, m.C, m.D)(1j * x)[:, 0] for x in w])
    np.testing.assert_allclose(_freqresp(z.A, z.B, z.C, w), ref, rtol=1e-9)
    # the acceleration state is the derivative of the velocity one
    np.testing.assert_allclose(mr.transform[3], m.C[1] @ m.A, rtol=1e-12)


def test_current_is_replaced_by_acceleration_when_it_copies_velocity():
    m = _companion_model()
    c = m.C.copy()
    c[2] = 0.37 * c[1]  # a current channel that is the tacho times a constant adds nothing
    m2 = m.replace(C=c)
    mr = measurable_realisation(m2)
    assert mr.states == ("position", "velocity", "acceleration", "jerk")


def test_velocity_only_and_one_state_models():
    sys_v = control.tf2ss(control.tf([3.0, 40.0], np.poly([-2.0, -20.0])))
    m = MotorModel(A=sys_v.A, B=sys_v.B, C=sys_v.C, D=sys_v.D, states=("x1", "x2"), outputs=("velocity",))
    mr = measurable_realisation(m)
    assert mr.states == ("velocity", "acceleration")
    one = MotorModel(A=[[-2.0]], B=[[1.8]], C=[[1.0]], D=[[0.0]], states=("velocity",), outputs=("velocity",))
    r1 = measurable_realisation(one)
    assert r1.states == ("velocity",) and not r1.changed


@pytest.mark.parametrize("poles", [[-3.5 + 3.57j, -3.5 - 3.57j, -17.5, -21.0], [-6.0, -6.0, -20.0, -25.0]])
def test_closed_loop_poles_unchanged_by_the_coordinates(poles):
    """Designed in measurable coordinates = python-control's placement on the original realisation."""
    m = _companion_model()
    p = np.array(poles, dtype=complex)
    d = design_controller(m, DesignSettings(poles=tuple(p)))
    assert d.states == ("position", "velocity", "current", "acceleration")
    k_ref = np.asarray(control.acker(m.A, m.B, p) if len(set(poles)) < len(poles) else control.place(m.A, m.B, p))
    np.testing.assert_allclose(d.K_model, k_ref.ravel(), rtol=1e-6)
    cl = np.sort_complex(np.linalg.eigvals(m.A - m.B @ d.K_model.reshape(1, -1)))
    # distinct poles: 1e-6 of the largest.  A double pole of a defective loop moves by
    # √(ε)·|p| for a relative perturbation ε of the gains; ε = 1e-9 covers round-off through the
    # transform (condition ~500) and the balancing, i.e. 3e-5·|p|
    repeated = len(set(poles)) < len(poles)
    tol = np.sqrt(1e-9) * 25 if repeated else 1e-6 * 25
    np.testing.assert_allclose(cl, np.sort_complex(p), atol=tol)
    # reference gain: unit DC gain from r to position on the original realisation
    dc = (m.C[:1] @ np.linalg.solve(m.A - m.B @ d.K_model.reshape(1, -1), -m.B))[0, 0] * d.kr
    assert dc == pytest.approx(1.0, rel=1e-9)


def test_design_json_round_trip_keeps_the_transform():
    m = _companion_model()
    d = design_controller(m, DesignSettings(damping=0.7, wn=5.0, observer_poles=(-40, -45, -50, -55)))
    data = d.to_json()
    assert data["states"] == ["position", "velocity", "current", "acceleration"]
    assert data["model_states"] == ["position", "x1", "x2", "x3"]
    assert [g["state"] for g in data["gains"]] == data["states"]
    assert data["gains"][1]["unit"] == "per V of the tacho"
    back = Design.from_json(data)
    np.testing.assert_allclose(back.K_model, d.K_model)
    np.testing.assert_allclose(back.L_model, d.L_model)
    # the observer on the original realisation has the requested poles (independent eig)
    cl = np.linalg.eigvals(m.A - d.L_model.reshape(-1, 1) @ m.C[:1])
    np.testing.assert_allclose(np.sort(cl.real), [-55, -50, -45, -40], rtol=1e-6)


def test_report_design_unchanged_on_physical_states():
    """The lab report's model (states position, velocity) is designed as before: no transform."""
    from motorid.control.params import MotorParams, model_from_params

    m = model_from_params(MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55))
    d = design_controller(m, DesignSettings(damping=1.0, k2=8.5))
    assert d.states == tuple(m.states) and d.transform is None and "model_states" not in d.to_json()
    assert d.K[0] == pytest.approx(19.64, abs=0.01)  # report eq. 39 (k1 = 19.6 for k2 = 8.5)

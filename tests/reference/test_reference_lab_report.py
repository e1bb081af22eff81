"""Worked examples of the lab report (Tsiolakis 2022) and of the paper's section II (Masoud 2019)."""

from __future__ import annotations

import control
import numpy as np
import pytest

from motorid.control import (
    DesignSettings,
    MotorParams,
    design_controller,
    dominant_second_order,
    integral_poly,
    model_from_params,
    params_from_step_test,
    routh_array,
    routh_conditions,
    routh_stable,
)

REPORT = MotorParams(km=249.3, kT=3.61e-3, gear=1 / 36, k0=0.25, Tm_s=0.55)


@pytest.fixture(scope="module")
def model():
    return model_from_params(REPORT)


def test_eqs_27_28_state_matrices(model):
    # exact algebra: A = [[0, kμk0/kT], [0, −1/Tm]], B = [0, kT km/Tm]
    np.testing.assert_allclose(model.A, [[0, (1 / 36) * 0.25 / 3.61e-3], [0, -1 / 0.55]], rtol=1e-12)
    np.testing.assert_allclose(model.B.ravel(), [0, 3.61e-3 * 249.3 / 0.55], rtol=1e-12)


def test_eqs_1_19_parameters_from_step_test():
    p = params_from_step_test(v_tacho_ss=9, u_step=10, Tm_s=0.55, delta_theta_v=15, delta_t_s=0.867, gear=1 / 36)
    # the report rounds kT to 3 figures (eq. 17: 3.61e-3) and km to 249.3 (eq. 19); ω = 2491.35 rpm (eq. 16)
    assert p.kT == pytest.approx(3.61e-3, rel=1e-3)
    assert p.k0 == pytest.approx(0.25, rel=1e-9)  # Δθ/(kμ ω Δt) = 15/(69.2·0.867) = 0.25 exactly
    assert p.km == pytest.approx(249.3, rel=2e-3)
    assert p.km * p.kT == pytest.approx(0.9, rel=1e-12)  # eq. 5


def test_eqs_32_36_k2_8_5_critical_damping_gives_k1_19_6(model):
    d = design_controller(model, DesignSettings(damping=1.0, k2=8.5))
    # report prints k1 = 19.6 (3 figures): analytic k1 = Tm P1²/4 /(km kμ k0), P1 = (1 + 8.5 kT km)/Tm
    p1 = (1 + 8.5 * 3.61e-3 * 249.3) / 0.55
    assert d.K[0] == pytest.approx(0.55 * p1 ** 2 / 4 / (249.3 / 36 * 0.25), rel=1e-9)
    assert d.K[0] == pytest.approx(19.6, abs=0.05)
    assert d.K[1] == 8.5
    assert d.kr == pytest.approx(d.K[0], rel=1e-9)  # eq. 39: kr = k1
    # critical damping: a double real pole at −P1/2 (eig of a defective matrix: ~1e-7 split)
    np.testing.assert_allclose(d.closed_loop_poles, [-p1 / 2, -p1 / 2], atol=1e-6)
    # independent: python-control's closed loop DC gain with kr is 1 (eq. 37)
    cl = control.ss(model.A - model.B @ d.K.reshape(1, 2), model.B * d.kr, [[1, 0]], 0)
    assert float(control.dcgain(cl)) == pytest.approx(1.0, rel=1e-9)


def test_eq_33_k2_2_1_gives_k1_2_2(model):
    d = design_controller(model, DesignSettings(damping=1.0, k2=2.1))
    assert d.K[0] == pytest.approx(2.2, abs=0.01)  # report: 2.2 (2 figures); exact 2.193


def test_eqs_43_47_routh_bounds(model):
    poly = integral_poly(model.A, model.B, model.C[:1], ("k1", "k2"))
    conds = routh_conditions(poly)
    # eq. 46: k2 > −1/(kT km) = −1.111 (report multiplies kT·kμ in the text, the bound uses kT·km)
    assert conds[0] == "k2 > -1.111"
    assert conds[1] == "ki > 0"  # eq. 47
    assert conds[2] == "(1 + 0.9·k2)·k1 > 0.55·ki"  # eq. 45: k1 > Tm ki/(1 + kT km k2)
    # eq. 42 coefficients for k = (5, 3), ki = 5 (report §3.2)
    c = poly.at([5, 3, 5])
    g = (1 / 36) * 0.25 * 249.3 / 0.55
    np.testing.assert_allclose(c, [1, (1 + 3 * 0.89997) / 0.55, g * 5, g * 5], rtol=1e-4)


def test_report_section_3_2_gains_satisfy_routh(model):
    d = design_controller(model, DesignSettings(poles=None, damping=1.0, k2=8.5, integral=True, ki=5.0))
    assert d.warnings == ()
    assert np.all(d.closed_loop_poles.real < 0)
    # gains that break eq. 45 are flagged: k1 = 0.1 < Tm ki/(1 + 0.9 k2)
    bad = design_controller(model, DesignSettings(poles=(-1, -2), integral=True, ki=50.0))
    assert any("Routh" in w for w in bad.warnings)


@pytest.mark.parametrize("obs", [(-50.0, -40.0), (-80.0, -10.0)])
def test_eqs_49_57_observer_gain_equals_place_on_dual(model, obs):
    d = design_controller(model, DesignSettings(damping=1.0, k2=8.5, observer_poles=obs))
    c = np.array([[1.0, 0.0]])
    ref = control.place(model.A.T, c.T, obs).T.ravel()
    np.testing.assert_allclose(d.L, ref, rtol=1e-9)
    # eq. 57 by hand: L1 = p1 − a1, L2 = (p2 − a1 (p1 − a1)) kT/(kμ k0), a1 = 1/Tm
    p1, p2 = -(obs[0] + obs[1]), obs[0] * obs[1]
    a1 = 1 / 0.55
    np.testing.assert_allclose(d.L, [p1 - a1, (p2 - a1 * (p1 - a1)) * 3.61e-3 / (0.25 / 36)], rtol=1e-9)
    # separation: plant + observer + feedback poles = controller ∪ observer poles
    np.testing.assert_allclose(np.sort_complex(d.output_feedback_poles),
                               np.sort_complex(np.concatenate([d.closed_loop_poles, obs])), atol=1e-5)


def test_paper_eq_6_dominant_pair_of_exact_loop():
    h = control.tf([10], [1, 11, 10, 0])  # eq. 4: 10/(s(s+1)(s+10))
    exact = control.feedback(5 * h, 1)
    approx = dominant_second_order(exact)
    num, den = np.asarray(approx.num[0][0]), np.asarray(approx.den[0][0])
    # eq. 6 prints 4.762/(s² + 0.5 s + 4.762); the roots of s³ + 11 s² + 10 s + 50 give 4.7614 and 0.4989
    np.testing.assert_allclose(den, [1, 0.49886, 4.76139], rtol=1e-4)
    assert num[-1] == pytest.approx(den[-1], rel=1e-9)  # unity DC gain kept
    assert den[1] == pytest.approx(0.5, abs=0.002) and den[2] == pytest.approx(4.762, abs=0.002)


def test_paper_eq_5_fast_pole_removed_first():
    # dropping 10/(s+10) (DC gain 1) before closing the loop: 5/(s(s+1)) in unity feedback
    approx = control.feedback(control.tf([5], [1, 1, 0]), 1)
    np.testing.assert_allclose(np.asarray(approx.den[0][0]), [1, 1, 5], rtol=1e-12)
    np.testing.assert_allclose(np.asarray(approx.num[0][0]), [5], rtol=1e-12)


@pytest.mark.parametrize("alpha,stable", [(0.1, True), (0.02, False), (0.0301, True), (0.0299, False)])
def test_paper_eq_3_routh_boundary_alpha_0_03(alpha, stable):
    den = [1, alpha, 1, 0.03]
    assert routh_stable(den) is stable
    assert bool(np.all(np.real(np.roots(den)) < 0)) is stable  # independent check by the roots
    # first column: 1, α, (α·1 − 0.03)/α, 0.03 → boundary α = 0.03
    np.testing.assert_allclose(routh_array(den), [1, alpha, (alpha - 0.03) / alpha, 0.03], rtol=1e-12)

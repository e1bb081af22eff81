"""A plausible motor drawn far out in a wide interval: its loop's numbers are unknown (NaN), not a warning or 1e19."""

from __future__ import annotations

import warnings

import numpy as np

from motorid.control import robust


def test_a_loop_whose_exponential_overflows_has_no_step_response():
    a = np.array([[[-1.0, 0.0], [0.0, -2.0]], [[1e5, 0.0], [0.0, -2.0]]])  # the second's e^(A·dt) overflows
    b = np.array([[[1.0], [1.0]]] * 2)
    c = np.array([[[1.0, 0.0]]] * 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no RuntimeWarning (the command line's tests make them errors)
        _t, y = robust._steps(a, b, c, 5.0)
    assert np.all(np.isfinite(y[0])) and np.all(np.isnan(y[1]))
    assert abs(y[0, -1] - 1.0) < 0.01  # the first settles at −CA⁻¹B = 1


def test_a_draw_with_an_overflowing_time_constant_is_no_warning():
    joint = robust._Joint(("K", "log_tau_1"), np.array([2.0, np.log(0.3)]), np.diag([1e-4, 1e-4]))
    from motorid.model import MotorModel

    model = MotorModel(A=[[-1 / 0.3]], B=[[1.0]], C=[[2.0 / 0.3]], D=[[0.0]], states=("x1",), outputs=("velocity",))
    theta = np.array([[2.0, np.log(0.3)], [2.0, 800.0]])  # e^800 overflows
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        r, _delays = joint.plants(model, theta)
    assert np.allclose(r.A[0], [[-1 / 0.3]])  # the nominal draw realised as the model
    assert r.A.shape[0] == 2  # the far draw is realised too (without a warning); _plants keeps only finite ones

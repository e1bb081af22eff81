"""A model's transfer functions and first-order approximation are computed once, and belong to that model."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import scipy.signal

from motorid.model.motor import MotorModel


def _model(k: float = 2.0, tau: float = 0.3) -> MotorModel:
    return MotorModel(A=[[-1.0 / tau]], B=[[k / tau]], C=[[1.0]], D=[[0.0]], states=("velocity",),
                      outputs=("velocity",))


def test_repeated_calls_give_scipys_transfer_function_and_do_not_share_arrays():
    m = _model()
    num, den = m.tf_coefficients("velocity")
    ref_num, ref_den = scipy.signal.ss2tf(m.A, m.B, m.C, m.D)
    assert np.allclose(np.trim_zeros(num, "f") / den[0], np.trim_zeros(ref_num[0], "f") / ref_den[0])
    num[...] = 99.0  # the caller's copy: the model's own is untouched
    again, _ = m.tf_coefficients("velocity")
    assert not np.any(again == 99.0)
    assert m.first_order() is m.first_order()


def test_a_replaced_model_computes_its_own():
    m = _model(2.0, 0.3)
    fo = m.first_order()
    other = m.replace(A=[[-1.0 / 0.5]], B=[[2.0 / 0.5]])
    assert fo.time_constant_s == np.float64(0.3) or abs(fo.time_constant_s - 0.3) < 1e-12
    assert abs(other.first_order().time_constant_s - 0.5) < 1e-12
    assert abs(m.first_order().time_constant_s - 0.3) < 1e-12


def test_pickled_and_copied_models_keep_their_numbers():
    m = _model()
    m.first_order()
    for twin in (pickle.loads(pickle.dumps(m)), copy.deepcopy(m)):
        assert abs(twin.first_order().time_constant_s - 0.3) < 1e-12
        assert abs(twin.dc_gain() - 2.0) < 1e-12

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


def _two_poles_and_a_slow_pair(record_s: float) -> MotorModel:
    """Velocity (s + 0.01)/((s + 0.0101)(s + 2)(s + 5)) from a record of ``record_s``: the slow
    pole–zero pair is an artefact of a short record only (the first order drops it then)."""
    num = np.polymul([1.0], [1.0, 0.01])
    den = np.polymul(np.polymul([1.0, 0.0101], [1.0, 2.0]), [1.0, 5.0])
    a, b, c, d = scipy.signal.tf2ss(num, den)
    return MotorModel(A=a, B=b, C=c, D=d, states=("x1", "x2", "x3"), outputs=("velocity",),
                      settings={"record_length_s": record_s})


def test_a_copy_with_other_fields_keeps_what_was_computed_and_it_is_its_own():
    m = _two_poles_and_a_slow_pair(2.0)
    fo = m.first_order()
    copy_ = m.replace(warnings=("a note",), method="oe")
    assert copy_.first_order() is fo  # carried over: the same object, not recomputed
    fresh = MotorModel(**{f: getattr(copy_, f) for f in ("A", "B", "C", "D", "states", "outputs", "settings")})
    assert copy_.first_order() == fresh.first_order()
    # the settings decide which pairs are artefacts: a copy with a long record recomputes
    long = m.replace(settings={"record_length_s": 2000.0})
    ref = _two_poles_and_a_slow_pair(2000.0).first_order()
    assert long.first_order() == ref
    assert long.first_order().time_constant_s != fo.time_constant_s
    # the matrices decide the transfer function: a copy with another A recomputes both
    other = m.replace(A=m.A * 2.0)
    assert other.tf_coefficients("velocity")[1][-1] != m.tf_coefficients("velocity")[1][-1]

"""MotorModel: transfer functions, simplification, JSON and MATLAB export."""

from __future__ import annotations

import json
import re

import control
import numpy as np
import pytest

from motorid.model import ModelFormatError, MotorModel, model_from_velocity_tf


def _pinv_like() -> MotorModel:
    # Paper eq. 46 (extended state), every state an output.
    a = [[0, 1, 0], [-0.0101, -2.4731, 0.6196], [-0.0031, -0.0717, -0.2191]]
    b = [0, 2.3373, 0.082]
    return MotorModel(A=a, B=b, C=np.eye(3), D=np.zeros((3, 1)),
                      states=("position", "velocity", "current"),
                      outputs=("position", "velocity", "current"),
                      step_volts=5.92, method="pinv", settings={"structure": "free"},
                      sample_interval_s=0.12, fit={"velocity_nrmse": 0.0123},
                      warnings=("a warning",), extras={"uncertainty": {"k_std": 0.1}})


def test_transfer_functions_match_python_control() -> None:
    m = _pinv_like()
    ref = control.ss2tf(m.A, m.B, [[0, 1, 0]], 0)
    np.testing.assert_allclose(m.velocity_tf.num[0][0], ref.num[0][0] / ref.den[0][0][0], atol=1e-12)
    assert m.velocity_tf.den[0][0][0] == 1.0
    refp = control.ss2tf(m.A, m.B, [[1, 0, 0]], 0)
    # python-control's ss2tf leaves a round-off leading coefficient (−9e-16 s²) that motorid
    # drops: compare the transfer functions, on the imaginary axis
    w = 1j * np.logspace(-2, 3, 12)
    np.testing.assert_allclose(m.position_tf(w), refp(w), rtol=1e-9)
    assert len(m.position_tf.num[0][0]) == 2
    assert m.current_tf is not None
    np.testing.assert_allclose(np.sort_complex(m.poles()), np.sort_complex(np.linalg.eigvals(m.A)), atol=1e-9)


def test_velocity_only_model_position_is_integral() -> None:
    m = model_from_velocity_tf([2.0], [1.0, 2.5], step_volts=1.0, method="classic")
    assert m.states == ("velocity",)
    assert m.current_tf is None
    np.testing.assert_allclose(m.position_tf.den[0][0], [1.0, 2.5, 0.0])
    fo = m.first_order()
    assert fo.dc_gain == pytest.approx(0.8)
    assert fo.time_constant_s == pytest.approx(0.4)
    assert fo.k == pytest.approx(2.0) and fo.p == pytest.approx(2.5)


def test_tf_coefficients_are_the_transfer_functions_without_python_control() -> None:
    from motorid.errors import OptionError

    for m in (_pinv_like(), model_from_velocity_tf([2.0], [1.0, 2.5], step_volts=1.0, method="classic")):
        for channel in ("velocity", "position", "current"):
            coeffs = m.tf_coefficients(channel)
            tf = getattr(m, f"{channel}_tf")
            if tf is None:
                assert coeffs is None
                continue
            np.testing.assert_array_equal(np.ravel(tf.num[0][0]), coeffs[0])
            np.testing.assert_array_equal(np.ravel(tf.den[0][0]), coeffs[1])
    with pytest.raises(OptionError, match="no transfer function for channel 'torque'"):
        _pinv_like().tf_coefficients("torque")


def test_first_order_is_mean_residence_time() -> None:
    # G = 1/((s+1)(s+4)): τ = 1 + 1/4 (sum of time constants), DC gain 1/4.
    m = model_from_velocity_tf([1.0], [1.0, 5.0, 4.0])
    fo = m.first_order()
    assert fo.dc_gain == pytest.approx(0.25)
    assert fo.time_constant_s == pytest.approx(1.25)


def test_json_round_trip_preserves_everything() -> None:
    m = _pinv_like()
    text = json.dumps(m.to_json())
    data = json.loads(text)
    for key in ("schema", "method", "order", "step_volts", "sample_interval", "states", "state_space",
                "velocity_tf", "position_tf", "first_order", "poles", "zeros", "fit", "warnings"):
        assert key in data
    assert data["schema"] == "motorid.model/1"
    assert data["state_space"]["C"] == [[0.0, 1.0, 0.0]] and data["state_space"]["D"] == [[0.0]]
    assert data["velocity_tf"]["den"][0] == 1.0
    back = MotorModel.from_json(data, file="m.json")
    for name in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(getattr(back, name), getattr(m, name))
    assert back.states == m.states and back.outputs == m.outputs
    assert (back.step_volts, back.method, back.sample_interval_s) == (5.92, "pinv", 0.12)
    assert dict(back.fit) == dict(m.fit) and back.warnings == m.warnings
    assert dict(back.settings) == dict(m.settings) and dict(back.extras) == dict(m.extras)
    assert back.to_json() == m.to_json()


@pytest.mark.parametrize("mutate", [
    lambda d: d.update(schema="motorid.model/0"),
    lambda d: d.pop("state_space"),
    lambda d: d["state_space"].update(A=[[1, 2, 3]]),
    lambda d: d["state_space"].pop("B"),
    lambda d: d.update(states=["position"]),
])
def test_from_json_rejects_bad_input_naming_file(mutate) -> None:
    data = json.loads(json.dumps(_pinv_like().to_json()))
    mutate(data)
    with pytest.raises(ModelFormatError) as info:
        MotorModel.from_json(data, file="bad.json")
    assert str(info.value).startswith("bad.json: ")
    assert "\n" not in str(info.value)


def test_to_matlab_defines_matrices() -> None:
    m = _pinv_like()
    text = m.to_matlab()
    found = dict(re.findall(r"^([ABCD]) = \[(.*)\];$", text, flags=re.M))
    def parse(s: str) -> np.ndarray:
        return np.array([[float(v) for v in row.split()] for row in s.split(";")])
    np.testing.assert_array_equal(parse(found["A"]), m.A)
    np.testing.assert_array_equal(parse(found["B"]), m.B)
    np.testing.assert_array_equal(parse(found["C"]), [[0, 1, 0]])
    np.testing.assert_array_equal(parse(found["D"]), [[0]])
    assert "sys = ss(A, B, C, D);" in text
    assert "% states x = [position, velocity, current]" in text


def test_cancel_near_removes_pair_and_keeps_dc_gain() -> None:
    # (s + 1.01)/((s + 1)(s + 10)): the pair at -1/-1.01 is 0.1 % of the fastest pole apart.
    m = model_from_velocity_tf([1.0, 1.01], [1.0, 11.0, 10.0], with_position=True)
    c = m.cancel_near(0.01, keep="dc")
    assert c.velocity_tf.den[0][0].size == 2
    assert c.dc_gain() == pytest.approx(m.dc_gain(), rel=1e-12)
    np.testing.assert_allclose(c.poles(), [-10.0], rtol=1e-9)
    assert "position" in c.outputs
    assert m.cancel_near(1e-4) is m  # nothing within tolerance


def test_reduce_keeps_dc_gain_exactly() -> None:
    m = model_from_velocity_tf([0.9 * 20], [1.0, 22.3, 46.0], with_position=True)  # poles -2.3, -20
    r = m.reduce(1)
    assert r.dc_gain() == pytest.approx(m.dc_gain(), rel=1e-10)
    assert r.poles().size == 1
    assert r.poles()[0].real == pytest.approx(-2.3, rel=0.1)  # dominant pole survives
    # Singular perturbation adds a direct term, so the one velocity state is "x1".
    assert r.states[0] == "position" and len(r.states) == 2


def test_step_response_matches_python_control() -> None:
    m = _pinv_like()
    t = np.linspace(0, 3, 301)
    ours = m.step_response(t, 5.92)["velocity"]
    ref = control.forced_response(control.ss(m.A, m.B, [[0, 1, 0]], 0), t, np.full(t.size, 5.92)).outputs
    np.testing.assert_allclose(ours, ref, atol=1e-9 * np.abs(ref).max())
    assert m.fit_nrmse(t, ref) == pytest.approx(0.0, abs=1e-9)


def test_constructor_rejects_bad_shapes() -> None:
    with pytest.raises(ModelFormatError):
        MotorModel(A=np.eye(2), B=[1.0], C=[[0, 1]], D=[[0]], states=("position", "velocity"))
    with pytest.raises(ModelFormatError):
        MotorModel(A=np.eye(2), B=[0, 1.0], C=[[0, 1]], D=[[0]], states=("a", "b"), outputs=("position",))


def test_first_order_cancels_slow_artifact_pairs_but_keeps_fast_ones() -> None:
    """The paper's eq. 39 → 41: the near-origin pair of a pinv model is dropped (DC factor
    of a pair the record cannot show), giving 2.1751/(s + 2.2998).  A pair faster than the
    dominant pole (an SRIVC fit of the 3rd-order trainer: zero −13.78 near pole −16.17) is
    seen by the record: the first-order gain is the model's DC gain and τ its moments."""
    a = [[0.0042, 1.0325], [-0.0327, -2.3145]]
    slow = MotorModel(A=a, B=[-0.0371, 2.1751], C=np.eye(2), D=None, states=("position", "velocity"),
                      outputs=("position", "velocity"))
    fo = slow.first_order()
    assert fo.k == pytest.approx(2.1751, rel=1e-4) and fo.p == pytest.approx(2.2998, rel=1e-4)
    z, p = [-13.78], [-16.17, -2.31, -130.35]
    g = control.zpk(z, p, 1.0) * (0.92 / control.dcgain(control.zpk(z, p, 1.0)))
    fast = model_from_velocity_tf(np.ravel(g.num[0][0]), np.ravel(g.den[0][0]), step_volts=1.0, method="srivc")
    fo = fast.first_order()
    assert fo.dc_gain == pytest.approx(0.92, rel=1e-9)
    assert fo.time_constant_s == pytest.approx(sum(-1 / x for x in p) - sum(-1 / x for x in z), rel=1e-9)


def test_python_control_systems_carry_named_signals_with_units():
    """``u [V]`` → ``velocity [rpm]``: a system printed or interconnected by name says what it is."""
    from motorid.model.motor import model_from_velocity_tf

    m = model_from_velocity_tf([2.0], [0.5, 1.0], with_position=True).replace(units={"velocity": "rpm"})
    assert m.velocity_tf.input_labels == ["u [V]"] and m.velocity_tf.output_labels == ["velocity [rpm]"]
    assert m.position_tf.output_labels == ["position [V]"]
    sys = m.state_space  # a property, as the transfer functions are
    assert sys.input_labels == ["u [V]"]
    assert sys.output_labels == [f"{ch} [{'rpm' if ch == 'velocity' else 'V'}]" for ch in m.outputs]
    np.testing.assert_array_equal(m.ss().A, sys.A)  # the call kept for older code

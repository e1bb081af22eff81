"""The step response and the NRMSE on long records: no full-length temporaries, the same bits."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from motorid.identification.metrics import nrmse, response_change
from motorid.model import MotorModel
from motorid.blockwise import max_abs
from motorid.blockwise import BLOCK as _BLOCK  # the blocks the response module works in
from motorid.model.response import _uniform_steps, step_response


def _model(delay_s: float = 0.0) -> MotorModel:
    a = np.array([[0.0, 1.0, 0.0], [0.0, -2.0, 30.0], [0.0, -5.0, -400.0]])
    b = np.array([[0.0], [0.0], [500.0]])
    return MotorModel(A=a, B=b, C=np.eye(3), D=np.zeros((3, 1)), states=("position", "velocity", "current"),
                      outputs=("position", "velocity", "current"), step_volts=5.0, delay_s=delay_s)


def test_record_from_the_step_has_the_bits_of_the_general_path() -> None:
    # a grid from t = 0 is filled in place; with one sample before the step the general path (zeros, then the
    # samples after the step) runs: each sample must come out the same, bit for bit
    t = np.arange(3 * _BLOCK + 17) * 1e-4
    fast = step_response(_model(), t)
    general = step_response(_model(), np.r_[-1e-4, t])
    for name in fast:
        assert general[name][0] == 0.0
        np.testing.assert_array_equal(fast[name], general[name][1:])
        assert fast[name].tobytes() == general[name][1:].tobytes()


def test_dead_time_still_shifts_the_response() -> None:
    t = np.arange(2000) * 1e-3
    late = step_response(_model(delay_s=0.05), t)["velocity"]
    early = step_response(_model(), t)["velocity"]
    assert np.all(late[:50] == 0.0) and late[52] != 0.0
    np.testing.assert_allclose(late[60:], early[10:-50], rtol=1e-9, atol=1e-12)


def test_block_checks_match_the_full_length_computation() -> None:
    rng = np.random.default_rng(3)
    t = np.cumsum(1e-3 + rng.normal(0, 1e-9, 2 * _BLOCK + 5))
    d = np.diff(t)
    for tol in (0.0, 5e-10, 2e-9, 1e-8):
        assert _uniform_steps(t, float(t[1] - t[0]), tol) == bool(np.all(np.abs(d - d[0]) <= tol))
    assert max_abs(-t) == float(np.max(np.abs(t)))
    t[2 * _BLOCK] += 1e-6  # one step off in the last block
    assert not _uniform_steps(t, float(t[1] - t[0]), 1e-8)


def test_nrmse_is_the_formula_bit_for_bit() -> None:
    rng = np.random.default_rng(4)
    y = 2.0 * -np.expm1(-np.arange(100_001) / 3e4) + rng.normal(0, 0.01, 100_001)
    yhat = 2.0 * -np.expm1(-np.arange(100_001) / 3.1e4)
    want = float(np.sqrt(np.mean((y - yhat) ** 2)) / response_change(y))
    assert nrmse(y, yhat) == want


def test_step_response_of_a_long_record_holds_little_besides_its_result() -> None:
    # the outputs (3 channels × 8 bytes a sample) plus the orbit's half-length products; before, the
    # zeros, the copy of the times, their steps and the D-term array made it about twice that
    n = 400_000
    t = np.arange(n) * 1e-4
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        out = step_response(_model(), t)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    assert set(out) == {"position", "velocity", "current"}
    assert peak < 8 * n * 3 * 2.2, peak / (8 * n)


def _orbit_with_temporaries(phi: np.ndarray, gam: np.ndarray, x0: np.ndarray, count: int) -> np.ndarray:
    """The doubling as it was written before the in-place products: ``out[:k] @ Φᵐᵀ + c_m`` into the orbit."""
    out = np.empty((count, x0.size))
    out[0] = x0
    power, offset, m = phi.copy(), gam.copy(), 1
    while m < count:
        k = min(m, count - m)
        out[m : m + k] = out[:k] @ power.T + offset
        offset = power @ offset + offset
        power = power @ power
        m *= 2
    return out


def test_the_orbit_filled_in_place_has_the_bits_of_the_products_with_temporaries() -> None:
    from motorid.model.response import _affine_orbit

    rng = np.random.default_rng(11)
    for n in (1, 2, 3, 4, 6):
        for count in (1, 2, 3, 1000, 2**17 + 3):
            q, _ = np.linalg.qr(rng.normal(size=(n, n)))
            phi = q @ np.diag(rng.uniform(0.2, 0.9999, n)) @ q.T
            gam, x0 = rng.normal(size=n), rng.normal(size=n)
            want = _orbit_with_temporaries(phi, gam, x0, count)
            got = _affine_orbit(phi, gam, x0, count)
            assert got.tobytes() == want.tobytes(), (n, count)
            into = np.full((count, n), np.nan)
            assert _affine_orbit(phi, gam, x0, count, out=into) is into and into.tobytes() == want.tobytes()


def test_outputs_written_over_the_states_in_blocks_have_the_bits_of_the_whole_product() -> None:
    from motorid.model.response import _outputs

    rng = np.random.default_rng(12)
    for count in (5, 2 * _BLOCK - 1, 2 * _BLOCK, 3 * _BLOCK + 17):
        for n, m in ((1, 1), (3, 1), (3, 2), (3, 3), (4, 3), (2, 3)):
            x = rng.normal(size=(count, n)) * 10.0 ** rng.uniform(-6, 6, size=(count, 1))
            c = rng.normal(size=(m, n))
            want = x @ c.T
            got = _outputs(x.copy(), c)
            assert got.shape == want.shape
            assert np.ascontiguousarray(got).tobytes() == want.tobytes(), (count, n, m)


def test_a_long_records_outputs_share_the_states_memory() -> None:
    from motorid.model.response import _outputs

    x = np.ones((2 * _BLOCK + 3, 3))
    y = _outputs(x, np.array([[1.0, 2.0, 3.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]]))
    assert y is x and np.all(y[:, 0] == 6.0) and np.all(y[:, 1] == 1.0)
    one = _outputs(np.ones((2 * _BLOCK + 3, 3)), np.array([[1.0, 2.0, 3.0]]))
    assert one.shape == (2 * _BLOCK + 3, 1) and one.flags.c_contiguous  # one output: its own contiguous column


def test_nrmse_and_fit_of_a_strided_simulation_have_the_bits_of_its_contiguous_copy() -> None:
    from motorid.identification.metrics import _pair, fit_percent

    rng = np.random.default_rng(13)
    n = 100_003
    y = 2.0 * -np.expm1(-np.arange(n) / 3e4) + rng.normal(0, 0.01, n)
    outputs = np.column_stack([rng.normal(size=n), 2.0 * -np.expm1(-np.arange(n) / 3.1e4), rng.normal(size=n)])
    column = outputs[:, 1]  # a step response's channel: a strided view
    assert not column.flags.c_contiguous
    assert _pair(y, column)[1] is not None and np.shares_memory(_pair(y, column)[1], outputs)  # not copied
    assert nrmse(y, column) == nrmse(y, column.copy())
    assert fit_percent(y, column) == fit_percent(y, column.copy())


def test_step_fit_gives_the_numbers_of_nrmse_and_fit_percent_one_by_one() -> None:
    from motorid.identification.metrics import fit_percent, step_fit

    rng = np.random.default_rng(14)
    n = 700_003  # more than two blocks, the last one short
    t = np.arange(n) * 1e-5
    measured = {"velocity": 2.0 * -np.expm1(-t / 3.0) + rng.normal(0, 0.01, n),
                "position": np.cumsum(2.0 * -np.expm1(-t / 3.0)) * 1e-4 + rng.normal(0, 0.01, n),
                "current": np.zeros(n)}  # constant: no fit %
    model = _model()
    reference = step_response(model, t)
    asked: list[slice] = []
    for one_output in (False, True):
        def simulate(block: slice, one_output: bool = one_output) -> dict[str, np.ndarray]:
            asked.append(block)
            out = step_response(model, t[block])  # the model's exact response on each block of the grid
            return {"velocity": out["velocity"]} if one_output else out

        errors, fits = step_fit(measured, simulate, ["velocity", "position"] if not one_output else ["velocity"])
        # the sums are taken a block at a time: the numbers of the whole-record formulas to rounding
        for ch, value in errors.items():
            assert value == pytest.approx(nrmse(measured[ch], reference[ch], reference="final"), rel=1e-9), ch
        for ch, value in fits.items():
            assert value == pytest.approx(fit_percent(measured[ch], reference[ch]), rel=1e-9), ch
        assert "current" not in fits and set(fits) == ({"velocity"} if one_output else {"velocity", "position"})
    # never the whole record at once: blocks that tile it
    assert max(b.stop - b.start for b in asked) < n and asked[0].start == 0 and asked[2].stop == n


def test_step_fit_of_an_overflowed_simulation_is_the_worst_fit() -> None:
    from motorid.identification.metrics import step_fit

    y = np.linspace(0.0, 1.0, 1000)
    errors, fits = step_fit({"velocity": y}, lambda b: {"velocity": np.full(b.stop - b.start, np.inf)}, ["velocity"])
    assert errors["velocity"] == float("inf") and fits["velocity"] == float("-inf")

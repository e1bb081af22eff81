"""motorid.numfmt: four significant figures, conjugate pairs, names in words.

Checked against Python's own rounding (``format(x, ".4g")``) as the independent reference: the
text must be the same number, with no exponent between 1e-4 and 1e6 and no ``-0``.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from motorid.numfmt import complex_text, metric_name, roots_text, sig


def _significant_digits(text: str) -> int:
    mant = text.split("e")[0].lstrip("-").replace(".", "").lstrip("0")
    return len(mant.rstrip("0")) if "." in text.split("e")[0] else len(mant.rstrip("0") or "0")


def test_sig_is_python_rounding_to_four_figures_in_plain_notation() -> None:
    rng = np.random.default_rng(16)
    xs = rng.choice([-1, 1], 3000) * 10 ** rng.uniform(-6, 8, 3000)
    for x in xs:
        text = sig(x)
        assert float(text) == float(format(x, ".4g")), (x, text)
        assert _significant_digits(text) <= 4, (x, text)
        if 1e-4 <= abs(float(format(x, ".4g"))) < 1e6:
            assert "e" not in text, (x, text)
        else:
            assert re.fullmatch(r"-?\d(\.\d+)?e[+-]\d\d", text), (x, text)


@pytest.mark.parametrize(("x", "text"), [
    (0.90464, "0.9046"), (5088.3, "5088"), (12345.6, "12350"), (-0.0, "0"), (-1e-9 * 0, "0"),
    (9.99996, "10"), (5.92, "5.92"), (1.2e7, "1.2e+07"), (-2.3113, "-2.311"), (-0.00004, "-4e-05"),
])
def test_sig_examples(x: float, text: str) -> None:
    assert sig(x) == text


def test_sig_never_writes_minus_zero() -> None:
    for x in (-1e-12, -0.0):
        assert not sig(x).startswith("-0") or sig(x) == sig(x).replace("-", "", 0)
    assert sig(-0.0) == "0"
    assert sig(float("nan")) == "nan" and sig(float("-inf")) == "-inf"


def test_complex_numbers() -> None:
    assert complex_text(-2.8 + 1.15j) == "-2.800 + 1.150j"
    assert complex_text(-2.8 - 1.15j) == "-2.800 − 1.150j"
    assert complex_text(-2.8 + 1.15j, 3, pair=True) == "-2.80 ± 1.15j"  # the example
    assert complex_text(-3 + 0j) == "-3" and "j" not in complex_text(complex(-3, 1e-14))  # no +0j
    assert complex_text(-1e-3 + 2000j) == "-0.001 + 2000j"  # a tiny real part keeps its sign


def test_roots_merge_conjugate_pairs_and_keep_the_others() -> None:
    roots = np.roots([1, 10.6, 46.4, 63.1])  # one real root and a conjugate pair
    text = roots_text(roots)
    assert text.count("±") == 1 and text.count(",") == 1
    real = roots[np.abs(roots.imag) < 1e-9][0].real
    pair = roots[roots.imag > 1e-9][0]
    assert sig(real) in text and complex_text(pair, pair=True) in text
    # each printed number is within half a unit of its 4th figure of the true root
    nums = [float(v) for v in re.findall(r"-?\d+\.\d+|-?\d+", text)]
    assert math.isclose(nums[0], real, rel_tol=5e-4) or math.isclose(nums[-1], real, rel_tol=5e-4)
    assert roots_text([-1 + 2j, -1 + 2j]) == "-1.000 + 2.000j, -1.000 + 2.000j"  # no conjugate: not merged


def test_metric_names_in_words() -> None:
    assert metric_name("settling_time_s") == "settling time (2 %)"
    assert metric_name("velocity_nrmse") == "velocity NRMSE"
    assert metric_name("something_new") == "something new"


def test_a_double_real_pole_is_printed_once() -> None:
    """Pole placement's double pole comes back from the eigenvalue solver as -8 ± 3e-5j: printed
    as ``-8.000 ± 0.000j`` it read as an oscillation; it is one real pole, twice."""
    assert roots_text([-48.0, -8 + 3e-5j, -8 - 3e-5j]) == "-48, -8 (double)"
    assert roots_text([-8 + 0.01j, -8 - 0.01j]) == "-8.000 ± 0.010j"  # a visible imaginary part stays a pair
    # a pole-placement double pole, as python-control computes it
    import control

    a = np.array([[0.0, 1.0], [0.0, -2.0]])
    b = np.array([[0.0], [3.0]])
    k = control.acker(a, b, [-8.0, -8.0])
    text = roots_text(np.linalg.eigvals(a - b @ np.atleast_2d(k)))
    assert text == "-8 (double)", text

"""``identify(method_options=…)``: each estimator's own settings from Python reach that estimator."""

from __future__ import annotations

import pytest

import motorid as mi
from motorid.errors import OptionError


@pytest.fixture(scope="module")
def exp(demo_run):
    d = demo_run.folder
    return mi.read_experiment(position=d / "ALL0000", velocity=d / "ALL0001", current=d / "ALL0002")


@pytest.fixture(scope="module")
def default_auto(exp):
    return mi.identify(exp)


def _stage(fit, name):
    return next(st for st in fit.to_json()["stages"] if st.get("stage") == name)


def test_the_defaults_are_the_methods_own(exp, default_auto):
    """Passing the default settings objects changes nothing in the model."""
    given = mi.MethodOptions(laguerre=mi.LaguerreSettings(), srivc=mi.SrivcSettings(),
                             output_error=mi.OutputErrorOptions())
    again = mi.identify(exp, method_options=given)
    for a, b in zip(again.model.tf_coefficients("velocity"), default_auto.model.tf_coefficients("velocity"),
                    strict=True):
        assert a.tolist() == b.tolist()
    assert again.params["time_constant"].value == default_auto.params["time_constant"].value


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_a_fixed_laguerre_pole_reaches_the_markov_method(exp):
    """The Laguerre basis pole given is the one the Markov method used (its choice text says so)."""
    fit = mi.identify(exp, method="markov", method_options=mi.MethodOptions(laguerre=mi.LaguerreSettings(pole=37.0)))
    assert "Laguerre basis a = 37 1/s" in fit.reason or "a = 37 1/s" in fit.model.extras.get("choice", "") \
        or "a = 37 1/s" in str(fit.to_json())
    free = mi.identify(exp, method="markov")
    assert "a = 37 1/s" not in str(free.to_json())


def test_output_error_evaluations_reach_the_fit(exp):
    """Two evaluations are too few for the output-error fit: the sanity gate says it stopped before converging."""
    fit = mi.identify(exp, method="oe", order=2,
                      method_options=mi.MethodOptions(output_error=mi.OutputErrorOptions(max_nfev=2)))
    assert any("stopped before converging" in w for w in fit.warnings)
    normal = mi.identify(exp, method="oe", order=2)
    assert not any("stopped before converging" in w or "stopped early" in w for w in normal.warnings)


def test_srivc_iterations_reach_srivc(exp):
    """One SRIVC iteration does not converge, and the model says so; the default runs more."""
    fit = mi.identify(exp, method="srivc", order=2,
                      method_options=mi.MethodOptions(srivc=mi.SrivcSettings(max_iter=1)))
    assert any("did not converge in 1 iterations" in w for w in fit.warnings)
    normal = mi.identify(exp, method="srivc", order=2)
    assert not any("in 1 iterations" in w for w in normal.warnings)
    assert fit.model.tf_coefficients("velocity")[1].tolist() != normal.model.tf_coefficients("velocity")[1].tolist()


@pytest.mark.parametrize(("options", "words"), [
    ({"method_options": "fast"}, "method_options must be a MethodOptions"),
    ({"markov_params": 9, "method_options": mi.MethodOptions(laguerre=mi.LaguerreSettings(n_terms=12))},
     "markov_params=9 and method_options.laguerre.n_terms=12 disagree"),
    ({"order": 2, "method_options": mi.MethodOptions(laguerre=mi.LaguerreSettings(order=3))},
     "order=2 and method_options.laguerre.order=3 disagree"),
])
def test_bad_method_options_are_refused_naming_them(exp, options, words):
    with pytest.raises(OptionError, match=words):
        mi.identify(exp, **options)


@pytest.mark.parametrize(("build", "words"), [
    (lambda: mi.OutputErrorOptions(tolerance=2.0), "method_options.output_error.tolerance must be a number"),
    (lambda: mi.OutputErrorOptions(max_nfev=0), "method_options.output_error.max_nfev must be a whole number"),
    (lambda: mi.MethodOptions(srivc=mi.SrivcSettings(max_iter=0)), "method_options.srivc.max_iter"),
    (lambda: mi.SrivcSettings(tol=0.0), "method_options.srivc.tol must be a number"),  # checked where declared
    (lambda: mi.MethodOptions(laguerre=mi.SrivcSettings()), "method_options.laguerre must be a LaguerreSettings"),
])
def test_bad_settings_objects_are_refused_naming_the_field(build, words):
    with pytest.raises(OptionError, match=words):
        build()

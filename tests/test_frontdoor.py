"""The Python front door: ``import motorid as mi`` and the five calls on the demo."""

from __future__ import annotations

import json
import math
import pydoc
import subprocess
import sys
import time

import control
import numpy as np
import pytest

import motorid as mi
from motorid.errors import CaptureFormatError, MotorIdError, OptionError
from motorid.numfmt import sig

FRONT_DOOR = ("read_experiment", "identify", "design", "simulate", "write_report")


@pytest.fixture(scope="module")
def demo(demo_run):
    return demo_run.folder


@pytest.fixture(scope="module")
def fit(demo):
    exp = mi.read_experiment(position=demo / "ALL0000", velocity=demo / "ALL0001", current=demo / "ALL0002")
    t = time.perf_counter()
    result = mi.identify(exp)
    # timing is measured in bench/frontdoor_speed.py, not asserted here (< 2 s)
    print(f"mi.identify on the demo: {time.perf_counter() - t:.2f} s")
    return result


@pytest.mark.slow
def test_issue_example_runs_as_written(demo, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "D").symlink_to(demo)
    exp = mi.read_experiment(position="D/ALL0000", velocity="D/ALL0001", current="D/ALL0002")
    fit = mi.identify(exp)
    text = fit.summary()
    assert text.startswith("identified model: method ")
    fit.params["dc_gain"].value, fit.params["dc_gain"].stderr, fit.params["dc_gain"].ci95
    assert isinstance(fit.model.velocity_tf, control.TransferFunction)
    des = mi.design(fit.model, damping=0.7, wn=5.0)
    sim = mi.simulate(fit.model, des, duration_s=3.0)
    fig = sim.plot()
    assert fig.axes
    mi.write_report("report.html", fit, design=des)
    assert (tmp_path / "report.html").is_file()


def test_help_lists_the_front_door():
    text = pydoc.render_doc(mi, renderer=pydoc.plaintext)
    for name in (*FRONT_DOOR, "IdentificationResult", "ParameterEstimate", "MotorIdError"):
        assert name in text, name
    # every public name is in the catalogue and can be reached
    for name in mi.__all__:
        assert name in mi.__doc__, name
        assert getattr(mi, name) is not None


def test_import_motorid_stays_light():
    code = ("import sys, motorid; heavy = [m for m in ('scipy', 'control', 'matplotlib', 'typer', 'rich') "
            "if m in sys.modules]; print(','.join(heavy))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == ""


def test_front_door_functions_are_plain_functions_beside_their_stage_packages():
    # the stage subpackages are motorid.identification / motorid.simulation: no name clash
    code = ("import inspect, motorid as mi; import motorid.simulation.closed_loop as cl; "
            "import motorid.identification.pinv; from motorid import frontdoor; "
            "assert mi.identify is frontdoor.identify and mi.simulate is frontdoor.simulate; "
            "assert inspect.isfunction(mi.identify); print(cl.__name__)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "motorid.simulation.closed_loop"


def _mypy(tmp_path, snippet: str) -> subprocess.CompletedProcess:
    f = tmp_path / "snippet.py"
    f.write_text(snippet)
    return subprocess.run([sys.executable, "-m", "mypy", "--no-incremental", "--cache-dir", str(tmp_path / "c"),
                           "--follow-imports", "silent", str(f)], capture_output=True, text=True)


@pytest.mark.slow
def test_type_checkers_see_the_front_door_signatures(tmp_path):
    good = _mypy(tmp_path, "import motorid as mi\nexp = mi.read_experiment(velocity='v.csv')\n"
                           "fit = mi.identify(exp, method='oe')\nreveal_type(mi.identify)\n"
                           "reveal_type(fit.params)\n")
    assert "def (experiment: motorid.frontdoor.Experiment" in good.stdout, good.stdout
    assert "error" not in good.stdout.replace("note:", ""), good.stdout
    bad = _mypy(tmp_path, "import motorid as mi\nexp = mi.read_experiment(velocity='v.csv')\n"
                          "mi.identify(exp, methd='oe')\nmi.design(exp, overshot=5)\n")
    assert bad.returncode == 1
    assert 'Unexpected keyword argument "methd"' in bad.stdout, bad.stdout
    assert 'Unexpected keyword argument "overshot"' in bad.stdout, bad.stdout


def test_params_carry_value_stderr_and_interval(fit):
    dc = fit.params["dc_gain"]
    assert dc.ci95 is not None and dc.ci95[0] < dc.value < dc.ci95[1]
    assert dc.stderr > 0
    # the headline gain is the velocity TF's DC gain, computed independently by python-control
    assert dc.value == pytest.approx(float(control.dcgain(fit.model.velocity_tf)), rel=1e-9)
    # each pole of the model is a parameter (the roots of the TF's denominator, by numpy)
    den = np.ravel(fit.model.velocity_tf.den[0][0])
    roots = np.sort_complex(np.roots(den))
    got = np.sort_complex(np.array([complex(p.value) for k, p in fit.params.items() if k.startswith("pole_")]))
    np.testing.assert_allclose(got, roots, rtol=1e-6)
    with pytest.raises(TypeError):
        fit.params["dc_gain"] = dc  # read-only


def test_method_without_interval_gives_nan_stderr(demo):
    exp = mi.read_experiment(velocity=demo / "ALL0001")
    fit = mi.identify(exp, method="classic")
    tau = fit.params["time_constant"]
    assert math.isnan(tau.stderr) and tau.ci95 is None
    assert tau.value == pytest.approx(fit.model.first_order().time_constant_s)


def test_summary_and_json_equal_the_cli(fit, demo, run_cli, tmp_path):
    m = tmp_path / "m.json"
    res = run_cli("identify", "--position", demo / "ALL0000", "--velocity", demo / "ALL0001",
                  "--current", demo / "ALL0002", "--json", m)
    assert res.code == 0, res.err
    printed = res.out.split("\nmodel JSON: ")[0]
    # the CLI wraps long lines at its console width; the words and their order are the same
    assert printed.split() == fit.summary().split()
    assert json.loads(m.read_text()) == json.loads(json.dumps(fit.to_json()))


def test_simulation_plot_is_a_figure_of_the_run(fit):
    from matplotlib.figure import Figure

    des = mi.design(fit, damping=0.7, wn=5.0)
    sim = mi.simulate(fit, des, duration_s=3.0)
    fig = sim.plot(title="run")
    assert isinstance(fig, Figure) and len(fig.axes) == 3
    line = fig.axes[0].get_lines()[1]
    np.testing.assert_array_equal(line.get_ydata(), sim.output_v)


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_write_report_writes_html(fit, tmp_path):
    des = mi.design(fit.model, damping=0.7, wn=5.0)
    path = mi.write_report(tmp_path / "r.html", fit, design=des, validation=[])
    assert path.read_text(encoding="utf-8").startswith("<!DOCTYPE html>")
    from motorid.errors import OutputExistsError

    with pytest.raises(OutputExistsError):
        mi.write_report(tmp_path / "r.html", fit, overwrite=False)


def test_provenance_records_version_files_and_settings(fit, demo):
    import hashlib

    prov = fit.provenance
    assert prov.version == mi.__version__
    f = demo / "ALL0001" / "F0001CH2.CSV"
    assert prov.inputs_sha256[str(f)] == hashlib.sha256(f.read_bytes()).hexdigest()
    assert prov.settings["method"] == "auto"


@pytest.mark.parametrize("call, kind, word", [
    (lambda exp: mi.identify(exp, method="bogus"), OptionError, "method"),
    (lambda exp: mi.identify(exp, order=5), OptionError, "order"),
    (lambda exp: mi.identify(exp, sample_interval=-1.0), OptionError, "sample_interval"),
    (lambda exp: mi.identify("not an experiment"), OptionError, "Experiment"),
    (lambda exp: mi.read_experiment(velocity="/nonexistent/ALL0001"), CaptureFormatError, "no such file"),
    (lambda exp: mi.read_experiment(current="x.csv"), OptionError, "velocity="),
    (lambda exp: mi.design(object(), damping=0.7, wn=5.0), OptionError, "model="),
])
def test_bad_input_raises_one_line_motorid_error(demo, call, kind, word):
    exp = mi.read_experiment(velocity=demo / "ALL0001")
    with pytest.raises(kind) as info:
        call(exp)
    assert isinstance(info.value, MotorIdError)
    assert "\n" not in str(info.value) and word in str(info.value)


def test_role_check_names_the_parameter(demo):
    with pytest.raises(OptionError, match="force_role=True"):
        mi.read_experiment(velocity=demo / "ALL0000")  # the position sawtooth
    exp = mi.read_experiment(velocity=demo / "ALL0000", force_role=True)
    assert set(exp.captures) == {"velocity"}


def test_results_cross_process_boundaries_and_stay_read_only(fit):
    """A result, its experiment and its model pickle (the web page's workers, multiprocessing,
    joblib) and deep-copy; the mappings are read-only again on arrival."""
    import copy
    import pickle
    from types import MappingProxyType

    back = pickle.loads(pickle.dumps(fit))
    assert back.to_json() == fit.to_json()
    assert back.model.to_json_text() == fit.model.to_json_text()
    assert back.model.uncertainty == fit.model.uncertainty
    for mapping in (back.params, back.fit, back.experiment.captures, back.model.uncertainty.timing,
                    back.experiment.captures["velocity"].extra, back.provenance.settings):
        assert isinstance(mapping, MappingProxyType)
    with pytest.raises(TypeError):
        back.params["dc_gain"] = None  # type: ignore[index]
    np.testing.assert_array_equal(copy.deepcopy(fit).model.A, fit.model.A)


def test_a_result_reads_in_a_notebook(fit):
    """``repr`` is one line with the headline numbers (not the arrays), the HTML view a table of
    the parameters with their intervals, and ``plot()`` the measured-vs-model figure."""
    from matplotlib.figure import Figure

    text = repr(fit)
    assert text.startswith("<IdentificationResult ") and "\n" not in text and len(text) < 400, text
    gain = fit.params["dc_gain"]
    assert f"dc gain {sig(gain.value)} {gain.unit} [{sig(gain.ci95[0])}, {sig(gain.ci95[1])}]" in text
    assert f"{len(fit.sanity.checks)}/{len(fit.sanity.checks)} checks passed" in text
    page = fit._repr_html_()
    assert page.count("<tr>") == 1 + len(fit.params) and "95 % interval" in page
    fig = fit.plot()
    assert isinstance(fig, Figure)
    roles = [r for r in ("velocity", "position", "current") if r in fit.model.outputs]
    assert [ax.get_title(loc="left") for ax in fig.axes[::2]] == roles
    assert fig.axes[0].get_ylabel() == f"velocity ({fit.model.units.get('velocity') or 'V'})"


def test_design_and_simulate_read_files_after_checking_their_options(fit, tmp_path):
    # what the command line gives: files, and poles as text
    model_file = tmp_path / "m.json"
    model_file.write_text(fit.model.to_json_text())
    poles = [-6 + 3j, -6 - 3j, -40, -50, -60][:fit.model.A.shape[0]]
    text = ", ".join(f"{p.real:g}{p.imag:+g}j" if p.imag else f"{p.real:g}" for p in map(complex, poles))
    des = mi.design(model_file, poles=text, sensors="position,velocity")
    same = mi.design(fit, poles=poles, sensors=["position", "velocity"])
    np.testing.assert_array_equal(des.K, same.K)
    design_file = tmp_path / "d.json"
    design_file.write_text(json.dumps(des.to_json()))
    from_files = mi.simulate(model_file, design_file, duration_s=2.0)
    np.testing.assert_allclose(from_files.output_v, mi.simulate(fit, des, duration_s=2.0).output_v, rtol=1e-12)
    # an option error comes before any file is read (the files need not exist), in the caller's words
    missing = tmp_path / "nothing.json"
    with pytest.raises(OptionError, match=r"^dt") as err:
        mi.simulate(missing, missing, dt_s=0.0)
    assert err.value.file is None
    with pytest.raises(OptionError, match="trainer_preset"):
        mi.simulate(missing, missing, plant="trainer", trainer_preset="nope")
    with pytest.raises(OptionError, match="poles: cannot read"):
        mi.design(missing, poles="-3+2j,abc")


def test_a_refused_design_names_the_file_it_came_from(fit, tmp_path):
    from motorid.model import MotorModel

    other = MotorModel(A=np.diag([-1.0, -2.0, -3.0]), B=[[1.0], [1.0], [1.0]], C=[[1.0, 1.0, 1.0]],
                       D=[[0.0]], states=("x1", "x2", "x3"), outputs=("velocity",))
    model_file = tmp_path / "other.json"
    model_file.write_text(other.to_json_text())
    design_file = tmp_path / "d.json"
    design_file.write_text(json.dumps(mi.design(fit, damping=0.7, wn=5.0).to_json()))
    with pytest.raises(OptionError) as err:
        mi.simulate(model_file, design_file)
    assert err.value.file == str(design_file)
    with pytest.raises(OptionError) as err:  # given as objects, no file is named
        mi.simulate(other, mi.design(fit, damping=0.7, wn=5.0))
    assert err.value.file is None


def test_identify_levels_takes_captures_and_one_level_for_all(tmp_path):
    from motorid.trainer.multilevel import multilevel_experiment

    exp = multilevel_experiment("deadzone", levels=(2.0, 4.0, 6.0), repeats=1, seed=0)
    caps = [c.capture for c in exp.captures]
    res = mi.identify_levels(caps)  # Capture objects, e.g. the steps of one staircase log
    assert len(res.responses) == 3
    assert res.static.gain_ci95[0] <= exp.truth.gain <= res.static.gain_ci95[1]
    with pytest.raises(OptionError, match="step_volts gives 2 levels for 3 captures"):
        mi.identify_levels(caps, step_volts=[1.0, 2.0])


@pytest.mark.slow  # a whole report (3 s); the demo's own report goes the same way in the quick part
def test_write_report_takes_named_validation_a_truth_and_a_title(fit, demo, tmp_path):
    truth = {"schema": "motorid.trainer-truth/1", "preset": "paper", "seed": 0, "captures": {},
             "transfer_functions": {}, "config": {}}
    page = mi.write_report(tmp_path / "r.html", fit, validation={"sine": demo / "ALL0003"}, truth=truth,
                           title="my rig").read_text(encoding="utf-8")
    assert "<title>my rig" in page and "sine" in page and "ALL0003" not in page.split("Files:")[0]


def test_validate_scores_the_model_as_the_command_line_does(fit, demo, run_cli, tmp_path):
    model_file = tmp_path / "m.json"
    model_file.write_text(fit.model.to_json_text())
    results = mi.validate(fit, [demo / "ALL0003", demo / "ALL0004"])
    assert [type(r).__name__ for r in results] == ["ValidationResult"] * 2
    res = run_cli("validate", model_file, f"{demo / 'ALL0003'},{demo / 'ALL0004'}", "--json")
    assert res.code == 0, res.err
    by_cli = json.loads(res.out)
    assert [r["nrmse"] for r in by_cli] == pytest.approx([r.nrmse for r in results], rel=1e-12)
    # the options are checked before any file is read, in the caller's words
    with pytest.raises(OptionError, match=r"^warmup_s must be"):
        mi.validate(tmp_path / "missing.json", tmp_path / "missing", warmup_s=-1.0)
    from motorid.model import MotorModel

    velocity_only = tmp_path / "v.json"
    velocity_only.write_text(MotorModel(A=[[-2.0]], B=[[2.0]], C=[[1.0]], D=[[0.0]], states=("velocity",),
                                        outputs=("velocity",)).to_json_text())
    with pytest.raises(OptionError, match="has no 'current' output") as err:
        mi.validate(velocity_only, demo / "ALL0003", channel="current")
    assert err.value.file == str(velocity_only)


def test_validate_names_the_output_a_poorly_fitting_capture_matches(fit, demo, run_cli):
    """A velocity capture validated as the position gave "NRMSE 66 %" and nothing else, which reads
    as a bad model; now the model's other outputs are tried and the one that fits is named."""
    (as_position,) = mi.validate(fit, demo / "ALL0003", channel="position")
    (as_velocity,) = mi.validate(fit, demo / "ALL0003", channel="velocity")
    assert as_position.nrmse > 0.2 and as_velocity.nrmse < 0.05
    hint = [w for w in as_position.warnings if "was this capture of the velocity?" in w]
    assert len(hint) == 1 and "(--channel velocity)" in hint[0]
    assert f"{100 * as_velocity.nrmse:.4g} % as the model's velocity" in hint[0]
    assert not any("was this capture" in w for w in as_velocity.warnings)

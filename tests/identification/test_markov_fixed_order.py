"""The Markov method at an order the data do not support: unstable realisations are set aside, not simulated.

On the HSLU lab's closed-loop log ``12_dc_step_20_25_05.csv``, ``--method markov --order 2``
kept an unstable realisation (a fixed order keeps them, as a start for the polish) and simulated
it over the 20 s record: its response overflowed, numpy's least squares stopped with "SVD did not
converge", LAPACK wrote "On entry to DLASCL parameter number 4 had an illegal value" six times
to stderr, and the command ended in "internal error: LinAlgError".
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from motorid.errors import IdentificationError
from motorid.identification.laguerre import _refit_input_gains

LOG = "hslu-rtl-dcmotor/csv/12_dc_step_20_25_05.csv"


def test_an_unstable_realisation_is_refused_before_its_least_squares():
    t = np.arange(0.0, 20.0, 0.01)
    a = np.array([[50.0]])  # a pole at +50 1/s: e^(50·20) overflows
    with np.errstate(over="ignore", invalid="ignore"), pytest.raises(IdentificationError, match="unstable"):
        _refit_input_gains(a, np.array([[1.0]]), t, np.ones_like(t), None, 1.0, 0.0, False)
    stable, _ = _refit_input_gains(-a, np.array([[1.0]]), t, 50.0 * (1 - np.exp(-50.0 * t)), None, 1.0, 0.0, False)
    assert stable[0, 0] == pytest.approx(2500.0, rel=1e-6)  # ẋ = −50x + B·1 settles at B/50 = 50


def test_markov_at_order_2_on_the_closed_loop_log_as_a_user_runs_it(real_dir, tmp_path):
    out = tmp_path / "m.json"
    proc = subprocess.run([sys.executable, "-m", "motorid", "identify", "--velocity", str(real_dir / LOG),
                           "--method", "markov", "--order", "2", "--json", str(out)],
                          capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "internal error" not in proc.stderr and "DLASCL" not in proc.stderr + proc.stdout
    assert out.is_file() and "2 poles of the velocity TF" in proc.stdout


@pytest.mark.slow  # an end-to-end run of several seconds: the full suite runs it
def test_the_order_2_model_of_the_closed_loop_log_goes_on_to_design_simulate_and_the_report(real_dir, tmp_path):
    import warnings

    import motorid as mi

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fit = mi.identify(mi.read_experiment(velocity=str(real_dir / LOG)), method="markov", order=2)
    assert len(fit.model.poles()) == 2
    design = mi.design(fit.model, overshoot=5, settling_time=1.0)
    sim = mi.simulate(fit.model, design)
    assert np.all(np.isfinite(np.asarray(sim.time_s)))
    mi.write_report(tmp_path / "report.html", fit, design=design)
    assert (tmp_path / "report.html").stat().st_size > 0

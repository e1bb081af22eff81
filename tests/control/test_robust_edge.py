"""Plausible motors of a fit whose pair of poles stopped at its double pole (the edge of its real poles).

The model is the output-error fit of the HSLU lab's open-loop rig log ``06_dc_step_5_15_00``
(written out, so the test runs in a plain clone): poles −5.146 and a pair at −14.24 that the fit
holds at its double pole.  There the response changes with the square of the pair's split, and
the delta method's covariance of the two log time constants has a variance of 24 489 along
their difference (±2229 1/s on each pole).  Drawn as a Gaussian along it, the "plausible motors"
had one pole at microseconds and the other at hours, and the design below (poles −20, −20, −100,
gain margin 22 dB, phase margin 73°) was "stable for 42.1 % of 2000 plausible motors".
"""

from __future__ import annotations

import numpy as np
import pytest

from motorid.control import DesignSettings, design_controller
from motorid.control.robust import _draws, _Joint, robust_check
from motorid.model import MotorModel
from motorid.model.uncertainty import Uncertainty

UNCERTAINTY = {
    "poles": [{"value": [-5.146303230636665, 0.0], "std": 0.19780477536843916},
              {"value": [-14.238588500049488, 0.0], "std": 2228.0817431798873},
              {"value": [-14.247074003299204, 0.0], "std": 2229.514807442742}],
    "pole_pairs": [{"poles": [1, 2], "natural_frequency": {"value": 14.242830619744451, "std": 0.31149245537085735},
                    "damping": {"value": 1.00000004436828, "std": None, "ci95": [None, None]}}],
    "joint": {"parameters": ["K", "log_tau_0", "log_tau_1", "log_tau_2"],
              "values": [245.75787318600524, -1.6382786376261687, -2.656551552529122, -2.655955778883365],
              "covariance": [[0.012583266428956016, 0.0012525193842994966, 3.7794044279892542, -3.779913154919156],
                             [0.0012525193843371087, 0.00147734797009402, 5.270196181705465, -5.270695557652681],
                             [3.7794044281598427, 5.270196181699634, 24488.904739325677, -24487.747898595015],
                             [-3.779913155089737, -5.270695557646854, -24487.74789859503, 24486.59297107353]]},
}
MODEL = MotorModel(
    A=np.array([[-33.63196573398535, -349.4540810305391, -1043.969933855244], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]),
    B=np.array([[1.0], [0.0], [0.0]]), C=np.array([[0.0, 0.0, 256563.83061439937]]), D=np.zeros((1, 1)),
    states=("x1", "x2", "x3"), outputs=("velocity",), method="oe", units={"velocity": "rpm"},
    uncertainty=Uncertainty.from_dict(UNCERTAINTY))


def test_the_pairs_split_is_held_and_everything_else_keeps_its_spread():
    joint = _Joint.of(MODEL)
    assert joint is not None
    held = joint.held_at_edges(MODEL)
    assert len(held.held) == 1 and "poles 2 and 3 held at their double pole" in held.held[0]
    theta = _draws(held, 4000, np.random.default_rng(1))
    split = theta[:, 2] - theta[:, 3]
    assert np.ptp(split) < 1e-9  # the fit's own split, −6e-4 in log τ, every draw
    assert np.mean(split) == pytest.approx(joint.values[2] - joint.values[3], abs=1e-9)
    # the rest is the Gaussian conditioned on the split (independently: Σ − Σd dᵀΣ / dᵀΣd)
    d = np.array([0.0, 0.0, 1.0, -1.0])
    cond = joint.cov - np.outer(joint.cov @ d, joint.cov @ d) / (d @ joint.cov @ d)
    mean_log_tau = 0.5 * (theta[:, 2] + theta[:, 3])
    want = np.sqrt(0.25 * (cond[2, 2] + cond[3, 3] + 2 * cond[2, 3]))
    # inside the 95 % region (truncated), the spread is a little under the Gaussian's
    assert 0.7 * want < np.std(mean_log_tau) < 1.0 * want
    assert np.std(theta[:, 0]) == pytest.approx(0.85 * np.sqrt(cond[0, 0]), rel=0.15)
    # without it the draws are no motors: the split's standard deviation is 221 in log τ
    assert np.sqrt(d @ joint.cov @ d) > 200


def test_a_well_damped_design_is_stable_on_every_plausible_motor():
    design = design_controller(MODEL, DesignSettings(damping=1.0, wn=20.0))
    check = robust_check(MODEL, design, samples=500)
    assert check.stable_fraction == 1.0
    assert "held at their double pole" in check.note
    lo, _, hi = check.gain_margin_db
    assert 20 < lo <= hi < 25  # the nominal loop's 22.4 dB, spread by the fit's intervals

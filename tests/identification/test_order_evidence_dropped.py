"""The order search says why a structure it fitted was not kept.

On a clean first-order rpm log (python-control's step response of 180/(0.25 s + 1) rpm/V, a
6 V step, 3 rpm of noise) the three-pole fits park an extra pole faster than the record can show
and are dropped.  Before, the choice did not mention them (or read "only 1 pole(s) and 0 zero(s)
could be fitted", as if the others had failed to converge); now it names them and the reason.
"""

from __future__ import annotations

import control
import numpy as np
from clihelpers import motorid_ok


def test_a_dropped_structure_is_named_with_its_reason(tmp_path):
    t = np.arange(0.0, 3.0, 0.01)
    _, y = control.forced_response(control.tf([180.0], [0.25, 1.0]), T=t, U=np.where(t >= 0.5, 6.0, 0.0))
    y = y + np.random.default_rng(2).normal(0.0, 3.0, t.size)
    log = tmp_path / "log.csv"
    rows = [f"{a:.3f},{6.0 if a >= 0.5 else 0.0:.2f},{b:.1f}" for a, b in zip(t, y, strict=True)]
    log.write_text("time,voltage,rpm\n" + "\n".join(rows) + "\n")
    out = " ".join(motorid_ok("identify", "--velocity", log).out.split())
    choice = out[out.index("choice:"):]
    assert "not kept (a pole or zero beyond the sampling rate, faster than the record can show): " in choice
    assert "could be fitted" not in choice

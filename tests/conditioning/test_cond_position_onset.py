"""The onset of a position log with no input channel (an encoder in counts, a potentiometer).

Before: a line through 10–30 % of the peak of the ramp met the baseline a time constant late
(110.408 s detected, motion from 110.300 s) and every fit then failed; ``--t0`` at the first
sample was refused as "outside the record".
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from motorid.capture import Capture, ChannelInfo
from motorid.conditioning.edge import response_onset
from motorid.conditioning.response import step_response

DT, TAU, SPEED = 0.005, 0.08, 3000.0


def _encoder(t_on: float, n: int = 400, t_first: float = 110.0, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Counts of a delayed, lagged ramp, floored to whole counts with a random code phase."""
    rng = np.random.default_rng(seed)
    t = t_first + np.arange(n) * DT
    te = np.clip(t - t_on, 0, None)
    return t, np.floor(SPEED * (te - TAU * (1 - np.exp(-te / TAU))) + rng.uniform(0, 1))


@pytest.mark.parametrize("phase", [0.0, 0.3, 0.8])
def test_the_ramp_onset_is_found_within_a_sample(phase):
    t_on = 110.3 + phase * DT
    t, counts = _encoder(t_on)
    cap = Capture("<enc>", "plain-csv", t, counts, ChannelInfo("encoder_counts", "counts"))
    old = response_onset(t, counts)
    assert old.time_s - t_on > 0.5 * TAU  # the read-off is a time constant late
    r = step_response(cap, "position", step_volts=6.0)
    assert abs(r.edge.time_s - t_on) < DT


def test_an_encoder_log_through_the_cli_and_t0_at_the_first_sample(tmp_path, run_cli):
    t, counts = _encoder(110.3021)
    f = tmp_path / "enc.csv"
    f.write_text("time_s,encoder_counts\n" + "\n".join(f"{a:.3f},{int(c)}" for a, c in zip(t, counts, strict=True)))
    out = tmp_path / "m.json"
    res = run_cli("identify", "--position", str(f), "--step-volts", "6", "--json", str(out))
    assert res.code == 0, res.err
    m = json.loads(out.read_text())
    assert m["first_order"]["dc_gain"] == pytest.approx(SPEED / 6, rel=0.01)
    assert m["first_order"]["residence_time_s"] == pytest.approx(TAU, rel=0.05)
    # a log that starts at the step: --t0 at its first sample is accepted, with a note
    t2 = np.arange(300) * DT
    pos = np.floor(SPEED * (t2 - TAU * (1 - np.exp(-t2 / TAU))))
    g = tmp_path / "start.csv"
    g.write_text("time_s,encoder_counts\n" + "\n".join(f"{a:.3f},{int(c)}" for a, c in zip(t2, pos, strict=True)))
    out2 = tmp_path / "s.json"
    res = run_cli("identify", "--position", str(g), "--step-volts", "6", "--t0", "0", "--json", str(out2))
    assert res.code == 0, res.err
    m2 = json.loads(out2.read_text())
    assert m2["first_order"]["residence_time_s"] == pytest.approx(TAU, rel=0.05)
    assert any("first sample" in w for w in m2["warnings"])
    res = run_cli("identify", "--position", str(g), "--step-volts", "6", "--t0", "-1")
    assert res.code == 2 and "outside the record" in res.err

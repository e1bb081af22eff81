"""The static characteristic (dead-zone, gain, rails) from steps at several levels.

Ground truth: the virtual trainer's dead-zone plus Coulomb friction referred to the input
(``truth_of(config).equivalent_input_offset_v``), its linear DC gain and the amplifier rails.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from motorid.errors import OptionError
from motorid.identification.hammerstein import level_response
from motorid.identification.static import LevelPoint, fit_static_characteristic
from motorid.trainer.multilevel import multilevel_config, multilevel_experiment


def _fit(exp):
    return fit_static_characteristic([level_response(c.capture)[0] for c in exp.captures])


@pytest.mark.parametrize("seed", range(8))
def test_dead_zone_and_gain_from_five_levels_three_repeats(seed):
    # the target: dead-zone within ±0.05 V, linear gain within 1 %; the interval covers
    # the truth (the 100-run coverage figure comes from bench/multilevel_accuracy.py)
    exp = multilevel_experiment("deadzone", seed=seed)
    fit = _fit(exp)
    assert abs(fit.dead_zone_v - exp.truth.dead_zone_v) < 0.05
    assert fit.gain == pytest.approx(exp.truth.gain, rel=0.01)
    lo, hi = fit.dead_zone_ci95
    assert lo < fit.dead_zone_v < hi and hi - lo < 0.05
    assert all(p.status == "moving" for p in fit.points)


def test_the_saturated_level_is_flagged_and_left_out():
    exp = multilevel_experiment("deadzone-rails", seed=3)
    assert 8.0 < exp.truth.saturation_input_v < 10.0
    fit = _fit(exp)
    status = {round(p.step_volts): p.status for p in fit.points}
    assert status[10] == "saturated" and status[8] == "moving"
    # the input at which the law reaches the saturated output: the trainer's rails
    assert fit.saturation_input_v == pytest.approx(exp.truth.saturation_input_v, abs=0.15)
    assert any("saturation" in w for w in fit.warnings)
    # the line is fitted without it, so the gain is still the linear one
    assert fit.gain == pytest.approx(exp.truth.gain, rel=0.01)


def test_a_level_inside_the_dead_zone_is_still():
    exp = multilevel_experiment("deadzone", levels=(0.3, 2.0, 5.0, 8.0), repeats=1, seed=1)
    fit = _fit(exp)
    still = [p for p in fit.points if p.status == "still"]
    assert len(still) == 1 and abs(still[0].step_volts - 0.3) < 0.02
    assert abs(fit.dead_zone_v - exp.truth.dead_zone_v) < 0.05


def test_negative_steps_get_their_own_threshold():
    exp = multilevel_experiment("deadzone", levels=(-8.0, -4.0, -2.0, 2.0, 4.0, 8.0), repeats=1, seed=2)
    fit = _fit(exp)
    assert fit.negative is not None
    assert abs(fit.negative.dead_zone_v - exp.truth.dead_zone_v) < 0.05
    assert fit.negative.gain == pytest.approx(exp.truth.gain, rel=0.01)
    assert fit.predict(-4.0) == pytest.approx(-fit.negative.gain * (4.0 - fit.negative.dead_zone_v))


def test_levels_of_different_record_lengths_and_intervals_work():
    a = multilevel_experiment("deadzone", levels=(2.0, 6.0), repeats=1, seed=4, sec_per_div=0.5)
    b = multilevel_experiment("deadzone", levels=(4.0, 9.0), repeats=1, seed=5, sec_per_div=1.0)
    intervals = {c.capture.time_s[1] - c.capture.time_s[0] for c in (*a.captures, *b.captures)}
    assert len({round(x, 6) for x in intervals}) == 2
    fit = fit_static_characteristic([level_response(c.capture)[0] for c in (*a.captures, *b.captures)])
    assert abs(fit.dead_zone_v - a.truth.dead_zone_v) < 0.05


def test_one_moving_level_is_refused_with_the_reason():
    exp = multilevel_experiment("deadzone", levels=(5.0,), repeats=2, seed=0)
    with pytest.raises(OptionError, match="at least two step levels that move"):
        _fit(exp)


def test_fieller_interval_against_a_direct_monte_carlo():
    # independent check of the interval: draw synthetic points from a known line with the
    # stated errors; the 95 % interval of u0 must cover the truth ~95 % of the time
    rng = np.random.default_rng(0)
    k, u0 = 0.9, 0.5
    levels = np.repeat([1.0, 2.0, 4.0, 6.0, 8.0], 3)
    hits = 0
    n = 400
    for _ in range(n):
        se = 0.004 + 0.001 * levels
        y = k * (levels - u0) + rng.normal(0, se)
        pts = [LevelPoint(float(u), float(v), float(s), 0.001, True, f"p{i}") for i, (u, v, s) in
               enumerate(zip(levels, y, se, strict=True))]
        lo, hi = fit_static_characteristic(pts).dead_zone_ci95
        hits += lo <= u0 <= hi
    assert 0.92 <= hits / n <= 0.98


def test_a_motor_without_friction_has_no_dead_zone():
    cfg = replace(multilevel_config("deadzone"), amp_dead_zone_v=0.0, coulomb_nm=0.0, static_nm=0.0)
    exp = multilevel_experiment(config=cfg, levels=(2.0, 5.0, 8.0), repeats=2, seed=6)
    fit = _fit(exp)
    assert fit.dead_zone_v < 0.03
    assert fit.dead_zone_ci95[0] < 0.0 < fit.dead_zone_ci95[1] or fit.dead_zone_v < 0.01


def test_steps_that_do_not_start_from_rest_use_absolute_levels():
    # a rig stepping 2 V → 4…10 V: the motor already turns before the step, so the increments
    # alone would put the dead-zone near 0; the absolute levels give it back
    exp = multilevel_experiment("deadzone", levels=(4.0, 6.0, 8.0, 10.0), repeats=2, seed=3, start_volts=2.0)
    points = [level_response(c.capture)[0] for c in exp.captures]
    assert sorted({round(p.step_volts) for p in points}) == [4, 6, 8, 10]
    fit = fit_static_characteristic(points)
    assert abs(fit.dead_zone_v - exp.truth.dead_zone_v) < 0.05
    assert fit.gain == pytest.approx(exp.truth.gain, rel=0.01)


def _rpm_log(path, level, rng, unit="rpm"):
    t = np.arange(-0.5, 3.0, 0.01)
    u = np.where(t >= 0, level, 0.0)
    y = np.where(t >= 0, 240.0 * (level - 0.5) * (1 - np.exp(-np.clip(t, 0, None) / 0.3)), 0.0)
    y = y + rng.normal(0, 2.0, t.size)
    np.savetxt(path, np.column_stack([t, u, y]), delimiter=",", header=f"time_s,motor_voltage_V,speed_{unit}",
               comments="")
    return path


def test_levels_logged_in_rpm_give_the_gain_in_rpm_per_volt(tmp_path, run_cli):
    rng = np.random.default_rng(0)
    logs = [_rpm_log(tmp_path / f"l{v}.csv", v, rng) for v in (2.0, 4.0, 6.0)]
    m = tmp_path / "m.json"
    res = run_cli("identify", *[a for f in logs for a in ("--velocity", f)], "--json", m)
    assert res.code == 0, res.err
    assert "static gain K = 240" in res.out and "rpm/V" in res.out
    doc = __import__("json").loads(m.read_text())
    assert doc["dc_gain_unit"] == "rpm/V"
    assert doc["static_nonlinearity"]["dead_zone"]["value"] == pytest.approx(0.5, abs=0.05)
    mixed = _rpm_log(tmp_path / "rad.csv", 3.0, rng, unit="rads")
    res = run_cli("identify", "--velocity", logs[0], "--velocity", mixed)
    assert res.code == 2 and "different units" in res.err and res.err.count("\n") == 1

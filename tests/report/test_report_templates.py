"""The templates, the figures'
style and the sentence that explains an estimate that misses the truth.  No demo run: fast."""

from __future__ import annotations

import math
from types import SimpleNamespace

import matplotlib
import numpy as np
import pytest
from markupsafe import Markup
from matplotlib.lines import Line2D
from matplotlib.text import Text

from motorid.model.uncertainty import Uncertainty
from motorid.report import SECTIONS, figures
from motorid.report import html as page
from motorid.report.truth import CLASSIC_LABEL, TRUTH_LABEL, reference_values, truth_checks


@pytest.fixture
def drawn(monkeypatch):
    """Every Figure a figure function renders, kept for inspection (the PNG is still made)."""
    kept = []
    real_png = figures.png

    def keep(fig):
        kept.append(fig)
        return real_png(fig)

    monkeypatch.setattr(figures, "png", keep)
    return kept


def _texts(fig):
    """Every visible, non-empty text of a figure (titles, labels, ticks, legends, annotations)."""
    fig.canvas.draw()  # tick labels exist only once drawn
    return [t for t in fig.findobj(Text) if t.get_visible() and t.get_text().strip()]


def _fake_model(*, value=1.0, std=0.01, noise=None, delay=0.0):
    u = {"dc_gain": {"value": value, "std": std, "ci95": [value - 1.96 * std, value + 1.96 * std]},
         "time_constant": {"value": 0.5, "std": 0.002, "ci95": [0.5 - 1.96 * 0.002, 0.5 + 1.96 * 0.002]},
         "t63_s": {"value": 0.5, "std": 0.002, "ci95": [0.5 - 1.96 * 0.002, 0.5 + 1.96 * 0.002]}}
    return SimpleNamespace(method="oe", uncertainty=Uncertainty.from_dict(u), extras={"noise": noise or {}}, delay_s=delay)


# --------------------------------------------------------------------------- page structure


def test_every_section_has_a_builder_and_a_template_in_page_order():
    assert tuple(sid for sid, _, _ in page.SECTION_BUILDERS) == SECTIONS
    env = page.template_environment()
    for sid in SECTIONS:
        env.get_template(f"sections/{sid}.html")  # raises TemplateNotFound if missing
    assert env.autoescape is True or env.autoescape(f"sections/{SECTIONS[0]}.html")


def test_page_escapes_what_it_is_given():
    hostile = "<script>alert(1)</script>"
    body = page.render_section("captures", hostile, lambda: {"png": ""})
    html = page.render_page("report.html", hostile, [body], has_reference=False, reference_label="")
    assert "<script" not in html.lower()
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in html
    assert '<section id="captures">' in html and "no raw captures given" in html
    assert 'id="guide"' in html and "How to read this page" in html
    assert "@page{size:A4" in html.replace(" ", "")


def test_a_section_that_fails_says_why_escaped():
    def broken():
        raise ValueError("bad <b>thing</b>")

    sec = page.render_section("fit", "Fit", broken)
    assert isinstance(sec.body, Markup)
    assert "not available: bad &lt;b&gt;thing&lt;/b&gt;" in sec.body


@pytest.mark.parametrize(("x", "text"), [
    (0.90463751983, "0.9046"), (1234567.0, "1.235e+06"), (np.float64(-2.3113984), "-2.311"),
    (complex(-2.8, 1.15), "-2.800 + 1.150j"), (complex(-2.8, 0.0), "-2.8"), (3, "3"), (None, ""),
])
def test_numbers_on_the_page_have_four_significant_figures(x, text):
    assert page._cell(x) == text


def test_metric_names_are_words_with_units():
    rows = page._metric_rows({"settling_time_s": 1.5244, "overshoot_pct": 2.7684, "peak_control_v": float("nan")})
    assert rows == [["settling time (2 %)", "1.524 s"], ["overshoot", "2.768 %"], ["peak |u|", "—"]]


def test_closed_loop_poles_print_a_conjugate_pair_once():
    assert page._value_text([[-21.0, 0.0], [-3.5, 3.5707], [-3.5, -3.5707]]) == "-21, -3.500 ± 3.571j"
    assert page._value_text([1.80416812, -5.70634635]) == "[1.804, -5.706]"


# -------------------------------------------------------------------------- truth checks


def test_truth_inside_the_interval_is_said_so_with_its_distance():
    model = _fake_model(value=1.0, std=0.01)
    checks = truth_checks(model, {"dc_gain": 1.012, "time_constant": 0.5}, TRUTH_LABEL)
    gain = checks[0]
    assert gain.inside and math.isclose(gain.z, 1.2, rel_tol=1e-9)
    assert "inside the 95 % interval" in gain.sentence and "1.2 standard errors" in gain.sentence


def test_a_miss_explained_by_the_trainers_input_offset():
    """Friction as an input offset: output/step is low by offset/step; corrected, the estimate is
    within the noise of the truth.  Independent arithmetic of the same correction."""
    truth_gain, offset, step = 0.92055, 0.1, 5.92
    measured = truth_gain * (1 - offset / step) - 0.0003  # biased by the offset, plus a little noise
    std = 0.00022
    model = _fake_model(value=measured, std=std, noise={"position": {"use": "scale only"}})
    truth = {"transfer_functions": {"first_order": {"dc_gain": truth_gain, "time_constant": 0.5},
                                    "equivalent_input_offset_v": offset}}
    values, label = reference_values(model, truth)
    assert label == TRUTH_LABEL
    gain = truth_checks(model, values, label, truth=truth, step_volts=step)[0]
    z = (truth_gain - measured) / std
    assert not gain.inside and gain.z == pytest.approx(z)
    assert f"{abs(z):.3g} standard errors above" in gain.sentence
    corrected = measured / (1 - offset / step)
    assert f"corrected for it the estimate is {corrected:.4g}" in gain.sentence
    z_corr = (truth_gain - corrected) / (std / (1 - offset / step))
    assert abs(z_corr) < 1.96 and f"{abs(z_corr):.2g} standard errors from the truth" in gain.sentence
    assert "8-bit" not in gain.sentence and "linearised plant" not in gain.sentence  # the offset alone explains it


def test_a_miss_with_an_undithered_8_bit_channel_names_the_quantisation():
    model = _fake_model(value=1.0, std=0.01, noise={"position": {"use": "scale only"}, "velocity": {"use": "dynamics"}})
    gain = truth_checks(model, {"dc_gain": 1.05, "time_constant": 0.5}, TRUTH_LABEL)[0]
    assert not gain.inside and "5 standard errors above" in gain.sentence
    assert "8-bit codes of the position channel are not dithered" in gain.sentence
    assert "The truth is the linearised plant" in gain.sentence  # a second cause starts its own sentence


def test_without_truth_the_classic_estimate_is_the_reference():
    classic = SimpleNamespace(first_order=lambda: SimpleNamespace(dc_gain=0.97, time_constant_s=0.51))
    model = _fake_model(value=1.0, std=0.01)
    values, label = reference_values(model, None, classic)
    assert label == CLASSIC_LABEL and values == {"dc_gain": 0.97, "t63_s": 0.51}
    gain, t63 = truth_checks(model, values, label)  # the classic 63 % read-off against the model's 63 % time
    assert t63.quantity == "63 % time"
    tau = t63
    assert not gain.inside and "3 standard errors below" in gain.sentence and "classic estimate reads" in gain.sentence
    assert tau.z == pytest.approx((0.51 - 0.5) / 0.002)
    # the classic model compared with itself is no check
    assert reference_values(SimpleNamespace(method="classic"), None, classic) is None


# ------------------------------------------------------------------------------- figures


def _check_style(fig):
    """Full width; every text at least FONT_PT."""
    assert fig.get_figwidth() == pytest.approx(figures.FULL_WIDTH_IN)
    small = [(t.get_text(), t.get_fontsize()) for t in _texts(fig) if t.get_fontsize() < figures.FONT_PT]
    assert not small, small


def test_the_validation_overlay_gives_an_rpm_output_and_a_volts_input_their_own_axes(drawn):
    """The overlay drew a log's rpm and its volts on one axis labelled "V"."""
    t = np.linspace(0, 2, 200)
    figures.validation_overlay(t, np.sin(t), 800 * np.sin(t), 790 * np.sin(t), "sine", "rpm", "V")
    labels = sorted(ax.get_ylabel() for ax in drawn[0].axes)
    assert labels == ["input (V)", "output (rpm)"]
    figures.validation_overlay(t, np.sin(t), np.sin(t), 0.9 * np.sin(t), "sine")
    assert [ax.get_ylabel() for ax in drawn[1].axes] == ["V"]

def test_figures_are_full_width_with_fonts_of_at_least_11_pt(drawn):
    before = dict(matplotlib.rcParams)
    t = np.linspace(0, 2, 200)
    figures.validation_overlay(t, np.sin(t), np.sin(t), 0.9 * np.sin(t), "sine: NRMSE 1 %")
    figures.hankel_values([1, 0.1, 0.001], [1, 0.2, 0.002], 0.01)
    figures.sweep_maps([1.9, 2.4], [0.04, 0.08], np.array([[2.1, 2.2], [2.3, 2.4]]), np.array([[0.4, 0.41], [0.42, 0.43]]))
    figures.closed_loop(t, {"reference": np.ones_like(t), "output": 1 - np.exp(-t), "u (control)": np.exp(-t)},
                        "closed loop", rails_v=10.0, disturbances_s=[1.0], metrics=["overshoot: 0 %"])
    figures.interval_checks([figures.IntervalCheck("dc gain (V/V)", 1.0, (0.98, 1.02), 1.05, "truth")])
    assert len(drawn) == 5
    for fig in drawn:
        _check_style(fig)
    assert dict(matplotlib.rcParams) == before  # the style is per figure, never global


def test_closed_loop_draws_the_rails_the_load_instant_and_the_metrics(drawn):
    t = np.linspace(0, 3, 300)
    figures.closed_loop(t, {"reference": np.ones_like(t), "output": 1 - np.exp(-3 * t), "u (control)": np.exp(-t)},
                        "closed loop", rails_v=7.5, disturbances_s=[1.5], metrics=["settling time (2 %): 1.3 s"])
    fig = drawn[0]
    top, bottom = fig.axes[:2]
    flat = {tuple(np.round(np.asarray(ln.get_ydata(), float), 9)) for ln in bottom.get_lines()}
    assert (7.5, 7.5) in flat and (-7.5, -7.5) in flat  # the rails, on the control panel
    for ax in (top, bottom):
        xs = [tuple(np.asarray(ln.get_xdata(), float)) for ln in ax.get_lines()]
        assert (1.5, 1.5) in xs  # the load instant, on both panels
    assert "settling time (2 %): 1.3 s" in top.get_title(loc="left")


def test_mode_maps_have_gain_units_and_mark_the_design(drawn):
    from motorid.simulation.modes import ModeMap

    kp, kv = np.linspace(1, 20, 4), np.linspace(0, 4, 3)
    labels = np.arange(12, dtype=np.int8).reshape(3, 4) % 6
    maps = (ModeMap("2nd order", kp, kv, labels, 1e-3, 10), ModeMap("3rd order", kp, kv, labels, 1e-3, 10))
    figures.mode_maps(maps, design_gains=(12.0, 2.5))
    fig = drawn[0]
    _check_style(fig)
    for ax in fig.axes[:2]:
        assert ax.get_xlabel() == "Kp (V/V)" and ax.get_ylabel() == "Kv (V/(V/s))"
        stars = [ln for ln in ax.get_lines() if isinstance(ln, Line2D) and ln.get_marker() == "*"]
        assert [(float(s.get_xdata()[0]), float(s.get_ydata()[0])) for s in stars] == [(12.0, 2.5)]


def test_a_long_capture_path_wraps_instead_of_squeezing_the_axes(drawn, recwarn):
    """A web upload's capture lives in a long temporary path: the title wraps, the axes keep
    their size (matplotlib warns 'constrained_layout not applied' when a title is too wide)."""
    t = np.linspace(-0.5, 2, 200)
    source = "/tmp/" + "/".join(["motorid-upload-0123456789abcdef"] * 8) + "/ALL0001"
    # raw_captures reads only these fields of a Capture
    cap = SimpleNamespace(time_s=t, output_v=np.tanh(np.clip(t, 0, None)), input_v=np.where(t > 0, 5.0, 0.0),
                          source=source)
    figures.raw_captures({"velocity": cap})
    assert not [w for w in recwarn if "constrained_layout" in str(w.message)]
    ax = drawn[0].axes[0]
    assert ax.get_position().width > 0.7  # the panel keeps most of the figure's width
    assert ax.get_title(loc="left").replace("\n", "") == f"velocity: {source}"

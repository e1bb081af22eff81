"""Curves drawn with at most two points per pixel column keep every extreme."""

from __future__ import annotations

import numpy as np

from motorid.report.figures import MAX_DRAWN_POINTS, thinned


def test_thinned_curve_keeps_its_extremes_ends_and_order():
    t = np.linspace(0.0, 3.0, 3001)
    rng = np.random.default_rng(0)
    # a bang-bang control effort: rails, fast switching, one-sample spikes
    y = np.where(np.sin(40 * t) > 0, 10.0, -10.0) + rng.normal(0, 0.1, t.size)
    y[[17, 1234, 2999]] = [25.0, -30.0, 12.0]
    tt, yy = thinned(t, y)
    assert tt.size <= MAX_DRAWN_POINTS + 10
    assert np.all(np.diff(tt) > 0)
    assert tt[0] == t[0] and tt[-1] == t[-1]
    assert yy.max() == y.max() and yy.min() == y.min()
    # every bucket's range is drawn: the envelope of the thinned curve equals the data's
    k = int(np.ceil(t.size / (MAX_DRAWN_POINTS // 2)))
    for start in range(0, t.size - k, k):
        inside = (tt >= t[start]) & (tt <= t[start + k - 1])
        assert yy[inside].max() == y[start:start + k].max()
        assert yy[inside].min() == y[start:start + k].min()


def test_short_curves_are_drawn_whole():
    t = np.arange(100.0)
    tt, yy = thinned(t, t**2)
    assert tt is t and np.array_equal(yy, t**2)


def test_closed_loop_canvas_redraws_in_place_and_keeps_a_figure_per_set_of_curves():
    from motorid.report.figures import ClosedLoopCanvas

    t = np.linspace(0.0, 3.0, 3001)
    names = ("reference", "output (velocity)", "u (control)")
    canvas = ClosedLoopCanvas()
    first = canvas.svg(t, {"reference": np.ones_like(t), "output (velocity)": 1 - np.exp(-t), "u (control)": np.exp(-t)},
                       "closed loop: ζ = 1")
    fig, axes, _ = canvas._figures[(*names, "V", "V")]
    second = canvas.svg(t, {"reference": 2 * np.ones_like(t), "output (velocity)": 2 * (1 - np.exp(-3 * t)),
                            "u (control)": 8 * np.exp(-3 * t)}, "closed loop: ζ = 0.7, and a title long enough to wrap "
                           "onto a second line of the heading")
    assert canvas._figures[(*names, "V", "V")][0] is fig  # same curves: the figure is reused
    assert first.startswith(b"<?xml") and second.startswith(b"<?xml") and first != second
    assert "ζ = 0.7" in axes[0].get_title(loc="left")
    # text is SVG text (the browser's fonts), not glyph outlines
    assert "ζ = 0.7" in second.decode() and "<text" in second.decode()
    # the axes follow the new data: the control axis now reaches 8
    assert axes[1].get_ylim()[1] >= 8.0
    canvas.svg(t, {"reference": np.ones_like(t), "output (position)": t}, "other curves")
    assert canvas._figures[("reference", "output (position)", "V", "V")][0] is not fig
    # the first set of curves comes back to its own figure, not a new one
    canvas.svg(t, {"reference": np.ones_like(t), "output (velocity)": t, "u (control)": t}, "back")
    assert canvas._figures[(*names, "V", "V")][0] is fig
    # the data's units on the axes: another figure, labelled rpm and pwm (never a V for them)
    canvas.svg(t, {"reference": np.ones_like(t), "output (velocity)": t, "u (control)": t}, "rpm",
               output_unit="rpm", input_unit="pwm")
    _, rpm_axes, _ = canvas._figures[(*names, "rpm", "pwm")]
    assert rpm_axes[0].get_ylabel() == "rpm" and rpm_axes[1].get_ylabel() == "control u (pwm)"
    assert axes[0].get_ylabel() == "V"
    for i in range(ClosedLoopCanvas.KEPT + 2):  # never more than KEPT figures
        canvas.svg(t, {f"curve {i}": t}, "many")
    assert len(canvas._figures) == ClosedLoopCanvas.KEPT

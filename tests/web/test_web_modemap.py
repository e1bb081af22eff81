"""The design marker on the six-mode maps — the gains it stands for, and where it
lands in the library's SVG, checked against matplotlib's own data transform."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.figure import Figure

import motorid as mi
from motorid.control.feedback import poles_from_damping
from motorid.simulation.modes import MODES, servo_plants
from motorid.web.modemap import build_mode_maps, design_point, mark


@pytest.fixture(scope="module")
def models(demo_run):
    d = demo_run.folder
    two = mi.identify(mi.read_experiment(position=d / "ALL0000", velocity=d / "ALL0001"), method="pinv", order=2)
    return two.model, demo_run.result.identification.model


def test_a_position_velocity_design_is_the_maps_loop_itself(models):
    two, _ = models
    des = mi.design(two, damping=0.7, wn=5.0, robust_samples=0)
    # kr = k1 when position integrates velocity; pinv's free θ row does so to within 0.1 %
    assert tuple(des.states) == ("position", "velocity") and des.kr == pytest.approx(des.K[0], rel=1e-3)
    kp, kv, what = design_point(two, des, 0.7, 5.0)
    assert (kp, kv) == (des.K[0], des.K[1]) and "own gains" in what


def test_other_designs_are_marked_by_the_same_poles_on_the_2nd_order_loop(models):
    _, four = models
    des = mi.design(four, damping=0.6, wn=7.0, integral=True, robust_samples=0)
    kp, kv, what = design_point(four, des, 0.6, 7.0)
    second = servo_plants(four)[0]
    # independent check: the 2nd-order loop with these gains has the poles of ζ, ωn
    loop = second.A - second.B @ np.array([[kp, kv]])
    want, _ = poles_from_damping(0.6, 7.0, 2)
    np.testing.assert_allclose(np.sort_complex(np.linalg.eigvals(loop)), np.sort_complex(want), rtol=1e-9)
    assert "integrator" in what


def test_marker_lands_where_matplotlib_draws_the_gains(models, tmp_path, monkeypatch):
    _, four = models
    figures: list[Figure] = []
    original = Figure.savefig

    def keep(self, *args, **kwargs):
        figures.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    view = build_mode_maps(four, tmp_path, step_v=5.0, saturation_v=10.0, kp_max=40.0, kv_max=6.0, points=12)
    assert len(view.panels) == 2 and (tmp_path / "modes.svg").is_file()
    fig = figures[0]
    height_pt = fig.get_size_inches()[1] * 72  # SVG units are points; y grows downwards
    for kp, kv in ((0.0, 0.0), (40.0, 6.0), (13.0, 2.5), (55.0, -1.0)):
        for ax, marker in zip(fig.axes[: len(view.maps)], mark(view, kp, kv), strict=True):
            x_px, y_px = ax.transData.transform((np.clip(kp, 0, 40), np.clip(kv, 0, 6)))
            assert marker.x == pytest.approx(x_px * 72 / fig.dpi, abs=0.5)
            assert marker.y == pytest.approx(height_pt - y_px * 72 / fig.dpi, abs=0.5)
            assert marker.inside == (0 <= kp <= 40 and 0 <= kv <= 6)
    # the mode under the marker is the map's label at the nearest grid point
    m = view.maps[0]
    j, i = int(np.argmin(np.abs(m.kp - 13.0))), int(np.argmin(np.abs(m.kv - 2.5)))
    assert mark(view, 13.0, 2.5)[0].mode == MODES[m.labels[i, j]]

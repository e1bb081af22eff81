"""The six-mode map of the design panel, with the design's (Kp, Kv) marked as the sliders move.

The maps are drawn once per model and actuator limit by the library's own
:func:`motorid.simulation.modes.plot_mode_maps` (as SVG).

The marker is placed in the SVG's own coordinates: each map is an ``<image>`` element whose
rectangle is the map's extent, so a gain pair maps linearly onto it.  Redrawing the maps for
every slider step would cost far more than the 200 ms an update may take.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from motorid.control.design import Design
from motorid.control.feedback import place_gains, poles_from_damping
from motorid.model import MotorModel
from motorid.simulation.modes import MODES, ModeCriteria, ModeMap, mode_map, plot_mode_maps, servo_plants

__all__ = ["MapPanel", "Marker", "ModeMapView", "build_mode_maps", "design_point", "mark"]

_SVG = "{http://www.w3.org/2000/svg}"
_FLIP = re.compile(r"scale\(1 -1\)\s*translate\(0 (-?[\d.]+)\)")


@dataclass(frozen=True, slots=True)
class MapPanel:
    """Where one map is drawn in the SVG (its own units) and the gains it spans."""

    name: str
    x: float
    y_top: float
    width: float
    height: float
    kp: tuple[float, float]
    kv: tuple[float, float]


@dataclass(frozen=True, slots=True)
class ModeMapView:
    """Drawn maps and their geometry.

    Attributes
    ----------
    svg : bytes
        The maps as :func:`~motorid.simulation.modes.plot_mode_maps` draws them.
    viewbox : tuple of float
        ``(width, height)`` of the SVG's view box.
    panels : tuple of MapPanel
        One per map (empty when the SVG's layout was not recognised: no markers then).
    maps : tuple of ModeMap
        The classified grids (the marker's mode is read off them).
    """

    svg: bytes
    viewbox: tuple[float, float]
    panels: tuple[MapPanel, ...]
    maps: tuple[ModeMap, ...]


@dataclass(frozen=True, slots=True)
class Marker:
    """A design point on one map."""

    plant: str
    x: float
    y: float
    inside: bool
    mode: str


def _panels(svg_path: Path, maps: tuple[ModeMap, ...]) -> tuple[tuple[float, float], tuple[MapPanel, ...]]:
    root = ET.parse(svg_path).getroot()
    box = [float(v) for v in root.get("viewBox", "0 0 1 1").split()]
    images = list(root.iter(f"{_SVG}image"))
    if len(images) != len(maps):
        return (box[2], box[3]), ()
    panels = []
    for img, m in zip(images, maps, strict=True):
        x, y = float(img.get("x", 0)), float(img.get("y", 0))
        w, h = float(img.get("width", 0)), float(img.get("height", 0))
        tf = (img.get("transform") or "").strip()
        flip = _FLIP.fullmatch(tf)
        if flip:  # matplotlib draws images upside down and flips them back
            top = -float(flip.group(1)) - (y + h)
        elif not tf:
            top = y
        else:
            return (box[2], box[3]), ()
        panels.append(MapPanel(m.plant, x, top, w, h, (float(m.kp[0]), float(m.kp[-1])),
                               (float(m.kv[0]), float(m.kv[-1]))))
    return (box[2], box[3]), tuple(panels)


def build_mode_maps(model: MotorModel, folder: Path, *, step_v: float, saturation_v: float, kp_max: float,
                    kv_max: float, points: int = 40) -> ModeMapView:
    """Classify and draw the 2nd- and 3rd-order maps over ``[0, kp_max] × [0, kv_max]``.

    Parameters
    ----------
    model : MotorModel
        The identified model.
    folder : Path
        The tab's folder (the SVG is written there, then read back).
    step_v, saturation_v : float
        Reference step and actuator rails [V] of the mapped loop.
    kp_max, kv_max : float
        Upper ends of the gain axes.
    points : int
        Grid points per axis.

    Returns
    -------
    ModeMapView
        The SVG and where each map sits in it.

    Raises
    ------
    OptionError
        A model the map cannot be drawn for, or bad limits (from the library).
    """
    criteria = ModeCriteria(step_v=step_v, saturation_v=saturation_v)
    kp = np.linspace(0.0, kp_max, points)
    kv = np.linspace(0.0, kv_max, points)
    maps = tuple(mode_map(pl, kp, kv, criteria) for pl in servo_plants(model))
    path = folder / "modes.svg"
    plot_mode_maps(maps, path)
    box, panels = _panels(path, maps)
    return ModeMapView(path.read_bytes(), box, panels, maps)


def design_point(model: MotorModel, design: Design, damping: float, wn: float) -> tuple[float, float, str]:
    """The (Kp, Kv) of the map's loop ``u = sat(Kp (r − θ) − Kv v)`` that the design stands for.

    A design on (position, velocity) without integral action is that loop (``kr = k1`` when the
    position integrates the velocity): its own gains.  Otherwise the map shows the gains that
    place the chosen ζ, ωn on the map's 2nd-order loop.

    Parameters
    ----------
    model : MotorModel
        The identified model.
    design : Design
        The current design.
    damping, wn : float
        The sliders' ζ and ωn [rad/s].

    Returns
    -------
    (float, float, str)
        Kp, Kv and a sentence saying which of the two it is.
    """
    if tuple(design.states) == ("position", "velocity") and design.ki is None:
        return float(design.K[0]), float(design.K[1]), "the design's own gains (k_position, k_velocity)"
    second = servo_plants(model)[0]
    poles, _ = poles_from_damping(damping, wn, 2)
    k = place_gains(second.A, second.B, poles).ravel()
    extra = " and an integrator" if design.ki is not None else ""
    return float(k[0]), float(k[1]), (f"the design has {len(design.K)} gains{extra}: marked are the (Kp, Kv) "
                                       "that give the same ζ, ωn on the map's 2nd-order loop")


def mark(view: ModeMapView, kp: float, kv: float) -> list[Marker]:
    """Place ``(kp, kv)`` on every map and read off its mode.

    Parameters
    ----------
    view : ModeMapView
        The drawn maps.
    kp, kv : float
        The gains.

    Returns
    -------
    list of Marker
        One per map (none when the layout is unknown); a point outside the grid is drawn on
        its edge with ``inside=False`` and the mode of the nearest grid point.
    """
    out = []
    for panel, m in zip(view.panels, view.maps, strict=False):
        (p0, p1), (v0, v1) = panel.kp, panel.kv
        inside = math.isfinite(kp) and math.isfinite(kv) and p0 <= kp <= p1 and v0 <= kv <= v1
        fx = 0.0 if p1 == p0 else float(np.clip((kp - p0) / (p1 - p0), 0.0, 1.0))
        fy = 0.0 if v1 == v0 else float(np.clip((kv - v0) / (v1 - v0), 0.0, 1.0))
        j = int(np.argmin(np.abs(m.kp - kp))) if math.isfinite(kp) else 0
        i = int(np.argmin(np.abs(m.kv - kv))) if math.isfinite(kv) else 0
        out.append(Marker(m.plant, panel.x + fx * panel.width, panel.y_top + (1.0 - fy) * panel.height, inside,
                          MODES[int(m.labels[i, j])]))
    return out

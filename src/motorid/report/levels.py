"""The page of a multi-level identification.

The static characteristic with its interval band, the per-level responses normalised and
overlaid, and the Hammerstein model.
"""

from __future__ import annotations

import functools
from typing import Any

import matplotlib
import numpy as np

from motorid.identification.hammerstein import MultiLevelResult
from motorid.model.notation import poly_text
from motorid.model.units import channel_unit
from motorid.report import figures
from motorid.report.html import render_page, render_section

__all__ = ["build_levels_report", "normalised_responses_png", "static_characteristic_png"]

#: Colours of the level statuses in the static-characteristic plot.
STATUS_STYLE = {"moving": ("o", "C0"), "still": ("s", "0.5"), "saturated": ("^", "C3")}


@figures.styled
def static_characteristic_png(result: MultiLevelResult) -> bytes:
    """Steady output against step level: the points by status, the fitted law and its 95 % band.

    Parameters
    ----------
    result : MultiLevelResult
        The multi-level identification.

    Returns
    -------
    bytes
        PNG image.
    """
    st = result.static
    fig, ax = figures._subplots(figsize=(figures.FULL_WIDTH_IN, 4.4))
    u = np.array([p.step_volts for p in st.points])
    span = np.linspace(min(0.0, u.min()) * 1.05, max(0.0, u.max()) * 1.05, 300)
    law = st.predict(span)
    ax.plot(span, law, "k-", lw=1.2,
            label=f"K·(u − u₀): K = {st.gain:.4g}, u₀ = {st.dead_zone_v:.3g} {result.model.input_unit}")
    # the band: the law at the ends of the gain and dead-zone intervals (the extremes of the box)
    lo_dz, hi_dz = st.dead_zone_ci95
    lo_k, hi_k = st.gain_ci95
    if np.isfinite(lo_dz) and np.isfinite(hi_dz):
        corners = [k * np.clip(span - d, 0.0, None) for k in (lo_k, hi_k) for d in (max(lo_dz, 0.0), hi_dz)]
        pos = span >= 0
        ax.fill_between(span[pos], np.min(corners, axis=0)[pos], np.max(corners, axis=0)[pos], color="0.8",
                        label="95 % interval")
    for status, (marker, colour) in STATUS_STYLE.items():
        pts = [p for p in st.points if p.status == status]
        if pts:
            ax.errorbar([p.step_volts for p in pts], [p.steady_state for p in pts],
                        yerr=[1.96 * p.stderr for p in pts], fmt=marker, color=colour, label=f"{status} level")
    ax.axvline(st.dead_zone_v, color="0.4", ls=":", lw=1)
    ax.set_xlabel(f"step level u ({result.model.input_unit})")
    ax.set_ylabel(f"steady output y_ss ({channel_unit(result.model.units, 'velocity')})")
    ax.legend(loc="best")
    ax.grid(alpha=0.3)
    return figures.png(fig)


@figures.styled
def normalised_responses_png(result: MultiLevelResult) -> bytes:
    """Every moving level's response divided by its steady state, overlaid (shared dynamics?).

    Parameters
    ----------
    result : MultiLevelResult
        The multi-level identification.

    Returns
    -------
    bytes
        PNG image.
    """
    fig, ax = figures._subplots(figsize=(figures.FULL_WIDTH_IN, 4.4))
    levels = sorted({round(p.step_volts, 2) for p, _ in result.responses})
    cmap = matplotlib.colormaps["viridis"]
    for point, resp in result.responses:
        if point.status == "still" or point.steady_state == 0:
            continue
        i = levels.index(round(point.step_volts, 2))
        colour = cmap(i / max(len(levels) - 1, 1))
        ls = "--" if point.status == "saturated" else "-"
        ax.plot(resp.time_s, resp.output_v / point.steady_state, ls, color=colour, lw=1,
                label=f"{point.step_volts:.3g} {result.model.input_unit} ({point.status})")
    handles, labels = ax.get_legend_handles_labels()
    seen: dict[str, object] = {}
    for h, lab in zip(handles, labels, strict=True):
        seen.setdefault(lab, h)
    ax.legend(list(seen.values()), list(seen), loc="best", ncol=2)
    ax.axhline(1 - np.exp(-1), color="0.5", lw=0.8, ls=":")
    ax.set_xlabel("time from the step (s)")
    ax.set_ylabel("y / y_ss")
    ax.grid(alpha=0.3)
    return figures.png(fig)



def static_section(result: MultiLevelResult) -> dict[str, Any]:
    """The dead-zone, the static gain and the saturation, with the characteristic's plot.

    Parameters
    ----------
    result : MultiLevelResult
        The multi-level identification.

    Returns
    -------
    dict
        The names ``levels/static.html`` shows.
    """
    st = result.static
    fo = result.model.first_order()
    unit, u_unit = result.model.dc_gain_unit, result.model.input_unit
    rows = [["dead-zone u₀ (input-referred)", f"{st.dead_zone_v:.4g} {u_unit}",
             f"[{st.dead_zone_ci95[0]:.4g}, {st.dead_zone_ci95[1]:.4g}] {u_unit}"],
            ["static gain K", f"{st.gain:.4g} {unit}", f"[{st.gain_ci95[0]:.4g}, {st.gain_ci95[1]:.4g}] {unit}"]]
    if st.negative is not None:
        rows.append(["dead-zone for negative steps", f"{st.negative.dead_zone_v:.4g} {u_unit}",
                     f"[{st.negative.dead_zone_ci95[0]:.4g}, {st.negative.dead_zone_ci95[1]:.4g}] {u_unit}"])
    if st.saturation_input_v is not None:
        rows.append(["saturation seen from", f"{st.saturation_input_v:.4g} {u_unit}",
                     f"output ≈ {st.saturation_output_v:.4g} {channel_unit(result.model.units, 'velocity')}"])
    rows.append(["time constant (joint fit)", f"{fo.time_constant_s:.4g} s", ""])
    return {"rows": rows, "png": figures.data_uri(static_characteristic_png(result))}


def levels_section(result: MultiLevelResult) -> dict[str, Any]:
    """Every level's response normalised, and the per-level time constants.

    Parameters
    ----------
    result : MultiLevelResult
        The multi-level identification.

    Returns
    -------
    dict
        The names ``levels/levels.html`` shows.
    """
    u_unit = result.model.input_unit
    return {"png": figures.data_uri(normalised_responses_png(result)), "note": result.dynamics_note,
            "rows": [[f"{d.step_volts:.3g} {u_unit}", f"{d.time_constant_s:.4g} s", f"{d.stderr:.2g} s", d.count]
                     for d in result.dynamics]}


def hammerstein_section(result: MultiLevelResult) -> dict[str, Any]:
    """The Hammerstein model: the linear part's TF and the static nonlinearity f(u).

    Parameters
    ----------
    result : MultiLevelResult
        The multi-level identification.

    Returns
    -------
    dict
        The names ``levels/model.html`` shows.
    """
    st = result.static
    tf = result.model.velocity_tf
    clip = None if st.saturation_input_v is None else f"{st.saturation_input_v - st.dead_zone_v:.4g}"
    return {"num": poly_text(tf.num[0][0]), "den": poly_text(tf.den[0][0]), "dead_zone": f"{st.dead_zone_v:.4g}",
            "clip": clip}


def warnings_section(result: MultiLevelResult) -> dict[str, Any]:
    """The warnings of the multi-level identification.

    Parameters
    ----------
    result : MultiLevelResult
        The multi-level identification.

    Returns
    -------
    dict
        The names ``levels/warnings.html`` shows.
    """
    return {"warnings": list(result.warnings)}


def build_levels_report(result: MultiLevelResult, title: str = "motorid report: several step levels") -> str:
    """The self-contained HTML page of a multi-level identification.

    Parameters
    ----------
    result : MultiLevelResult
        The multi-level identification.
    title : str
        Page title.

    Returns
    -------
    str
        A complete HTML document.
    """
    parts = [
        ("static", "Static characteristic", static_section, "levels/static.html"),
        ("levels", "Per-level responses, normalised", levels_section, "levels/levels.html"),
        ("model", "Hammerstein model: y = K·G(s)·f(u)", hammerstein_section, "levels/model.html"),
    ]
    if result.warnings:
        parts.append(("warnings", "Warnings", warnings_section, "levels/warnings.html"))
    sections = [render_section(sid, heading, functools.partial(make, result), template)
                for sid, heading, make, template in parts]
    return render_page("levels.html", title, sections)

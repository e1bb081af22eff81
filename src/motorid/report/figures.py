"""The report's figures, each a function of data returning PNG bytes.

Matplotlib figures are made without pyplot, so the caller's backend is never switched, and
every figure is drawn inside its own style context (:func:`styled`): the report's fonts and
sizes never leak into the caller's ``rcParams``.

Every figure is as wide as the text of an A4 page, so that a printed figure keeps its fonts at
their point size (≥ 11 pt).  The figure numbers of Masoud 2019 that each one
corresponds to are given in the docstrings.
"""

from __future__ import annotations

import functools
import base64
import io
import textwrap
import threading
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ParamSpec, TypeVar, cast

import matplotlib
import numpy as np
from matplotlib.figure import Figure

from motorid.capture import Capture
from motorid.conditioning.denoise import fft_denoise
from motorid.conditioning.derivative import derivative
from motorid.conditioning.pipeline import ConditionedExperiment
from motorid.model import MotorModel
from motorid.model.response import recorded_step_response
from motorid.model.units import channel_unit

__all__ = [
    "DPI",
    "FONT_PT",
    "FULL_WIDTH_IN",
    "MAX_DRAWN_POINTS",
    "ClosedLoopCanvas",
    "IntervalCheck",
    "closed_loop",
    "conditioned_signals",
    "current_denoising",
    "hankel_values",
    "interval_checks",
    "mode_maps",
    "png",
    "pole_zero",
    "raw_captures",
    "step_fit",
    "styled",
    "sweep_maps",
    "thinned",
    "validation_overlay",
]

#: Resolution of the PNGs (dots per inch): sharp on paper at the figure's own size.
DPI = 120
#: Width of every figure: the text width of an A4 page (210 mm − 2 × 12 mm margins = 7.3 in), so
#: that the page shows it at its own size and a print keeps its fonts at their point size.
FULL_WIDTH_IN = 7.3
#: The smallest font of any text in a figure (points).
FONT_PT = 11
#: Height of one strip of time series (a capture, a signal).
_STRIP_IN = 2.2
#: Characters per line of a title: longer titles (a capture's path) wrap instead of squeezing the axes.
_TITLE_CHARS = 72
#: Metrics per line under a closed-loop plot's title.
_METRICS_PER_LINE = 2
#: The report's matplotlib style, applied per figure (never globally).
_STYLE: dict[str, Any] = {
    "font.size": FONT_PT,
    "axes.titlesize": FONT_PT + 1,
    "axes.labelsize": FONT_PT,
    "xtick.labelsize": FONT_PT,
    "ytick.labelsize": FONT_PT,
    "legend.fontsize": FONT_PT,
    "legend.title_fontsize": FONT_PT,
    "figure.titlesize": FONT_PT + 1,
    "legend.framealpha": 0.85,
    "lines.linewidth": 1.3,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "savefig.dpi": DPI,
}
#: Colours of the six modes of the mode map (the order of :data:`motorid.simulation.modes.MODES`).
_MODE_COLOURS = ("#d62728", "#1f77b4", "#2ca02c", "#bcbd22", "#ff7f0e", "#9467bd")

_P = ParamSpec("_P")
_R = TypeVar("_R")


def styled(func: Callable[_P, _R]) -> Callable[_P, _R]:
    """Run a figure function inside the report's style context (fonts ≥ :data:`FONT_PT`).

    Font sizes are read from ``rcParams`` when an artist is created, so the whole function,
    drawing and saving, runs inside :func:`matplotlib.rc_context`; the caller's settings are
    restored afterwards.

    Parameters
    ----------
    func : callable
        A function that draws a figure.

    Returns
    -------
    callable
        The same function, styled.
    """

    @functools.wraps(func)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _R:
        with matplotlib.rc_context(cast("Any", _STYLE)):
            return func(*args, **kwargs)

    return wrapper


def _subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], **kwargs):
    """``pyplot.subplots`` without pyplot: a :class:`~matplotlib.figure.Figure` of its own.

    No global figure manager, no backend switch — a notebook's backend is left alone.
    """
    fig = Figure(figsize=figsize, layout="constrained")
    return fig, fig.subplots(nrows, ncols, **kwargs)


def _channel_unit(info: Any) -> str:
    """The unit a channel was recorded in (``V`` for scope channels and when unknown)."""
    return str(getattr(info, "units", "") or "V")


def _wrapped(title: str) -> str:
    """A title wrapped to :data:`_TITLE_CHARS` per line (paths break anywhere)."""
    return "\n".join(textwrap.fill(line, _TITLE_CHARS) for line in title.splitlines())


def _short(x: float) -> str:
    """A number in at most five characters for a heat-map cell (``1044``, ``0.357``, ``12.3``)."""
    return f"{x:.0f}" if abs(x) >= 100 else f"{x:.3g}"


#: Most points drawn per curve: two per pixel column of a full-width figure (a 3000-sample
#: closed loop drawn whole took a third of a slider move's time, most of it the legend's search
#: for the emptiest corner).
MAX_DRAWN_POINTS = int(2 * FULL_WIDTH_IN * DPI)


def thinned(time_s: np.ndarray, y: np.ndarray, most: int = MAX_DRAWN_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """A curve with at most about ``most`` points that draws the same: each bucket's minimum and maximum.

    Parameters
    ----------
    time_s, y : ndarray
        The curve.
    most : int
        Largest number of points kept (about; the samples past the last whole bucket are kept too).

    Returns
    -------
    (ndarray, ndarray)
        The kept samples, in time order: the first and last, and every bucket's extremes, so no
        peak, rail or switching edge is lost.
    """
    n = y.size
    if n <= most or most < 4:
        return time_s, y
    k = int(np.ceil(n / (most // 2)))
    whole = n // k * k
    buckets = y[:whole].reshape(-1, k)
    start = np.arange(buckets.shape[0]) * k
    keep = np.unique(np.r_[0, start + buckets.argmin(axis=1), start + buckets.argmax(axis=1),
                           np.arange(whole, n), n - 1])
    return time_s[keep], y[keep]


def png(fig: Figure) -> bytes:
    """Render a figure to PNG bytes (the figure is not kept by any manager).

    Parameters
    ----------
    fig : Figure
        A matplotlib figure.

    Returns
    -------
    bytes
        The PNG image.
    """
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI)
    return buf.getvalue()


def data_uri(data: bytes, kind: str = "png") -> str:
    """An image as a ``data:`` URI, for a self-contained page (the report, the web page, a batch).

    Parameters
    ----------
    data : bytes
        The encoded image.
    kind : str
        ``png`` or ``svg+xml``.

    Returns
    -------
    str
        ``data:image/<kind>;base64,…``.
    """
    return f"data:image/{kind};base64,{base64.b64encode(data).decode('ascii')}"


@styled
def raw_captures(captures: Mapping[str, Capture]) -> bytes:
    """The captures as recorded, CH1 and CH2 on each file's own time axis (paper Fig. 25).

    Parameters
    ----------
    captures : Mapping[str, Capture]
        Captures keyed by role.

    Returns
    -------
    bytes
        The PNG image.
    """
    n = len(captures)
    fig, axes = _subplots(n, 1, figsize=(FULL_WIDTH_IN, _STRIP_IN * n), squeeze=False)
    for ax, (role, cap) in zip(axes[:, 0], captures.items(), strict=False):
        out_unit = _channel_unit(getattr(cap, "output_info", None))
        in_unit = _channel_unit(getattr(cap, "input_info", None))
        if cap.input_v is not None:
            ax.plot(cap.time_s, cap.input_v, lw=0.9, label=f"CH1 input ({in_unit})")
        ax.plot(cap.time_s, cap.output_v, lw=0.9, label=f"CH2 {role} ({out_unit})")
        ax.set_title(_wrapped(f"{role}: {cap.source}"), loc="left")
        ax.set_ylabel(out_unit if in_unit == out_unit or cap.input_v is None else f"{in_unit}, {out_unit}")
        ax.legend(loc="best")
    axes[-1, 0].set_xlabel("time on the file's axis (s)")
    return png(fig)


@styled
def conditioned_signals(cond: ConditionedExperiment, derivative_method: str = "five_point", *,
                        units: Mapping[str, str] | None = None) -> bytes:
    """Synchronised, unwrapped, reduced step responses and the numerical derivative (Figs. 16–17, 26).

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.
    derivative_method : str
        The numerical derivative shown (default ``five_point``).
    units : Mapping[str, str], optional
        The unit of each channel's data (``MotorModel.units``; missing: volts).

    Returns
    -------
    bytes
        The PNG image.
    """
    roles = list(cond.full_outputs)
    extra = 1 if "position" in roles else 0
    fig, axes = _subplots(len(roles) + extra, 1, figsize=(FULL_WIDTH_IN, _STRIP_IN * (len(roles) + extra)),
                          squeeze=False, sharex=True)
    for ax, role in zip(axes[:, 0], roles, strict=False):
        ax.plot(cond.full_time_s, cond.full_outputs[role], lw=0.9, label=f"{role}, synchronised")
        ax.plot(cond.time_s, cond.outputs[role], "o", ms=3, label=f"reduced ×{cond.ratio}")
        ax.set_ylabel(f"{role} ({channel_unit(units or {}, role)})")
        ax.legend(loc="best")
    if extra:
        ax = axes[-1, 0]
        dt = cond.sample_interval_s
        dpos = derivative(cond.outputs["position"], dt, derivative_method)
        ax.plot(cond.time_s, dpos, "o-", ms=3, lw=0.9, label=f"d/dt position ({derivative_method})")
        if "velocity" in cond.outputs:
            ax.plot(cond.full_time_s, cond.full_outputs["velocity"], lw=0.9, label="tacho velocity")
        pos_unit = channel_unit(units or {}, "position")
        ax.set_ylabel(f"{pos_unit}/s")
        ax.legend(loc="best")
    axes[-1, 0].set_xlabel("time from the step (s)")
    return png(fig)


@styled
def current_denoising(cond: ConditionedExperiment) -> bytes:
    """Armature current as recorded and FFT-denoised (paper Figs. 18, 31–32).

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.

    Returns
    -------
    bytes
        The PNG image.
    """
    t = cond.full_time_s
    raw = cond.full_outputs["current"]
    den = fft_denoise(raw, float(t[1] - t[0]))
    fig, ax = _subplots(figsize=(FULL_WIDTH_IN, 3.0))
    ax.plot(t, raw, lw=0.5, alpha=0.6, label="recorded")
    ax.plot(t, den.values, lw=1.4, label=f"FFT denoised (cut-off {den.cutoff_hz:.3g} Hz)")
    ax.set_xlabel("time from the step (s)")
    ax.set_ylabel("current channel (V)")
    ax.legend(loc="best")
    return png(fig)


@styled
def pole_zero(model: MotorModel) -> bytes:
    """Poles (×) and zeros (○) of the velocity TF, with their 95% intervals when known.

    Parameters
    ----------
    model : MotorModel
        The model.

    Returns
    -------
    bytes
        The PNG image.
    """
    fig, ax = _subplots(figsize=(FULL_WIDTH_IN, 3.4))
    poles, zeros = model.poles(), model.zeros()
    ax.plot(np.real(poles), np.imag(poles), "x", ms=10, mew=2, label="poles")
    if zeros.size:
        ax.plot(np.real(zeros), np.imag(zeros), "o", mfc="none", ms=10, mew=2, label="zeros")
    u = model.uncertainty
    groups = () if u is None else ((u.poles, "C0"), (u.zeros, "C1"))
    for items, marker in groups:
        for item in items:
            half = 1.96 * item.stderr
            if np.isfinite(half):
                ax.errorbar(item.value.real, item.value.imag, xerr=half, color=marker, capsize=4, lw=1.2)
    ax.axvline(0, color="k", lw=0.6)
    ax.axhline(0, color="k", lw=0.6)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlabel("real part (1/s, symlog); bars: 95 % interval")
    ax.set_ylabel("imaginary part (1/s)")
    ax.legend(loc="best")
    return png(fig)


@styled
def step_fit(model: MotorModel, cond: ConditionedExperiment) -> bytes:
    """Measured vs model step responses with residuals (paper Figs. 27–28, 33–35), as PNG.

    Parameters
    ----------
    model : MotorModel
        The identified model.
    cond : ConditionedExperiment
        The conditioned captures.

    Returns
    -------
    bytes
        The PNG image of :func:`step_fit_figure`.
    """
    return png(step_fit_figure(model, cond))


@styled
def step_fit_figure(model: MotorModel, cond: ConditionedExperiment) -> Figure:
    """Measured vs model step responses with residuals (paper Figs. 27–28, 33–35).

    One response above its residual per output, stacked, so that every panel is full width;
    each axis in the data's unit.

    Parameters
    ----------
    model : MotorModel
        The identified model.
    cond : ConditionedExperiment
        The conditioned captures.

    Returns
    -------
    matplotlib.figure.Figure
        A figure of its own (no pyplot manager): a notebook shows it, ``fig.savefig`` saves it.
    """
    t = cond.full_time_s
    roles = [r for r in ("velocity", "position", "current") if r in cond.full_outputs and r in model.outputs]
    if not roles and "velocity" in cond.full_outputs:
        roles = ["velocity"]
    # a counted velocity is compared with the model's means over the same window
    sim = recorded_step_response(model, t, cond.step_volts, velocity_window_s=cond.velocity_window_s,
                                 velocity_window_ends=cond.velocity_window_ends(t))
    fig, axes = _subplots(2 * len(roles), 1, figsize=(FULL_WIDTH_IN, 2.9 * len(roles)), squeeze=False,
                          gridspec_kw={"height_ratios": [3, 1.3] * len(roles)})
    for j, role in enumerate(roles):
        top, bottom = axes[2 * j, 0], axes[2 * j + 1, 0]
        bottom.sharex(top)
        y = cond.full_outputs[role]
        yh = sim.get(role)
        top.plot(t, y, lw=0.8, label="measured")
        if yh is not None:
            counted = role == "velocity" and cond.velocity_window_s > 0
            top.plot(t, yh, lw=1.5, label=f"model ({model.method})"
                     + (f", its means over each {1e3 * cond.velocity_window_s:.3g} ms as counted" if counted else ""))
            bottom.plot(t, y - yh, lw=0.7, color="C3")
        top.set_title(role, loc="left")
        unit = channel_unit(model.units, role)
        top.set_ylabel(f"{role} ({unit})")
        top.legend(loc="best")
        top.tick_params(labelbottom=False)
        bottom.set_xlabel("time from the step (s)")
        bottom.set_ylabel(f"residual ({unit})")
    return fig


@styled
def loop_bode_nyquist(omega: np.ndarray, loop: np.ndarray, margins: Mapping[str, Any]) -> bytes:
    """Bode and Nyquist plots of a design's loop, broken at the motor's input, its margins marked.

    Parameters
    ----------
    omega : ndarray
        Frequencies (rad/s).
    loop : ndarray
        ``L(jω)`` (complex).
    margins : Mapping
        The design JSON's ``margins`` (``crossover_rad_s``, ``phase_deg``, ``gain_db``, ``ms``).

    Returns
    -------
    bytes
        The PNG image.
    """
    fig = Figure(figsize=(FULL_WIDTH_IN, 4.2), layout="constrained")
    grid = fig.add_gridspec(2, 2, width_ratios=[1.6, 1])
    mag, ph, nyq = fig.add_subplot(grid[0, 0]), fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[:, 1])
    ph.sharex(mag)
    ok = np.isfinite(loop)
    w, L = omega[ok], loop[ok]
    mag.semilogx(w, 20 * np.log10(np.abs(L)))
    mag.axhline(0.0, color="k", lw=0.6)
    mag.set_ylabel("|L| (dB)")
    mag.tick_params(labelbottom=False)
    ph.semilogx(w, np.degrees(np.unwrap(np.angle(L))))
    ph.axhline(-180.0, color="k", lw=0.6)
    ph.set_ylabel("phase of L (°)")
    ph.set_xlabel("ω (rad/s)")
    wc, pm = margins.get("crossover_rad_s"), margins.get("phase_deg")
    if wc is not None and pm is not None:
        for ax in (mag, ph):
            ax.axvline(wc, color="C3", ls="--", lw=0.8)
        ph.annotate(f"phase margin {pm:.3g}°", (wc, -180.0 + pm), color="C3", xytext=(4, 4),
                    textcoords="offset points")
    nyq.plot(L.real, L.imag, lw=1.2, label="L(jω), ω > 0")
    nyq.plot(L.real, -L.imag, lw=0.8, ls=":", color="C0")
    nyq.plot([-1.0], [0.0], "+", color="C3", ms=10, mew=2)
    ms = margins.get("ms")
    if ms:  # the Ms circle: |1 + L| ≥ 1/Ms everywhere
        theta = np.linspace(0, 2 * np.pi, 200)
        nyq.plot(-1 + np.cos(theta) / ms, np.sin(theta) / ms, color="C3", lw=0.8, ls="--",
                 label=f"|1 + L| = 1/Ms (Ms {ms:.3g})")
    nyq.set_xlim(-3, 1.5)
    nyq.set_ylim(-2.5, 2.5)
    nyq.set_aspect("equal", adjustable="box")  # keeps the limits (datalim would override them, and say so)
    nyq.set_xlabel("Re L")
    nyq.set_ylabel("Im L")
    nyq.legend(loc="lower right", fontsize="small")
    return png(fig)


@styled
def robust_band(band: Mapping[str, Sequence[float]], unit: str, summary: str) -> bytes:
    """The reference step over the plausible motors: the median and the 95 % band of the output.

    Parameters
    ----------
    band : Mapping
        The design JSON's ``robust.band`` (``time_s``, ``p2_5``, ``median``, ``p97_5``) for a
        unit reference step.
    unit : str
        The measured output's unit (of the reference too).
    summary : str
        The robustness line (:meth:`motorid.control.robust.RobustCheck.text`), as the title.

    Returns
    -------
    bytes
        The PNG image.
    """
    fig = Figure(figsize=(FULL_WIDTH_IN, 2.8), layout="constrained")
    ax = fig.add_subplot()
    t = np.asarray(band["time_s"], float)
    ax.fill_between(t, np.asarray(band["p2_5"], float), np.asarray(band["p97_5"], float), color="C0", alpha=0.3,
                    lw=0, label="95 % of the plausible motors")
    ax.plot(t, np.asarray(band["median"], float), color="C0", lw=1.2, label="median")
    ax.axhline(1.0, color="k", lw=0.6, ls="--", label="reference")
    ax.set_xlabel("time after a unit reference step (s)")
    ax.set_ylabel(f"output ({unit} per {unit} of reference)")
    ax.set_title(_wrapped(summary), fontsize="small")
    ax.legend(loc="lower right", fontsize="small")
    return png(fig)


@styled
def hankel_values(scaled: Sequence[float], raw: Sequence[float], floor: float | None) -> bytes:
    """Normalised Hankel singular values, time-scaled and raw (order evidence, paper §IV).

    Parameters
    ----------
    scaled : sequence of float
        Time-scaled Hankel singular values.
    raw : sequence of float
        Raw Hankel singular values.
    floor : float or None
        The noise floor, drawn as a line when given.

    Returns
    -------
    bytes
        The PNG image.
    """
    fig, ax = _subplots(figsize=(FULL_WIDTH_IN, 3.2))
    k = np.arange(1, len(scaled) + 1)
    ax.semilogy(k, np.maximum(scaled, 1e-16), "o-", label="time-scaled")
    ax.semilogy(np.arange(1, len(raw) + 1), np.maximum(raw, 1e-16), "s--", label="raw (seconds)")
    if floor is not None and np.isfinite(floor):
        ax.axhline(floor, color="k", ls=":", label="noise floor")
    ax.set_xlabel("index k")
    ax.set_ylabel("σ_k / σ_1")
    ax.legend(loc="best")
    ax.grid(True, which="both")
    return png(fig)


@styled
def sweep_maps(lengths: Sequence[float], intervals: Sequence[float], k: np.ndarray, tau: np.ndarray) -> bytes:
    """Heat maps of k and τ over record length × sample interval (paper Tables 1–3).

    Parameters
    ----------
    lengths : sequence of float
        Record lengths in s (columns).
    intervals : sequence of float
        Sample intervals in s (rows).
    k : ndarray
        ``k`` per cell, shape (intervals, lengths).
    tau : ndarray
        τ per cell, same shape.

    Returns
    -------
    bytes
        The PNG image.
    """
    fig, axes = _subplots(1, 2, figsize=(FULL_WIDTH_IN, 3.4))
    for ax, data, name in ((axes[0], k, "k (1/s)"), (axes[1], tau, "τ (s)")):
        im = ax.imshow(data, aspect="auto", origin="upper", cmap="viridis")
        ax.set_xticks(range(len(lengths)), [f"{x:g} s" for x in lengths])
        ax.set_yticks(range(len(intervals)), [f"{1000 * x:g} ms" for x in intervals])
        ax.set_xlabel("record length")
        ax.set_ylabel("ΔT")
        ax.set_title(name)
        ax.grid(False)
        middle = float(np.nanmean(data)) if np.isfinite(data).any() else 0.0
        for i in range(data.shape[0]):
            for j in range(data.shape[1]):
                # dark text on the light (high) end of viridis, white on the dark end
                colour = "k" if np.isfinite(data[i, j]) and data[i, j] > middle else "w"
                ax.text(j, i, _short(float(data[i, j])), ha="center", va="center", color=colour)
        fig.colorbar(im, ax=ax, fraction=0.046)
    return png(fig)


@styled
def validation_overlay(time_s: np.ndarray, input_v: np.ndarray, measured: np.ndarray, simulated: np.ndarray,
                       title: str, output_unit: str = "V", input_unit: str = "V") -> bytes:
    """Model driven by a recorded test signal vs the measured response (paper Figs. 36–38).

    Parameters
    ----------
    time_s : ndarray
        Times in s.
    input_v : ndarray
        The recorded input, in ``input_unit``.
    measured : ndarray
        The measured output, in ``output_unit``.
    simulated : ndarray
        The model's output, in ``output_unit``.
    title : str
        The figure title.
    output_unit, input_unit : str
        The channels' units: an input in another unit than the output (volts against rpm) gets
        its own axis on the right.

    Returns
    -------
    bytes
        The PNG image.
    """
    fig, ax = _subplots(figsize=(FULL_WIDTH_IN, 3.0))
    own_axis = input_unit != output_unit
    ax_in = ax.twinx() if own_axis else ax
    ax_in.plot(time_s, input_v, lw=0.7, alpha=0.5, color="C0", label="input (CH1)")
    ax.plot(time_s, measured, lw=0.8, color="C1", label="measured")
    ax.plot(time_s, simulated, lw=1.4, color="C2", label="model")
    ax.set_title(_wrapped(title), loc="left")
    ax.set_xlabel("time (s)")
    if own_axis:
        ax.set_ylabel(f"output ({output_unit})")
        ax_in.set_ylabel(f"input ({input_unit})")
        lines = ax.get_lines() + ax_in.get_lines()
        ax.legend(lines, [ln.get_label() for ln in lines], loc="best")
    else:
        ax.set_ylabel(output_unit)
        ax.legend(loc="best")
    return png(fig)


@styled
def closed_loop(time_s: np.ndarray, series: Mapping[str, np.ndarray], title: str, *,
                rails_v: float | None = None, disturbances_s: Sequence[float] = (),
                metrics: Sequence[str] = (), output_unit: str = "V", input_unit: str = "V") -> bytes:
    """Closed-loop response: output, reference, control effort (and estimated states).

    Parameters
    ----------
    time_s : ndarray
        Times in s.
    series : Mapping[str, ndarray]
        The simulation's columns by name (``reference``, ``output``, ``u``, states, ...); a name
        starting with ``u`` or containing ``control`` goes on the control-effort panel.
    title : str
        The figure title.
    rails_v : float, optional
        The actuator rails ±V, drawn on the control-effort panel.
    disturbances_s : sequence of float
        Instants a load is applied (s), drawn on both panels.
    metrics : sequence of str
        Short texts (e.g. ``"overshoot: 4.3 %"``) shown under the title.
    output_unit, input_unit : str
        The units of the output (and reference) and of the command (the model's; volts when the
        data did not say otherwise).

    Returns
    -------
    bytes
        The PNG image.
    """
    fig = Figure(figsize=(FULL_WIDTH_IN, 5.0), layout="constrained")
    axes, _ = _closed_loop_axes(fig, np.asarray(time_s), series, output_unit=output_unit, input_unit=input_unit)
    if rails_v is not None:
        for sign in (1.0, -1.0):
            axes[1].axhline(sign * rails_v, color="k", ls="--", lw=1.0,
                            label=f"rails ±{rails_v:g} {input_unit}" if sign > 0 else None)
    for i, t_d in enumerate(disturbances_s):
        for ax in axes:
            ax.axvline(t_d, color="C3", ls=":", lw=1.4, label="load applied" if i == 0 else None)
    for ax in axes:
        ax.legend(loc="best")
    # the metrics go under the title, never over the curves: three to a line
    lines = ["   ".join(metrics[i:i + _METRICS_PER_LINE]) for i in range(0, len(metrics), _METRICS_PER_LINE)]
    axes[0].set_title(_wrapped("\n".join([title, *lines])), loc="left")
    return png(fig)


def _closed_loop_axes(fig: Figure, time_s: np.ndarray, series: Mapping[str, np.ndarray], *, output_unit: str = "V",
                      input_unit: str = "V") -> tuple[Any, dict[str, Any]]:
    """The closed loop's two panels on ``fig``: outputs above, control effort below, labelled.

    A name starting with ``u`` or containing ``control`` goes on the control-effort panel; each
    curve is drawn :func:`thinned`.  Returns the axes and the curves by name.
    """
    axes = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    lines = {}
    for name, y in series.items():
        ax = axes[1] if name.startswith("u") or "control" in name else axes[0]
        lines[name] = ax.plot(*thinned(time_s, np.asarray(y)), lw=1.3, label=name)[0]
    axes[0].set_ylabel(output_unit)
    axes[1].set_ylabel(f"control u ({input_unit})")
    axes[1].set_xlabel("time (s)")
    return axes, lines


class ClosedLoopCanvas:
    """The closed-loop figure of :func:`closed_loop` kept between redraws, drawn as SVG.

    The web page redraws it on every slider move: building the figure (axes, ticks, the
    constrained layout) was most of a move's CPU, so the figure, its axes and its curves are
    made once and each redraw only replaces the curves' data, rescales and renders (about 36 ms
    instead of 150 ms; ``bench/web_update_speed.py``).  Fixed margins stand in for the
    constrained layout.  One figure is kept per set of series names (the page switches between
    a run with the plausible motors' band and one without), at most :attr:`KEPT` of them.  The
    SVG's text is text, not glyph outlines (``svg.fonttype: none``): a third less to render
    and to send.  Its own lock makes one canvas safe to share between threads.
    """

    #: Figures kept, one per set of series names.
    KEPT = 4

    def __init__(self) -> None:
        self._lock = threading.Lock()
        # keyed by the series' names and the two units
        self._figures: dict[tuple[str, ...], tuple[Figure, Any, dict[str, Any]]] = {}

    def _build(self, time_s: np.ndarray, series: Mapping[str, np.ndarray], units: tuple[str, str]
               ) -> tuple[Figure, Any, dict[str, Any]]:
        fig = Figure(figsize=(FULL_WIDTH_IN, 5.0))
        axes, lines = _closed_loop_axes(fig, time_s, series, output_unit=units[0], input_unit=units[1])
        for ax in axes:
            if ax.get_lines():  # a panel without curves gets no (empty) legend
                ax.legend(loc="best")
            # fixed places for the axis labels and the title: matplotlib otherwise measures every
            # tick label on each redraw to place them (a sixth of a redraw)
            ax.yaxis.set_label_coords(-0.085, 0.5)
        axes[-1].xaxis.set_label_coords(0.5, -0.2)
        if len(self._figures) >= self.KEPT:
            self._figures.pop(next(iter(self._figures)))
        self._figures[(*series, *units)] = (fig, axes, lines)
        return fig, axes, lines

    def svg(self, time_s: np.ndarray, series: Mapping[str, np.ndarray], title: str, *, output_unit: str = "V",
            input_unit: str = "V") -> bytes:
        """The figure for these curves, as SVG.

        Parameters
        ----------
        time_s : ndarray
            Times in s.
        series : Mapping[str, ndarray]
            The curves by name, as :func:`closed_loop` takes them.
        title : str
            The figure title.
        output_unit, input_unit : str
            The units of the output and of the command, on the axes.

        Returns
        -------
        bytes
            The SVG image (for :func:`data_uri` with ``kind="svg+xml"``).
        """
        t = np.asarray(time_s, dtype=float)
        with self._lock, matplotlib.rc_context(cast("Any", _STYLE | {"svg.fonttype": "none"})):
            kept = self._figures.get((*series, output_unit, input_unit))
            if kept is None:
                fig, axes, _ = self._build(t, series, (output_unit, input_unit))
            else:
                fig, axes, lines = kept
                for name, y in series.items():
                    lines[name].set_data(*thinned(t, np.asarray(y)))
                for ax in axes:
                    ax.relim()
                    ax.autoscale_view()
            heading = _wrapped(title)
            axes[0].set_title(heading, loc="left", y=1.0)
            # room for the heading's lines (about 0.2 in each at the style's title size)
            top = 1.0 - (0.2 * (heading.count("\n") + 1) + 0.15) / 5.0
            fig.subplots_adjust(left=0.1, right=0.98, bottom=0.11, top=top, hspace=0.08)
            buf = io.BytesIO()
            fig.savefig(buf, format="svg")
            return buf.getvalue()


@styled
def mode_maps(maps: Sequence[Any], design_gains: tuple[float, float] | None = None) -> bytes:
    """The modes of the saturated position/velocity loop over (Kp, Kv), one map per plant (Figs. 4, 11–13).

    Parameters
    ----------
    maps : sequence of ModeMap
        From :func:`motorid.simulation.modes.mode_map`.
    design_gains : (float, float), optional
        A design's own ``(Kp, Kv)``, marked on every map.

    Returns
    -------
    bytes
        The PNG image.
    """
    from matplotlib.artist import Artist
    from matplotlib.colors import ListedColormap
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    from motorid.simulation.modes import MODES

    cmap = ListedColormap(list(_MODE_COLOURS))
    fig, axes = _subplots(1, len(maps), figsize=(FULL_WIDTH_IN, 4.2), squeeze=False)
    for ax, m in zip(axes[0], maps, strict=False):
        ext = (float(m.kp[0]), float(m.kp[-1]), float(m.kv[0]), float(m.kv[-1]))
        ax.imshow(m.labels, origin="lower", aspect="auto", extent=ext, cmap=cmap, vmin=-0.5,
                  vmax=len(MODES) - 0.5, interpolation="nearest")
        if design_gains is not None:
            ax.plot(*design_gains, marker="*", ms=16, mfc="white", mec="k", ls="none")
        ax.set_title(m.plant)
        ax.set_xlabel("Kp (V/V)")
        ax.set_ylabel("Kv (V/(V/s))")
        ax.grid(False)
    handles: list[Artist] = [Patch(color=c, label=name.replace("_", " "))
                             for c, name in zip(_MODE_COLOURS, MODES, strict=False)]
    if design_gains is not None:
        handles.append(Line2D([], [], marker="*", ms=14, mfc="white", mec="k", ls="none",
                                               label="this design"))
    fig.legend(handles=handles, loc="outside lower center", ncol=4)
    return png(fig)


@dataclass(frozen=True, slots=True)
class IntervalCheck:
    """One estimate with its 95 % interval and a value to compare it with.

    Attributes
    ----------
    label : str
        The quantity, with its unit (``"dc gain (V/V)"``).
    value : float
        The estimate.
    ci95 : (float, float)
        Its 95 % interval.
    reference : float or None
        The value compared with it (the truth, or the classic estimate).
    reference_label : str
        What ``reference`` is (``"truth"``, ``"classic estimate"``).
    """

    label: str
    value: float
    ci95: tuple[float, float]
    reference: float | None
    reference_label: str


@styled
def interval_checks(checks: Sequence[IntervalCheck]) -> bytes:
    """Each estimate with its 95 % interval and the truth (or the classic estimate) beside it.

    One row per quantity; the horizontal axis of each row spans the interval and the
    reference, so that a miss shows as a marker outside the bar.

    Parameters
    ----------
    checks : sequence of IntervalCheck
        The quantities.

    Returns
    -------
    bytes
        The PNG image.
    """
    fig, axes = _subplots(len(checks), 1, figsize=(FULL_WIDTH_IN, 1.3 * len(checks) + 0.3), squeeze=False)
    for ax, c in zip(axes[:, 0], checks, strict=False):
        lo, hi = c.ci95
        ax.errorbar([c.value], [0], xerr=[[c.value - lo], [hi - c.value]], fmt="o", color="C0", capsize=6, lw=2,
                    label="estimate, 95 % interval")
        if c.reference is not None:
            ax.plot([c.reference], [0], "D", color="C3", ms=9, label=c.reference_label)
        ax.set_yticks([])
        ax.set_ylim(-1, 1.8)  # room above the markers for the legend
        ax.set_xlabel(c.label)
        ax.grid(False, axis="y")
        if ax is axes[0, 0]:
            ax.legend(loc="upper center", ncol=2, frameon=False)
        ax.ticklabel_format(axis="x", useOffset=False)
    return png(fig)

"""The report's figures, each a function of data returning PNG bytes.

Matplotlib figures are made without pyplot, so the caller's backend is never switched.

The figure numbers of Masoud 2019 that each one corresponds to are given in the docstrings.
"""

from __future__ import annotations

import io
from collections.abc import Mapping, Sequence

import numpy as np
from matplotlib.figure import Figure

from motorid.capture import Capture
from motorid.conditioning.denoise import fft_denoise
from motorid.conditioning.derivative import derivative
from motorid.conditioning.pipeline import ConditionedExperiment
from motorid.model import MotorModel

__all__ = [
    "closed_loop",
    "conditioned_signals",
    "current_denoising",
    "hankel_values",
    "png",
    "pole_zero",
    "raw_captures",
    "step_fit",
    "sweep_maps",
    "validation_overlay",
]

DPI = 80


def _subplots(nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], **kwargs):
    """``pyplot.subplots`` without pyplot: a :class:`~matplotlib.figure.Figure` of its own.

    No global figure manager, no backend switch — a notebook's backend is left alone.
    """
    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **kwargs)


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
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight")
    return buf.getvalue()


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
    fig, axes = _subplots(n, 1, figsize=(8, 2.2 * n), squeeze=False)
    for ax, (role, cap) in zip(axes[:, 0], captures.items(), strict=False):
        if cap.input_v is not None:
            ax.plot(cap.time_s, cap.input_v, lw=0.8, label="CH1 input")
        ax.plot(cap.time_s, cap.output_v, lw=0.8, label=f"CH2 {role}")
        ax.set_title(f"{role}: {cap.source}", fontsize=9)
        ax.set_ylabel("V")
        ax.legend(fontsize=7, loc="best")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time on the file's axis (s)")
    fig.tight_layout()
    return png(fig)


def conditioned_signals(cond: ConditionedExperiment, derivative_method: str = "five_point") -> bytes:
    """Synchronised, unwrapped, reduced step responses and the numerical derivative (Figs. 16–17, 26).

    Parameters
    ----------
    cond : ConditionedExperiment
        The conditioned captures.
    derivative_method : str
        The numerical derivative shown (default ``five_point``).

    Returns
    -------
    bytes
        The PNG image.
    """
    roles = list(cond.full_outputs)
    extra = 1 if "position" in roles else 0
    fig, axes = _subplots(len(roles) + extra, 1, figsize=(8, 2.2 * (len(roles) + extra)), squeeze=False)
    for ax, role in zip(axes[:, 0], roles, strict=False):
        ax.plot(cond.full_time_s, cond.full_outputs[role], lw=0.8, label=f"{role}, synchronised")
        ax.plot(cond.time_s, cond.outputs[role], "o", ms=3, label=f"reduced ×{cond.ratio}")
        ax.set_ylabel("V")
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    if extra:
        ax = axes[-1, 0]
        dt = cond.sample_interval_s
        dpos = derivative(cond.outputs["position"], dt, derivative_method)
        ax.plot(cond.time_s, dpos, "o-", ms=3, lw=0.8, label=f"d/dt position ({derivative_method})")
        if "velocity" in cond.outputs:
            ax.plot(cond.full_time_s, cond.full_outputs["velocity"], lw=0.8, label="tacho velocity")
        ax.set_ylabel("V, V/s")
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("time from the step (s)")
    fig.tight_layout()
    return png(fig)


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
    fig, ax = _subplots(figsize=(8, 2.6))
    ax.plot(t, raw, lw=0.5, alpha=0.6, label="recorded")
    ax.plot(t, den.values, lw=1.2, label=f"FFT denoised (cut-off {den.cutoff_hz:.3g} Hz)")
    ax.set_xlabel("time from the step (s)")
    ax.set_ylabel("V")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return png(fig)


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
    fig, ax = _subplots(figsize=(5, 3.4))
    poles, zeros = model.poles(), model.zeros()
    ax.plot(np.real(poles), np.imag(poles), "x", ms=9, mew=2, label="poles")
    if zeros.size:
        ax.plot(np.real(zeros), np.imag(zeros), "o", mfc="none", ms=9, mew=2, label="zeros")
    u = model.uncertainty
    for key, marker in (("poles", "C0"), ("zeros", "C1")):
        for item in u.get(key, []) if u else []:
            re_, im_ = item["value"]
            half = 1.96 * float(item["std"]) if item["std"] is not None else 0.0
            if np.isfinite(half):
                ax.errorbar(re_, im_, xerr=half, color=marker, capsize=3, lw=1)
    ax.axvline(0, color="k", lw=0.5)
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_xlabel("real (1/s, symlog)")
    ax.set_ylabel("imag (1/s)")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return png(fig)


def step_fit(model: MotorModel, cond: ConditionedExperiment) -> bytes:
    """Measured vs model step responses with residuals (paper Figs. 27–28, 33–35).

    Parameters
    ----------
    model : MotorModel
        The identified model.
    cond : ConditionedExperiment
        The conditioned captures.

    Returns
    -------
    bytes
        The PNG image.
    """
    t = cond.full_time_s
    roles = [r for r in ("velocity", "position", "current") if r in cond.full_outputs and r in model.outputs]
    if not roles and "velocity" in cond.full_outputs:
        roles = ["velocity"]
    sim = model.step_response(t, cond.step_volts)
    fig, axes = _subplots(2, len(roles), figsize=(4 * len(roles), 4.2), squeeze=False,
                             gridspec_kw={"height_ratios": [3, 1]})
    for j, role in enumerate(roles):
        y = cond.full_outputs[role]
        yh = sim.get(role)
        axes[0, j].plot(t, y, lw=0.7, label="measured")
        if yh is not None:
            axes[0, j].plot(t, yh, lw=1.2, label=f"model ({model.method})")
            axes[1, j].plot(t, y - yh, lw=0.6, color="C3")
        axes[0, j].set_title(role, fontsize=9)
        axes[0, j].legend(fontsize=7)
        axes[0, j].grid(alpha=0.3)
        axes[1, j].set_xlabel("time from the step (s)")
        axes[1, j].set_ylabel("residual (V)")
        axes[1, j].grid(alpha=0.3)
    fig.tight_layout()
    return png(fig)


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
    fig, ax = _subplots(figsize=(5, 3))
    k = np.arange(1, len(scaled) + 1)
    ax.semilogy(k, np.maximum(scaled, 1e-16), "o-", label="time-scaled")
    ax.semilogy(np.arange(1, len(raw) + 1), np.maximum(raw, 1e-16), "s--", label="raw (seconds)")
    if floor is not None and np.isfinite(floor):
        ax.axhline(floor, color="k", ls=":", label="noise floor")
    ax.set_xlabel("index")
    ax.set_ylabel("σ_k / σ_1")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    return png(fig)


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
    fig, axes = _subplots(1, 2, figsize=(8, 3))
    for ax, data, name in ((axes[0], k, "k"), (axes[1], tau, "τ (s)")):
        im = ax.imshow(data, aspect="auto", origin="upper", cmap="viridis")
        ax.set_xticks(range(len(lengths)), [f"{x:g} s" for x in lengths])
        ax.set_yticks(range(len(intervals)), [f"{1000 * x:g} ms" for x in intervals])
        ax.set_xlabel("record length")
        ax.set_ylabel("ΔT")
        ax.set_title(name, fontsize=9)
        for i in range(data.shape[0]):
            for j in range(data.shape[1]):
                ax.text(j, i, f"{data[i, j]:.3g}", ha="center", va="center", fontsize=7, color="w")
        fig.colorbar(im, ax=ax, fraction=0.046)
    fig.tight_layout()
    return png(fig)


def validation_overlay(time_s: np.ndarray, input_v: np.ndarray, measured: np.ndarray, simulated: np.ndarray,
                       title: str) -> bytes:
    """Model driven by a recorded test signal vs the measured response (paper Figs. 36–38).

    Parameters
    ----------
    time_s : ndarray
        Times in s.
    input_v : ndarray
        The recorded input in volts.
    measured : ndarray
        The measured output in volts.
    simulated : ndarray
        The model's output in volts.
    title : str
        The figure title.

    Returns
    -------
    bytes
        The PNG image.
    """
    fig, ax = _subplots(figsize=(8, 2.6))
    ax.plot(time_s, input_v, lw=0.6, alpha=0.5, label="input (CH1)")
    ax.plot(time_s, measured, lw=0.7, label="measured")
    ax.plot(time_s, simulated, lw=1.2, label="model")
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("V")
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    return png(fig)


def closed_loop(time_s: np.ndarray, series: Mapping[str, np.ndarray], title: str) -> bytes:
    """Closed-loop response: output, reference, control effort (and estimated states).

    Parameters
    ----------
    time_s : ndarray
        Times in s.
    series : Mapping[str, ndarray]
        The simulation's columns by name (``reference``, ``output``, ``u``, states, ...).
    title : str
        The figure title.

    Returns
    -------
    bytes
        The PNG image.
    """
    fig, axes = _subplots(2, 1, figsize=(8, 4), sharex=True)
    for name, y in series.items():
        ax = axes[1] if name.startswith("u") or "control" in name else axes[0]
        ax.plot(time_s, y, lw=1, label=name)
    for ax in axes:
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3)
    axes[0].set_title(title, fontsize=9)
    axes[1].set_xlabel("time (s)")
    fig.tight_layout()
    return png(fig)

"""Validation of a model on any recorded input (paper section VI-B, Figs. 36–38).

The model is driven by the input actually recorded on CH1 (sine, triangle, square, a step…)
and its output compared with the recorded CH2.  The record rarely starts at rest, so the
model starts from rest a warm-up before the compared part: the first ``warmup_tau``
dominant time constants of the record are simulated but not scored (the initial-state error
has decayed by ``e^-warmup_tau`` there).
"""

from __future__ import annotations

from dataclasses import dataclass

import control
import numpy as np

from motorid.capture import Capture
from motorid.errors import CaptureDataError, OptionError
from motorid.model import MotorModel

__all__ = ["ValidationResult", "validate_capture"]


@dataclass(frozen=True, slots=True)
class ValidationResult:
    """A model's prediction of one capture.

    Attributes
    ----------
    source : str
        The capture.
    channel : str
        The model output compared (``velocity``, ``position`` or ``current``).
    time_s, input_v, measured_v, simulated_v : ndarray
        The compared part of the record.
    nrmse : float
        RMS of (measured − simulated) over the RMS of the measured signal about its mean.
    fit_percent : float
        ``100·(1 − ‖y − ŷ‖/‖y − ȳ‖)``, MATLAB's ``compare`` fit.
    warmup_s : float
        Simulated but not scored.
    """

    source: str
    channel: str
    time_s: np.ndarray
    input_v: np.ndarray
    measured_v: np.ndarray
    simulated_v: np.ndarray
    nrmse: float
    fit_percent: float
    warmup_s: float


def validate_capture(
    model: MotorModel, capture: Capture, *, channel: str = "velocity", warmup_tau: float = 5.0
) -> ValidationResult:
    """Drive ``model`` with the capture's recorded input and compare with its output.

    Parameters
    ----------
    model : MotorModel
        Any identified model.
    capture : Capture
        A capture with an input channel (CH1).
    channel : str
        The model output that CH2 measured.
    warmup_tau : float
        Dominant time constants at the start that are simulated but not scored.

    Returns
    -------
    ValidationResult

    Raises
    ------
    CaptureDataError
        The capture has no input channel or is too short for the warm-up.
    OptionError
        The model has no such output.
    """
    if capture.input_v is None:
        raise CaptureDataError("no input channel (CH1) to drive the model with", file=capture.source)
    if channel not in model.outputs and channel != "position":
        raise OptionError(f"the model has no {channel!r} output; it has {', '.join(model.outputs)}")
    t = capture.time_s - capture.time_s[0]
    u = capture.input_v
    y = capture.output_v
    tf = {"velocity": model.velocity_tf, "position": model.position_tf, "current": model.current_tf}[channel]()
    _, yhat = control.forced_response(tf, t, u)
    tau = model.first_order().time_constant_s
    warm = warmup_tau * tau if np.isfinite(tau) and tau > 0 else 0.0
    keep = t >= warm
    if keep.sum() < 10:
        raise CaptureDataError(
            f"record of {t[-1]:.3g} s is too short to validate after a {warm:.3g} s warm-up", file=capture.source
        )
    ym, yh = y[keep], np.asarray(yhat)[keep]
    err = float(np.sqrt(np.mean((ym - yh) ** 2)))
    spread = float(np.sqrt(np.mean((ym - ym.mean()) ** 2)))
    nrmse = err / spread if spread > 0 else float("inf")
    return ValidationResult(capture.source, channel, capture.time_s[keep], u[keep], ym, yh, nrmse,
                            100.0 * (1.0 - nrmse), float(warm))

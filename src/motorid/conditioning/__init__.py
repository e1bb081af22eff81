"""Data conditioning of scope captures (Masoud 2019, section V-1 to V-3).

Each step is a small function of its own module, composable by :mod:`.pipeline`:
step-edge detection (:mod:`.edge`), step responses with time zero at the edge
(:mod:`.response`), synchronisation of captures (:mod:`.sync`), encoder unwrapping
(:mod:`.unwrap`), sample reduction (:mod:`.resample`), numerical differentiation
(:mod:`.derivative`), FFT denoising of the armature current (:mod:`.denoise`) and the role of
a capture guessed from its signal (:mod:`.role`).
"""

from motorid.conditioning.derivative import DERIVATIVE_METHODS, derivative
from motorid.conditioning.denoise import Denoised, fft_denoise
from motorid.conditioning.edge import StepEdge, response_onset, step_edge
from motorid.conditioning.resample import REDUCTION_METHODS, Reduced, ratio_for_interval, sample_reduction
from motorid.conditioning.unwrap import UnwrapResult, count_wraps, unwrap_position

__all__ = [
    "DERIVATIVE_METHODS",
    "REDUCTION_METHODS",
    "Denoised",
    "Reduced",
    "StepEdge",
    "UnwrapResult",
    "count_wraps",
    "derivative",
    "fft_denoise",
    "ratio_for_interval",
    "response_onset",
    "sample_reduction",
    "step_edge",
    "unwrap_position",
]

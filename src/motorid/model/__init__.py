"""The identified motor (:class:`MotorModel`) and what is done to it.

:mod:`.motor` the model itself (state space with named states and outputs, its transfer
functions), :mod:`.simplify` pole-zero cancellation, reduction and the dominant first order,
:mod:`.response` step responses and their NRMSE, :mod:`.serialize` the docs/formats.md JSON and
the MATLAB script, :mod:`.notation` polynomials written as the paper writes them.
"""

from motorid.errors import ModelFormatError
from motorid.model.motor import CHANNELS, MotorModel, model_from_velocity_tf
from motorid.model.response import step_nrmse
from motorid.model.serialize import SCHEMA
from motorid.model.simplify import CANCEL_TOL_REL, EXACT_CANCEL_TOL, FirstOrder

__all__ = [
    "CANCEL_TOL_REL",
    "CHANNELS",
    "EXACT_CANCEL_TOL",
    "SCHEMA",
    "FirstOrder",
    "ModelFormatError",
    "MotorModel",
    "model_from_velocity_tf",
    "step_nrmse",
]

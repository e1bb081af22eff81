"""motorid: identify a DC servo-motor model from oscilloscope step captures.

Front door
==========
::

    import motorid as mi
    exp = mi.read_experiment(position="D/ALL0000", velocity="D/ALL0001", current="D/ALL0002")
    fit = mi.identify(exp)                     # keyword-only options: method=, order=, ...
    print(fit.summary())                       # the text `motorid identify` prints
    fit.params["dc_gain"].value, fit.params["dc_gain"].ci95
    des = mi.design(fit.model, damping=0.7, wn=5.0)
    sim = mi.simulate(fit.model, des, duration_s=3.0); sim.plot()
    mi.write_report("report.html", fit, design=des)

.. autosummary::

   read_experiment  -- read the captures of one step experiment, one per role
   identify         -- identify the motor model (``motorid identify``)
   identify_levels  -- dead-zone, gain, rails and shared dynamics from several step levels
   advise           -- how to record the next capture: each scope setting's predicted intervals
   design           -- state feedback, integral action, observer (``motorid design``)
   design_pid       -- a PID tuned by SIMC or pole placement (``motorid design --pid``)
   simulate         -- closed-loop run on the model or the virtual trainer (``motorid simulate``)
   validate         -- score a model on recorded inputs: NRMSE, fit % (``motorid validate``)
   write_report     -- the self-contained HTML report (``motorid report``)

Results
=======

.. autosummary::

   Experiment           -- the captures of one experiment by role, with the files' SHA-256
   IdentificationResult -- model, params, stages, fit, warnings, sanity, provenance, summary()
   ParameterEstimate    -- value, stderr and 95 % interval of one identified quantity
   MethodOptions        -- the estimators' own settings for ``identify(method_options=...)``
   OutputErrorOptions   -- the output-error fit's evaluations and tolerances
   LaguerreSettings     -- the Laguerre–Hankel (Markov) estimate's basis, terms, orders, noise floor
   SrivcSettings        -- SRIVC's iterations and tolerance
   Provenance           -- motorid version, input files' SHA-256, settings
   MotorModel           -- the identified state-space model (python-control objects inside)
   Design               -- a designed controller (gains, poles, observer)
   PidDesign            -- a designed PID (gains in the data's units, margins, python-control objects)
   SimulationResult     -- closed-loop time series and metrics; plot() returns a Figure
   ValidationResult     -- a model's prediction of one capture: NRMSE, fit %, offset, series

Data and errors
===============

.. autosummary::

   Capture      -- raw samples of one scope acquisition (CH1 input, CH2 output)
   ChannelInfo  -- one channel's scope metadata (probe, scale, label)
   ScopeInfo    -- the scope's metadata (model, firmware, trigger)
   MotorIdError -- base class of every error caused by the user's input

Stages
======
Data flows one way: :mod:`motorid.io` (read capture files) →
:mod:`motorid.conditioning` (edge, sync, unwrap, reduce, differentiate, denoise) →
:mod:`motorid.identification.pipeline` (the methods in :mod:`motorid.identification`) → :mod:`motorid.model` →
:mod:`motorid.control` / :mod:`motorid.simulation` → :mod:`motorid.report`.
:mod:`motorid.trainer` is the virtual servo trainer that stands in for the bench hardware.

``import motorid`` stays light: the front door and the result types load on first use.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from motorid.errors import MotorIdError

if TYPE_CHECKING:  # what type checkers see; at run time each name loads on first use (below)
    from motorid.capture import Capture, ChannelInfo, ScopeInfo
    from motorid.control.design import Design
    from motorid.control.pid import PidDesign
    from motorid.frontdoor import (
        Experiment,
        IdentificationResult,
        Provenance,
        advise,
        design,
        design_pid,
        identify,
        identify_levels,
        read_experiment,
        simulate,
        validate,
        write_report,
    )
    from motorid.identification.laguerre import LaguerreSettings
    from motorid.identification.method_options import MethodOptions, OutputErrorOptions
    from motorid.identification.result import ParameterEstimate
    from motorid.identification.srivc import SrivcSettings
    from motorid.model import MotorModel
    from motorid.analysis.validation import ValidationResult
    from motorid.simulation.closed_loop import SimulationResult

__all__ = [
    "Capture",
    "ChannelInfo",
    "Design",
    "Experiment",
    "IdentificationResult",
    "LaguerreSettings",
    "MethodOptions",
    "MotorIdError",
    "MotorModel",
    "OutputErrorOptions",
    "ParameterEstimate",
    "PidDesign",
    "Provenance",
    "ScopeInfo",
    "SimulationResult",
    "SrivcSettings",
    "ValidationResult",
    "advise",
    "design",
    "design_pid",
    "identify",
    "identify_levels",
    "read_experiment",
    "simulate",
    "validate",
    "write_report",
]
__version__ = "0.1.0"

#: Public names loaded on first use, and the module each lives in.
_LAZY: dict[str, str] = {
    "Capture": "motorid.capture",  # numpy: not for ``motorid --help``
    "ChannelInfo": "motorid.capture",
    "ScopeInfo": "motorid.capture",
    "read_experiment": "motorid.frontdoor",
    "identify": "motorid.frontdoor",
    "simulate": "motorid.frontdoor",
    "identify_levels": "motorid.frontdoor",
    "design": "motorid.frontdoor",
    "design_pid": "motorid.frontdoor",
    "write_report": "motorid.frontdoor",
    "validate": "motorid.frontdoor",
    "advise": "motorid.frontdoor",
    "Experiment": "motorid.frontdoor",
    "IdentificationResult": "motorid.frontdoor",
    "ParameterEstimate": "motorid.identification.result",
    "MethodOptions": "motorid.identification.method_options",
    "OutputErrorOptions": "motorid.identification.method_options",
    "LaguerreSettings": "motorid.identification.laguerre",
    "SrivcSettings": "motorid.identification.srivc",
    "Provenance": "motorid.frontdoor",
    "MotorModel": "motorid.model",
    "Design": "motorid.control.design",
    "PidDesign": "motorid.control.pid",
    "SimulationResult": "motorid.simulation.closed_loop",
    "ValidationResult": "motorid.analysis.validation",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'motorid' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


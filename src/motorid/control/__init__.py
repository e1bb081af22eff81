"""Controller design on a motor model: state feedback, integral action, observer (Tsiolakis 2022).

The designed controller as one system (:func:`controller_system`), sampled and written as code
for a microcontroller (:mod:`.emit`: :func:`discretise_design`, :func:`emit_c`, :func:`emit_python`,
:func:`emit_matlab`).
"""

from motorid.control.approx import dominant_second_order
from motorid.control.controller import controller_system
from motorid.control.coordinates import MeasurableRealisation, measurable_realisation, realise_in, sensor_unit
from motorid.control.design import SCHEMA, Design, DesignSettings, design_controller, design_model, output_row
from motorid.control.emit import (
    DiscreteController,
    discretise,
    discretise_design,
    emit_c,
    emit_matlab,
    emit_python,
)
from motorid.control.feedback import (
    POLE_RATIO_MAX,
    UNCONTROLLABLE_TOL,
    ControlDesignError,
    check_controllable,
    check_pole_range,
    check_poles,
    pbh_margins,
    k1_for_damping,
    parse_poles,
    place_gains,
    poles_from_damping,
    poles_from_specs,
    reference_gain,
)
from motorid.control.integral import augment_integral, integral_gains, integral_poly, routh_violations
from motorid.control.observer import check_observable, observer_gain, output_feedback_matrix
from motorid.control.pid import PidDesign, PidSettings, design_pid
from motorid.control.params import MotorParams, model_from_params, params_from_step_test, parse_ratio
from motorid.control.routh import AffinePoly, affine_char_poly, routh_array, routh_conditions, routh_stable

__all__ = [
    "POLE_RATIO_MAX",
    "SCHEMA",
    "UNCONTROLLABLE_TOL",
    "AffinePoly",
    "ControlDesignError",
    "Design",
    "DesignSettings",
    "DiscreteController",
    "MeasurableRealisation",
    "MotorParams",
    "PidDesign",
    "PidSettings",
    "affine_char_poly",
    "augment_integral",
    "check_controllable",
    "check_observable",
    "check_pole_range",
    "check_poles",
    "controller_system",
    "design_controller",
    "design_model",
    "design_pid",
    "discretise",
    "discretise_design",
    "dominant_second_order",
    "emit_c",
    "emit_matlab",
    "emit_python",
    "integral_gains",
    "integral_poly",
    "k1_for_damping",
    "measurable_realisation",
    "model_from_params",
    "observer_gain",
    "output_feedback_matrix",
    "output_row",
    "params_from_step_test",
    "parse_poles",
    "parse_ratio",
    "pbh_margins",
    "place_gains",
    "poles_from_damping",
    "poles_from_specs",
    "realise_in",
    "reference_gain",
    "routh_array",
    "routh_conditions",
    "routh_stable",
    "routh_violations",
    "sensor_unit",
]

"""Controller design on a motor model: state feedback, integral action, observer (Tsiolakis 2022)."""

from motorid.control.approx import dominant_second_order
from motorid.control.coordinates import MeasurableRealisation, measurable_realisation, realise_in, sensor_unit
from motorid.control.design import SCHEMA, Design, DesignSettings, design_controller, design_model, output_row
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
from motorid.control.params import MotorParams, model_from_params, params_from_step_test, parse_ratio
from motorid.control.routh import AffinePoly, affine_char_poly, routh_array, routh_conditions, routh_stable

__all__ = [
    "dominant_second_order",
    "MeasurableRealisation", "measurable_realisation", "realise_in", "sensor_unit",
    "SCHEMA", "Design", "DesignSettings", "design_controller", "design_model", "output_row",
    "POLE_RATIO_MAX", "UNCONTROLLABLE_TOL", "ControlDesignError", "check_controllable", "check_pole_range",
    "check_poles", "pbh_margins", "k1_for_damping", "parse_poles",
    "place_gains", "poles_from_damping", "poles_from_specs", "reference_gain",
    "augment_integral", "integral_gains", "integral_poly", "routh_violations",
    "check_observable", "observer_gain", "output_feedback_matrix",
    "MotorParams", "model_from_params", "params_from_step_test", "parse_ratio",
    "AffinePoly", "affine_char_poly", "routh_array", "routh_conditions", "routh_stable",
]

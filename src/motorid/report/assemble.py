"""``motorid report`` / ``identify --report``: gather what a report shows and write the page."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from motorid._threads import single_blas_thread
from motorid.capture import Capture
from motorid.errors import MotorIdError
from motorid.identification.pipeline import Identification, IdentifySettings
from motorid.report import ReportInputs, build_report
from motorid.analysis.sweep import PAPER_LENGTHS_S, data_grid, sensitivity_table
from motorid.simulation.closed_loop import SimulationSettings
from motorid.simulation.reference import default_rails
from motorid.simulation.modes import ModeCriteria

__all__ = ["MODE_MAP_KP", "MODE_MAP_KV", "REPORT_RAILS_V", "make_report"]

#: Actuator rails (±V) of the report's closed-loop run: the same as the mode map's (paper Fig. 12).
REPORT_RAILS_V = ModeCriteria().saturation_v
#: States of the sensitivity table's pinv models: the paper's reduced state [θ, θ̇] when a
#: position capture is there, the velocity alone otherwise.
SWEEP_ORDER_WITH_POSITION = 2
SWEEP_ORDER_VELOCITY_ONLY = 1
#: The mode map's grid: Kp (V/V) and Kv (V/(V/s)), as in the paper's Figs. 11–13.
MODE_MAP_KP = (0.5, 60.0, 40)
MODE_MAP_KV = (0.0, 8.0, 40)


@single_blas_thread
def make_report(
    ident: Identification,
    captures: Mapping[str, Capture],
    *,
    validation: Mapping[str, Capture] | None = None,
    design: Mapping[str, Any] | None = None,
    truth: Mapping[str, Any] | None = None,
    sweep: bool = True,
    title: str = "motorid report",
    simulation: SimulationSettings | None = None,
) -> str:
    """The HTML report of an identification (see :func:`motorid.report.build_report`).

    The sensitivity table is the paper's: pinv with the reduced state over 1.9/2.4/2.9 s ×
    40–120 ms, so a student sees the drift the paper reports next to the model — or, when the
    record is shorter than the paper's lengths (a fast motor), the same grid in the data's own
    time scales (:func:`motorid.analysis.sweep.data_grid`).

    Parameters
    ----------
    ident : Identification
        The identification (:func:`motorid.identification.pipeline.identify_experiment`).
    captures : Mapping[str, Capture]
        The captures it was identified from, keyed by role.
    validation : Mapping[str, Capture], optional
        Captures of other inputs to validate the model on, by name.
    design : Mapping[str, Any], optional
        A design JSON dict to show with its closed-loop response and mode maps.
    truth : Mapping[str, Any], optional
        The virtual trainer's ``truth.json``, shown next to the estimate.
    sweep : bool
        Compute the sensitivity table (default True).
    title : str
        The page title.
    simulation : SimulationSettings, optional
        The closed-loop run shown with a design (default: a step to the model's reference level
        with the rails :func:`motorid.simulation.reference.default_rails`, the mode map's
        :data:`REPORT_RAILS_V` on a command in volts; a disturbance given here is marked on the plot).

    Returns
    -------
    str
        A complete, self-contained HTML document.
    """
    table = _sensitivity(ident, captures) if sweep else None
    view = _design_view(ident, design, simulation)
    return build_report(ReportInputs(ident, captures, validation or {}, table, view, truth, title))


def _sensitivity(ident: Identification, captures: Mapping[str, Capture]) -> Any:
    """The paper's sensitivity table on these captures, or None when it cannot be computed."""
    cond = ident.conditioned
    # captures without an input channel were identified with the user's step level
    step = cond.step_volts if any(c.input_v is None for c in captures.values()) else None
    order = SWEEP_ORDER_WITH_POSITION if "position" in captures else SWEEP_ORDER_VELOCITY_ONLY
    axes: dict[str, Any] = {}
    try:
        if float(cond.full_time_s[-1]) < max(PAPER_LENGTHS_S):
            lengths, intervals, _ = data_grid(captures, step_volts=step)
            axes = {"lengths_s": lengths, "intervals_s": intervals}
        return sensitivity_table(captures, settings=IdentifySettings(method="pinv", order=order),
                                 step_volts=step, **axes)
    except MotorIdError:
        return None  # the section says the table could not be computed


def _design_view(ident: Identification, design: Mapping[str, Any] | None,
                 settings: SimulationSettings | None) -> dict[str, Any] | None:
    """The design JSON plus its closed-loop step response and mode maps on the identified model.

    The closed loop needs the design's state vector in the model; when the identified model
    has other states (e.g. a companion form), the section shows the gains and says so.
    """
    if design is None:
        return None
    from motorid.control.design_io import controller_from_json
    from motorid.control.pid import PidDesign

    view: dict[str, Any] = dict(design)
    des = controller_from_json(design)
    # the paper's ±10 V on a command in volts; on a duty cycle the identification step's level
    run = settings if settings is not None else SimulationSettings(saturation_v=default_rails(ident.model))
    try:
        view["simulation"] = _closed_loop_view(ident, des, run)
    except MotorIdError as exc:
        what = f"the {des.kind} on the {des.loop}" if isinstance(des, PidDesign) else f"the design (states " \
            f"{list(des.states)})"
        view["note"] = (f"{what} cannot be simulated on the identified model "
                        f"(states {list(ident.model.states)}): {exc.message}")
    try:
        view["mode_maps"] = _mode_maps(ident)
        view["design_gains"] = _design_gains(des)
    except MotorIdError as exc:
        view["note"] = f"{view.get('note', '')} mode map not drawn: {exc.message}".strip()
    return view


def _closed_loop_view(ident: Identification, des: Any, settings: SimulationSettings) -> dict[str, Any]:
    """The closed-loop run as the page shows it: columns, metrics, rails and load instants."""
    from dataclasses import asdict

    from motorid.simulation.closed_loop import simulate_closed_loop

    # a design in measurable coordinates (position, velocity, current…) is simulated on
    # the model re-expressed in them (simulate_closed_loop does the change of states)
    sim = simulate_closed_loop(ident.model, des, settings)
    cols = sim.columns()
    return {
        "time": cols["time"].tolist(),
        "series": {"reference": cols["reference"].tolist(), "output": cols["output"].tolist(),
                   "u (control)": cols["u"].tolist()},
        "metrics": asdict(sim.metrics),
        "output_unit": sim.output_unit,
        "reference_level": None if sim.reference_level is None else sim.reference_level.to_dict(),
        "rails_v": settings.saturation_v,
        "disturbances_s": [settings.disturbance_start_s] if settings.disturbance_v != 0 else [],
    }


def _mode_maps(ident: Identification) -> tuple[Any, ...]:
    """The mode maps of the 2nd- and 3rd-order servo plants on the report's grid."""
    import numpy as np

    from motorid.simulation.modes import mode_map, servo_plants

    kp, kv = np.linspace(*MODE_MAP_KP), np.linspace(*MODE_MAP_KV)
    return tuple(mode_map(pl, kp, kv, ModeCriteria()) for pl in servo_plants(ident.model))


def _design_gains(des: Any) -> tuple[float, float] | None:
    """The design as a point of the mode map: its own (Kp, Kv) when it is that loop, else None.

    The map's loop is ``u = sat(Kp (r − θ) − Kv θ̇)``: a design on (position, velocity) without
    integral action is exactly that loop.
    """
    if not hasattr(des, "states"):  # a PID: its filtered derivative is not the map's loop
        return None
    if tuple(des.states) == ("position", "velocity") and des.ki is None:
        return float(des.K[0]), float(des.K[1])
    return None

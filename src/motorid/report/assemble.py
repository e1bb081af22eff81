"""``motorid report`` / ``identify --report``: gather what a report shows and write the page."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from motorid._threads import single_blas_thread
from motorid.capture import Capture
from motorid.errors import MotorIdError
from motorid.identify.pipeline import Identification, IdentifySettings
from motorid.report import ReportInputs, build_report
from motorid.analysis.sweep import PAPER_LENGTHS_S, data_grid, sensitivity_table

__all__ = ["make_report"]


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
) -> str:
    """The HTML report of an identification (see :func:`motorid.report.build_report`).

    The sensitivity table is the paper's: pinv with the reduced state over 1.9/2.4/2.9 s ×
    40–120 ms, so a student sees the drift the paper reports next to the model — or, when the
    record is shorter than the paper's lengths (a fast motor), the same grid in the data's own
    time scales (:func:`motorid.analysis.sweep.data_grid`).

    Parameters
    ----------
    ident : Identification
        The identification (:func:`motorid.identify.pipeline.identify_experiment`).
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

    Returns
    -------
    str
        A complete, self-contained HTML document.
    """
    table = None
    if sweep:
        cond = ident.conditioned
        # captures without an input channel were identified with the user's step level
        step = cond.step_volts if any(c.input_v is None for c in captures.values()) else None
        try:
            order = 2 if "position" in captures else 1  # the paper's reduced state [θ, θ̇]
            axes: dict[str, Any] = {}
            if float(cond.full_time_s[-1]) < max(PAPER_LENGTHS_S):
                lengths, intervals, _ = data_grid(captures, step_volts=step)
                axes = {"lengths_s": lengths, "intervals_s": intervals}
            table = sensitivity_table(captures, settings=IdentifySettings(method="pinv", order=order),
                                      step_volts=step, **axes)
        except MotorIdError:
            table = None  # the section says the table could not be computed
    return build_report(ReportInputs(ident, captures, validation or {}, table, _design_view(ident, design), truth,
                                     title))


def _design_view(ident: Identification, design: Mapping[str, Any] | None) -> dict[str, Any] | None:
    """The design JSON plus its closed-loop step response and mode maps on the identified model.

    The closed loop needs the design's state vector in the model; when the identified model
    has other states (e.g. a companion form), the section shows the gains and says so.
    """
    if design is None:
        return None
    import tempfile

    import numpy as np

    from motorid.control.design import Design
    from motorid.simulate.closed_loop import SimulationSettings, simulate_closed_loop
    from motorid.simulate.modes import ModeCriteria, mode_map, plot_mode_maps, servo_plants

    view: dict[str, Any] = dict(design)
    model = ident.model
    des = Design.from_json(design)
    try:
        # a design in measurable coordinates (position, velocity, current…) is simulated on
        # the model re-expressed in them (simulate_closed_loop does the change of states)
        sim = simulate_closed_loop(model, des, SimulationSettings())
    except MotorIdError as exc:
        sim = None
        view["note"] = (f"the design (states {list(des.states)}) cannot be simulated on the identified model "
                        f"(states {list(model.states)}): {exc.message}")
    if sim is not None:
        cols = sim.columns()
        view["simulation"] = {
            "time": cols["time"].tolist(),
            "series": {"reference": cols["reference"].tolist(), "output": cols["output"].tolist(),
                       "u (control)": cols["u"].tolist()},
            "metrics": {k: v for k, v in sim.metrics.__dict__.items()} if hasattr(sim.metrics, "__dict__")
            else {f: getattr(sim.metrics, f) for f in sim.metrics.__dataclass_fields__},
        }
    try:
        kp = np.linspace(0.5, 60.0, 40)
        kv = np.linspace(0.0, 8.0, 40)
        maps = tuple(mode_map(pl, kp, kv, ModeCriteria()) for pl in servo_plants(model))
        with tempfile.TemporaryDirectory() as tmp:
            path = f"{tmp}/modes.png"
            plot_mode_maps(maps, path)
            with open(path, "rb") as fh:
                view["modes_png"] = fh.read()
    except MotorIdError as exc:
        view["note"] = f"{view.get('note', '')} mode map not drawn: {exc.message}".strip()
    return view

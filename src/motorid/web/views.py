"""What the page shows, computed from the library's results.

The inspect table, the model panel (its figures are the report's,
:mod:`motorid.report.figures`) and one design update (design → closed loop → figure →
mode-map marker).
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from motorid.errors import MotorIdError, OptionError
from motorid.web.tabs import CaptureEntry
from motorid.web.uploads import as_uploaded

if TYPE_CHECKING:
    from motorid.control.design import Design
    from motorid.frontdoor import IdentificationResult
    from motorid.model import MotorModel
    from motorid.simulation.closed_loop import SimulationResult
    from motorid.simulation.reference import ReferenceLevel
    from motorid.web.modemap import Marker, ModeMapView
    from motorid.web.uploads import CaptureFiles

__all__ = [
    "DesignForm",
    "DesignView",
    "SliderRanges",
    "default_roles",
    "design_update",
    "inspect_capture",
    "map_limits",
    "model_view",
    "slider_ranges",
]


def inspect_capture(cid: str, files: CaptureFiles, folder: Path) -> CaptureEntry:
    """Read one uploaded capture and guess its role as ``motorid inspect`` does.

    Parameters
    ----------
    cid : str
        Its id on the page.
    files : CaptureFiles
        Its stored files.
    folder : Path
        The upload's folder (cut from error messages).

    Returns
    -------
    CaptureEntry
        With the summary, or the one-line reason it cannot be read (role ``ignore``).
    """
    from motorid.conditioning.inspect import describe_capture
    from motorid.io import read_capture

    try:
        summary = describe_capture(read_capture(files.reader_argument()))
    except MotorIdError as exc:
        return CaptureEntry(cid, files, None, str(as_uploaded(exc, folder)), "ignore")
    role = summary.role if summary.role in ("position", "velocity", "current") and summary.step else "validation"
    return CaptureEntry(cid, files, summary, None, role)


def default_roles(entries: list[CaptureEntry]) -> dict[str, str]:
    """Each capture's role for the table: its guess, a role already taken becoming ``validation``.

    Parameters
    ----------
    entries : list of CaptureEntry
        In upload order.

    Returns
    -------
    dict
        ``cid`` → role.
    """
    taken: set[str] = set()
    roles = {}
    for e in entries:
        role = e.guessed_role
        if role in ("position", "velocity", "current"):
            if role in taken:
                role = "validation"
            taken.add(role)
        roles[e.cid] = role
    return roles


# ------------------------------------------------------------------------------------- model


def _fmt(x: Any) -> str:
    if isinstance(x, complex):
        return f"{x.real:.5g}{x.imag:+.4g}j"
    if isinstance(x, float):
        return "—" if not math.isfinite(x) else f"{x:.5g}"
    return str(x)


def model_view(fit: IdentificationResult) -> dict[str, Any]:
    """Everything the model panel shows, as strings and image URIs.

    Parameters
    ----------
    fit : IdentificationResult
        From :func:`motorid.identify`.

    Returns
    -------
    dict
        ``params`` rows (name, value, stderr, 95 % interval), ``fit`` rows, ``warnings``,
        ``reason``, ``summary`` text, ``stages`` rows, ``figures`` (title → data URI),
        ``laguerre`` (rows or None), ``sanity``, ``advice`` (how to record the next capture, one
        line, or ``None`` for captures without a scope header or a model of a paper method).
    """
    from motorid.report import figures

    model = fit.model
    ident = fit.identification
    params = []
    for name, est in fit.params.items():
        ci = "—" if est.ci95 is None else f"[{est.ci95[0]:.5g}, {est.ci95[1]:.5g}]"
        params.append((name, _fmt(est.value), _fmt(est.stderr), ci, est.unit))
    fit_rows = [(k, f"{v:.2f} %" if k.endswith("_fit_percent") else f"{100 * v:.2f} %") for k, v in fit.fit.items()]
    figs: dict[str, str] = {}
    errors: list[str] = []

    def add(title: str, make: Any) -> None:
        try:
            figs[title] = figures.data_uri(make())
        except Exception as exc:  # a figure that cannot be drawn says why, as in the report
            errors.append(f"{title}: not available ({exc})")

    add("Measured vs model step response, with residuals", lambda: figures.step_fit(model, ident.conditioned))
    add("Poles and zeros", lambda: figures.pole_zero(model))
    laguerre = None
    mk = ident.candidates.get("markov")
    if mk is not None and "hankel_singular_values_scaled" in mk.extras:
        ex = mk.extras
        add("Order evidence: Hankel singular values",
            lambda: figures.hankel_values(ex["hankel_singular_values_scaled"], ex["hankel_singular_values_raw"],
                                          ex.get("hankel_noise_floor")))
        if ex.get("markov_basis") == "laguerre":
            laguerre = {
                "pole": f"{ex['laguerre_pole']:.4g}",
                "terms": ex["laguerre_terms"],
                "rows": [(k, f"{g:.5g}", f"{sd:.3g}") for k, (g, sd) in
                         enumerate(zip(ex["laguerre_coefficients"], ex["laguerre_coefficients_std"], strict=False))],
                "note": str(ex.get("markov_choice", "")),
            }
    advice = fit.advice_line()
    stages = [(st.get("stage", ""), st.get("method", ""), st.get("order", ""),
               f"{_fmt(st.get('dc_gain', ''))} {model.dc_gain_unit}" if st.get("dc_gain") is not None else "",
               _fmt(st.get("time_constant", "")),
               "" if st.get("velocity_nrmse") is None else f"{100 * st['velocity_nrmse']:.2f} %",
               st.get("evidence", st.get("failed", ""))) for st in fit.stages]
    return {
        "method": model.method,
        "order": model.order,
        "states": ", ".join(model.states),
        "params": params,
        "fit": fit_rows,
        "warnings": list(fit.warnings) + errors,
        "reason": fit.reason,
        "summary": fit.summary(advice=False) + ("" if advice is None else f"\nadvice: {advice}"),
        "stages": stages,
        "figures": figs,
        "laguerre": laguerre,
        "sanity": "all passed" if fit.sanity.passed else "FAILED (see the warnings)",
        "advice": advice,
    }


# ------------------------------------------------------------------------------------ design


@dataclass(frozen=True, slots=True)
class SliderRanges:
    """The design panel's ranges and examples for one model (ωn scaled by its time constant τ).

    Attributes
    ----------
    damping, wn : tuple of float
        ``(min, max, step, start)`` of each slider.
    duration_s : float
        Record length of the simulation at the start.
    observer_example : str
        One observer pole per state, well left of the controller's.
    reference : ReferenceLevel or None
        The reference step at the start, in the output's unit, and where it comes from
        (:func:`motorid.simulation.reference.default_reference_level`).
    input_unit : str
        The command's unit (V; pwm or % for a logged duty cycle).
    rails : float
        The actuator rails at the start, in ``input_unit``
        (:func:`motorid.simulation.reference.default_rails`).
    """

    damping: tuple[float, float, float, float]
    wn: tuple[float, float, float, float]
    duration_s: float
    observer_example: str = ""
    reference: ReferenceLevel | None = None
    input_unit: str = "V"
    rails: float = 10.0


def slider_ranges(model: MotorModel) -> SliderRanges:
    """ζ from 0.2 to 2 (0.7 to start); ωn from 0.5/τ to 8/τ (2/τ to start); observer poles from 10 ωn.

    Parameters
    ----------
    model : MotorModel
        The identified model.

    Returns
    -------
    SliderRanges
        ``(min, max, step, start)`` per slider, a record length of 8/(ζωn) at the start and an
        example of observer poles (one per state).
    """
    tau = model.first_order().time_constant_s
    tau = tau if math.isfinite(tau) and tau > 0 else 1.0
    lo, hi = 0.5 / tau, 8.0 / tau
    start = 2.0 / tau
    step = float(f"{(hi - lo) / 300:.2g}")
    dur = float(f"{max(8.0 / (0.7 * start), 0.5):.2g}")
    observer = ",".join(f"{-(10 + 2 * i) * start:.3g}" for i in range(model.A.shape[0]))
    from motorid.control.design import default_output
    from motorid.model.units import channel_unit
    from motorid.simulation.reference import default_rails, default_reference_level

    # the design's output by default: its unit, its level
    output = default_output(model)
    unit = channel_unit(model.units, "input")
    rails = default_rails(model)
    return SliderRanges((0.2, 2.0, 0.01, 0.7), (float(f"{lo:.3g}"), float(f"{hi:.3g}"), step, float(f"{start:.3g}")),
                        dur, observer, default_reference_level(model, output), unit, rails)


@dataclass(frozen=True, slots=True)
class DesignForm:
    """The design panel's inputs.

    Attributes
    ----------
    damping, wn : float
        ζ and ωn [rad/s].
    integral : bool
        Integral action.
    observer_poles : str
        Comma-separated observer poles (empty: no observer).
    saturation_v : float or None
        Actuator rails ± of the simulation and the mode map, in the input's unit (None: none; the map
        then uses the page's starting rails, :attr:`SliderRanges.rails`).
    level_v : float or None
        Reference step in the output's unit (None: the model's default,
        :func:`motorid.simulation.reference.default_reference_level`).
    duration_s : float
        Record length [s].
    dt_s : float
        Control interval [s]: the simulation's, and the downloaded controller code's.
    """

    damping: float
    wn: float
    integral: bool = False
    observer_poles: str = ""
    saturation_v: float | None = 10.0
    level_v: float | None = None
    duration_s: float = 3.0
    dt_s: float = 1e-3

    def simulate_options(self) -> dict[str, Any]:
        """The :func:`motorid.simulate` options of this form (the report simulates the same run).

        Returns
        -------
        dict
            ``duration_s``, ``level_v``, ``saturation``, ``dt_s``.
        """
        return {"duration_s": self.duration_s, "level_v": self.level_v, "saturation": self.saturation_v,
                "dt_s": self.dt_s}

    def fields(self) -> dict[str, str]:
        """The form fields that :meth:`from_fields` reads back into this form.

        Returns
        -------
        dict
            Field name → text (``repr`` of the floats: the same numbers come back).
        """
        return {"damping": repr(self.damping), "wn": repr(self.wn), "integral": "on" if self.integral else "",
                "observer_poles": self.observer_poles,
                "saturation": "" if self.saturation_v is None else repr(self.saturation_v),
                "level": "" if self.level_v is None else repr(self.level_v), "duration": repr(self.duration_s),
                "dt": repr(self.dt_s)}

    @classmethod
    def from_fields(cls, fields: Mapping[str, str]) -> DesignForm:
        """Read the form fields.

        ``damping``, ``wn``, ``integral``, ``observer_poles``, ``saturation``, ``level``,
        ``duration``, ``dt``.

        Raises
        ------
        OptionError
            A field that is not a number (the message names it).
        """
        def number(name: str, default: float | None, *, positive: bool = False) -> float | None:
            text = (fields.get(name) or "").strip()
            if not text:
                return default
            try:
                value = float(text)
            except ValueError:
                raise OptionError(f"{name}={text!r}: give a number") from None
            if not math.isfinite(value) or (positive and value <= 0):
                raise OptionError(f"{name}={text!r}: give a finite number{' > 0' if positive else ''}")
            return value

        damping = number("damping", 0.7, positive=True)
        wn = number("wn", 1.0, positive=True)
        level = number("level", None)
        duration = number("duration", 3.0, positive=True)
        dt = number("dt", 1e-3, positive=True)
        assert damping is not None and wn is not None and duration is not None and dt is not None
        if duration > 120:
            raise OptionError(f"duration={duration:g}: at most 120 s on this page")
        if not dt <= min(1.0, duration / 10):
            raise OptionError(f"dt={dt:g}: the control interval must be at most 1 s and a tenth of the record")
        return cls(damping, wn, fields.get("integral", "") in ("on", "true", "1"),
                   (fields.get("observer_poles") or "").strip(), number("saturation", None, positive=True),
                   level, duration, dt)


@dataclass(frozen=True, slots=True)
class DesignView:
    """One update of the design panel.

    Attributes
    ----------
    design : Design
    simulation : SimulationResult
    plot : str
        The closed-loop figure (the report's :func:`motorid.report.figures.closed_loop`), data URI.
    markers : list of Marker
        The design on each mode map.
    point : tuple of (float, float, str)
        Kp, Kv and what they are.
    elapsed_ms : float
        Wall time of the update on the server (design + simulation + figure + marker) [ms].
    cpu_ms : float
        CPU time the update's thread spent [ms]: the work itself, whatever else the machine runs.
    """

    design: Design
    simulation: SimulationResult
    plot: str
    markers: list[Marker]
    point: tuple[float, float, str]
    elapsed_ms: float
    cpu_ms: float


def design_update(model: MotorModel, form: DesignForm, maps: ModeMapView | None,
                  canvas: Any = None, *, robust_samples: int = 0) -> DesignView:
    """Design, simulate, draw and mark one slider position.

    The check on the plausible motors is not part of a move by default: the page asks for it
    in a request of its own once the move is shown (:func:`robust_update`), so that a move
    stays within its CPU budget.

    Parameters
    ----------
    model : MotorModel
        The identified model.
    form : DesignForm
        The panel's inputs.
    maps : ModeMapView or None
        The drawn mode maps (None: no marker).
    canvas : ClosedLoopCanvas, optional
        The tab's closed-loop figure, redrawn in place (default: a new one).
    robust_samples : int
        Plausible motors the design is checked on (0: none, the page's default).

    Returns
    -------
    DesignView

    Raises
    ------
    OptionError, ControlDesignError
        A design that cannot be made (bad observer poles, …).
    """
    import motorid as mi
    from motorid.report import figures
    from motorid.web.modemap import design_point, mark

    t0, c0 = time.perf_counter(), time.thread_time()
    des = _design(model, form, robust_samples)
    sim = mi.simulate(model, des, **form.simulate_options())
    plot = _plot(des, sim, form, canvas if canvas is not None else figures.ClosedLoopCanvas())
    kp, kv, what = design_point(model, des, form.damping, form.wn)
    markers = mark(maps, kp, kv) if maps is not None else []
    return DesignView(des, sim, plot, markers, (kp, kv, what), 1e3 * (time.perf_counter() - t0),
                      1e3 * (time.thread_time() - c0))


def _design(model: MotorModel, form: DesignForm, robust_samples: int) -> Any:
    """The form's design (:func:`motorid.design`, as ``motorid design`` makes it)."""
    import motorid as mi
    from motorid.control.feedback import parse_poles

    observer = None
    if form.observer_poles:
        observer = [complex(p) for p in parse_poles(form.observer_poles, "observer poles")]
    return mi.design(model, damping=form.damping, wn=form.wn, integral=form.integral, observer_poles=observer,
                     robust_samples=robust_samples)


def _plot(des: Any, sim: SimulationResult, form: DesignForm, canvas: Any) -> str:
    """The closed-loop figure of a run (with the plausible motors' band when ``des`` has one), data URI."""
    from motorid.report import figures

    cols = sim.columns()
    series = {"reference": cols["reference"], f"output ({sim.output})": cols["output"], "u (control)": cols["u"]}
    series.update(_robust_band(des, cols["time"], form, sim))
    in_unit = sim.input_unit
    sat = f", rails ±{form.saturation_v:g} {in_unit}" if form.saturation_v else ""
    return figures.data_uri(canvas.svg(cols["time"], series,
                                       f"closed loop: ζ = {form.damping:g}, ωn = {form.wn:g} rad/s{sat}",
                                       output_unit=sim.output_unit, input_unit=in_unit), "svg+xml")


#: Plausible motors the page checks a design on (the command line checks 2000), in a request of
#: its own after each slider move (:func:`robust_update`): about 30 ms of CPU, a third of a move's.
WEB_ROBUST_SAMPLES = 100


@dataclass(frozen=True, slots=True)
class RobustView:
    """The check of one design on the plausible motors, shown after the slider move.

    Attributes
    ----------
    design : Design
        The design with its :attr:`~motorid.control.design.Design.robust` check.
    plot : str or None
        The closed-loop figure redrawn with the plausible motors' band (a step without rails
        only), data URI; None when the move's figure stays.
    elapsed_ms, cpu_ms : float
        Wall and CPU time of the check on the server [ms].
    """

    design: Design
    plot: str | None
    elapsed_ms: float
    cpu_ms: float


def robust_update(model: MotorModel, form: DesignForm, canvas: Any = None, *,
                  shown: SimulationResult | None = None) -> RobustView:
    """Check a slider position's design on :data:`WEB_ROBUST_SAMPLES` plausible motors.

    Parameters
    ----------
    model : MotorModel
        The identified model.
    form : DesignForm
        The panel's inputs (those of the move being shown).
    canvas : ClosedLoopCanvas, optional
        The tab's closed-loop figure (default: a new one).
    shown : SimulationResult, optional
        The closed-loop run the move showed for ``form`` (the check does not change the
        controller, so its run is the same): redrawn with the band instead of run again.

    Returns
    -------
    RobustView

    Raises
    ------
    OptionError, ControlDesignError
        A design that cannot be made.
    """
    import motorid as mi
    from motorid.report import figures

    t0, c0 = time.perf_counter(), time.thread_time()
    des = _design(model, form, WEB_ROBUST_SAMPLES)
    plot = None
    if _robust_band(des, [0.0], form, None):  # the band is drawn: the move's run again, with it
        sim = shown if shown is not None else mi.simulate(model, des, **form.simulate_options())
        plot = _plot(des, sim, form, canvas if canvas is not None else figures.ClosedLoopCanvas())
    return RobustView(des, plot, 1e3 * (time.perf_counter() - t0), 1e3 * (time.thread_time() - c0))


def _robust_band(des: Any, time_s: Any, form: DesignForm, sim: SimulationResult | None) -> dict[str, Any]:
    """The output's 95 % band over the plausible motors, for the plot (scaled to ``sim``'s reference level).

    A step without rails only: the band is the linear loop's.  ``sim`` None: whether there is one.
    """
    import numpy as np

    robust = getattr(des, "robust", None)
    if robust is None or not robust.band[0] or form.saturation_v is not None:
        return {}
    t = np.asarray(robust.band[0])
    if sim is None:
        return {"band": None}
    level = sim.reference_level.value if sim.reference_level is not None else float(form.level_v or 0.0)
    return {f"plausible motors {q}": level * np.interp(time_s, t, np.asarray(robust.band[i]), right=np.nan)
            for i, q in ((1, "2.5 %"), (3, "97.5 %"))}


def map_limits(model: MotorModel, ranges: SliderRanges) -> tuple[float, float]:
    """Upper ends of the mode map's gain axes: 1.1 × the (Kp, Kv) of the sliders' far corner.

    Parameters
    ----------
    model : MotorModel
        The identified model.
    ranges : SliderRanges
        The sliders.

    Returns
    -------
    (float, float)
        ``kp_max``, ``kv_max`` (positive).
    """
    from motorid.control.feedback import place_gains, poles_from_damping
    from motorid.simulation.modes import servo_plants

    second = servo_plants(model)[0]
    poles, _ = poles_from_damping(ranges.damping[1], ranges.wn[1], 2)
    k = place_gains(second.A, second.B, poles).ravel()
    kp = abs(float(k[0])) if math.isfinite(k[0]) and k[0] != 0 else 1.0
    kv = abs(float(k[1])) if math.isfinite(k[1]) and k[1] != 0 else 1.0
    return 1.1 * kp, 1.1 * kv

"""Command-line front end of controller design and closed-loop prediction.

Thin: parse, call :mod:`motorid.control` / :mod:`motorid.simulation`, print, write files.  User
mistakes raise :class:`~motorid.errors.MotorIdError` subclasses; ``motorid.cli.main`` turns them
into one line and exit code 2.  Register everything on the main app with :func:`register`.
"""


import json
import math
import time
from contextlib import nullcontext
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, cast

import typer

from motorid.errors import MotorIdError, OptionError
from motorid.numfmt import metric_name, roots_text, sig
from motorid.options import SIMULATE, TRAINER_PRESETS, defaults

if TYPE_CHECKING:
    import numpy as np

# numpy, the model/design loaders and the writers load inside each command (``motorid
# --help`` imports none of them)

__all__ = [
    "design",
    "model_app",
    "model_from_params_cmd",
    "model_from_step_test_cmd",
    "modes",
    "register",
    "simulate",
]

model_app = typer.Typer(no_args_is_help=True, help="Build a motor model without identification.")



def _check_outputs(outputs: list[tuple[Path | None, str, str | None]], force: bool) -> None:
    """Refuse, before any work, output paths that cannot be written as given.

    Each entry is ``(path, option, suffix)``: the path must not be a folder, its folder must
    exist, and with a suffix (``.png``) it must end in it, so the file written is exactly the
    path checked for ``--force`` (matplotlib would append ``.png`` to a bare name).
    """
    for path, option, suffix in outputs:
        if path is None:
            continue
        if suffix is not None and path.suffix.lower() != suffix:
            raise OptionError(f"{option} {path}: the file is written as {suffix[1:].upper()}; "
                              f"give a file name ending in {suffix}")
        if path.is_dir():
            raise OptionError(f"{option} {path} is a folder; give a file name")
        if not path.parent.is_dir():
            raise OptionError(f"{option} {path}: the folder {path.parent} does not exist; create it first")
    from motorid.io import check_writable

    check_writable([p for p, _, _ in outputs], force=force)


def _check_numbers(values: dict[str, float | None], positive: tuple[str, ...] = ()) -> None:
    """Refuse, naming the option, a non-finite number (or one ≤ 0 among ``positive``)."""
    for option, v in values.items():
        if v is None:
            continue
        if not math.isfinite(v):
            raise OptionError(f"{option} must be a finite number, got {v}")
        if option in positive and not v > 0:
            raise OptionError(f"{option} must be greater than 0, got {v:g}")


def _plot_to(outs, target: Path, plot, *args, **kwargs) -> None:
    """Draw a figure into the temporary file of ``target`` (``outs``: :func:`motorid.io.atomic_outputs`)."""
    from motorid.io.atomic import write_error

    try:
        plot(*args, outs.path(target), **kwargs)
    except MotorIdError:  # already one line (OutputWriteError is an OSError too)
        raise
    except OSError as exc:
        raise write_error(target, exc) from None


def _bar(description: str, total: float | None = None):
    """The command line's progress bar (``--progress`` lives on the main app; imported late: app imports this)."""
    from motorid.cli.app import _bar as app_bar

    return app_bar(description, total)


def _floats(text: str | None, option: str) -> tuple[float, ...] | None:
    if text is None:
        return None
    try:
        vals = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise OptionError(f"{option} must be comma-separated numbers, got {text!r}") from None
    if not vals or not all(math.isfinite(v) for v in vals):
        raise OptionError(f"{option} must be finite numbers, got {text!r}")
    return vals


def _print_model(model, out: Path | None) -> None:
    import numpy as np

    def text(a: Any) -> str:
        return np.array2string(np.asarray(a, dtype=float), formatter={"float_kind": lambda v: sig(float(v))})

    typer.echo(f"A = {text(model.A)}")
    typer.echo(f"B = {text(np.ravel(model.B))}")
    typer.echo("states: " + ", ".join(model.states) + " (position volts, tacho volts)")
    if out is not None:
        typer.echo(f"model JSON: {out}")


@model_app.command("from-params")
def model_from_params_cmd(
    km: Annotated[float, typer.Option("--km", help="Motor gain km, rpm/V (report: 249.3).")],
    kt: Annotated[float, typer.Option("--kT", help="Tacho gain kT, V/rpm (report: 3.61e-3).")],
    gear: Annotated[str, typer.Option("--gear", help="Reducer ratio kμ, e.g. 1/36.")],
    k0: Annotated[float, typer.Option("--k0", help="Position gain k0, V/(rpm·s) (report: 0.25).")],
    tm: Annotated[float, typer.Option("--Tm", help="Mechanical time constant Tm, s (report: 0.55).")],
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the model JSON here.")] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
) -> None:
    """The lab report's state equations (eqs. 24-29) from physical parameters."""
    from motorid.control.params import MotorParams, model_from_params, parse_ratio
    from motorid.io import atomic_outputs

    _check_outputs([(json_out, "--json", None)], force)
    model = model_from_params(MotorParams(km=km, kT=kt, gear=parse_ratio(gear), k0=k0, Tm_s=tm))
    if json_out is not None:
        with atomic_outputs(exclusive=not force) as outs:
            outs.write_text(json_out, model.to_json_text() + "\n")
    _print_model(model, json_out)


@model_app.command("from-step-test")
def model_from_step_test_cmd(
    v_tacho_ss: Annotated[float, typer.Option("--v-tacho-ss", help="Steady tacho volts (report: 9).")],
    u_step: Annotated[float, typer.Option("--u-step", help="Step input volts (report: 10).")],
    tm: Annotated[float, typer.Option("--Tm", help="Time to 63.2 % of the tacho step, s (report: 0.55).")],
    delta_theta: Annotated[float, typer.Option("--delta-theta", help="Sawtooth height, V (report: 15).")],
    delta_t: Annotated[float, typer.Option("--delta-t", help="Sawtooth period, s (report: 0.867).")],
    gear: Annotated[str, typer.Option("--gear", help="Reducer ratio kμ, e.g. 1/36.")],
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the model JSON here.")] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite an existing file.")] = False,
) -> None:
    """The lab report's model from its step-test measurements (eqs. 1-19)."""
    from motorid.control.params import model_from_params, params_from_step_test, parse_ratio
    from motorid.io import atomic_outputs

    _check_outputs([(json_out, "--json", None)], force)
    p = params_from_step_test(v_tacho_ss=v_tacho_ss, u_step=u_step, Tm_s=tm, delta_theta_v=delta_theta,
                              delta_t_s=delta_t, gear=parse_ratio(gear))
    typer.echo(f"km = {sig(p.km)} rpm/V, kT = {sig(p.kT)} V/rpm, k0 = {sig(p.k0)}, kμ = {sig(p.gear)}, "
               f"Tm = {sig(p.Tm_s)} s")
    model = model_from_params(p)
    if json_out is not None:
        with atomic_outputs(exclusive=not force) as outs:
            outs.write_text(json_out, model.to_json_text() + "\n")
    _print_model(model, json_out)


def design(
    model_file: Annotated[Path, typer.Argument(help="Model JSON (motorid identify --json or model from-params).")],
    poles: Annotated[str | None, typer.Option("--poles", help="Closed-loop poles, e.g. -3+2j,-3-2j.")] = None,
    damping: Annotated[float | None, typer.Option("--damping", help="Damping ζ (with --k2 or --wn).")] = None,
    k2: Annotated[float | None,
                  typer.Option("--k2", help="Velocity gain k2; k1 follows from ζ (report eqs. 32-36).")] = None,
    wn: Annotated[float | None, typer.Option("--wn", help="Natural frequency ωn, rad/s.")] = None,
    settling_time: Annotated[float | None, typer.Option("--settling-time", help="2 % settling time, s.")] = None,
    overshoot: Annotated[float | None, typer.Option("--overshoot", help="Percent overshoot.")] = None,
    integral: Annotated[bool, typer.Option("--integral", help="Integral action ż = y − r (report §3).")] = False,
    ki: Annotated[float | None, typer.Option("--ki", help="Given integral gain (Routh-checked).")] = None,
    integral_pole: Annotated[float | None, typer.Option(
        "--integral-pole", help="Extra real pole placed with the integrator.")] = None,
    observer_poles: Annotated[str | None, typer.Option(
        "--observer-poles", help="Observer poles, e.g. -50,-40: one per state for a full observer from --output, "
        "one per state the sensors do not measure for a reduced-order one.")] = None,
    sensors: Annotated[str | None, typer.Option(
        "--sensors", help="What the rig measures, e.g. position,velocity (default: the model's channels); "
        "the other states are estimated.")] = None,
    output: Annotated[str | None, typer.Option("--output", help="Measured channel y (default position).")] = None,
    robust: Annotated[float | None, typer.Option(
        "--robust", help="Tune for robustness: tighten the design's own settling time and overshoot until this "
        "fraction of the plausible motors meets --settling-time/--overshoot (e.g. 0.95).")] = None,
    robust_samples: Annotated[int, typer.Option(
        "--robust-samples", help="Plausible motors, drawn from the model's uncertainty, the design is checked on "
        "(0: no check).")] = 2000,
    pid: Annotated[bool, typer.Option(
        "--pid", help="A PID instead of state feedback: velocity PI, position PD (PID with --pid-integral), "
                      "tuned on the model (SIMC, or --pid-rule placement with --damping and --wn).")] = False,
    pid_loop: Annotated[str | None, typer.Option(
        "--pid-loop", help="velocity (a PI on the tacho; default) or position (a PD on the position).")] = None,
    pid_rule: Annotated[str | None, typer.Option(
        "--pid-rule", help="simc (Skogestad's rules; default) or placement (poles from --damping and --wn).")] = None,
    pid_integral: Annotated[bool, typer.Option(
        "--pid-integral", help="Integral action on the position loop (a PID instead of a PD).")] = False,
    tau_c: Annotated[float | None, typer.Option(
        "--tau-c", help="SIMC's closed-loop time constant τc, s (default max(θ, 0.25 τ)).")] = None,
    derivative_filter: Annotated[float | None, typer.Option(
        "--derivative-filter", help="N of the derivative filter Td/N (default 10).")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the Design JSON here.")] = None,
    discrete: Annotated[float | None, typer.Option(
        "--discrete", help="Sample the controller every TS seconds (python-control c2d; with zoh an observer is "
                           "placed on the motor as sampled); the JSON gains 'discrete' with its difference "
                           "equations.")] = None,
    discrete_method: Annotated[str | None, typer.Option(
        "--discrete-method", help="How to discretise: zoh (default), foh, tustin, euler or backward_diff.")] = None,
    emit: Annotated[str | None, typer.Option(
        "--emit", help="Write the sampled controller as code: c, python or matlab (to the terminal, the rest "
                       "of the printout then going to stderr, or to --emit-file).")] = None,
    emit_file: Annotated[Path | None, typer.Option("--emit-file", help="Write the --emit code here.")] = None,
    saturation: Annotated[float | None, typer.Option(
        "--saturation", help="With --discrete: the actuator's rails ±, in the input's unit; the sampled controller "
                             "clamps its command, feeds its observer the clamped one and holds its integrator against "
                             "them, as simulate --saturation runs it (zoh only).")] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite existing files.")] = False,
) -> None:
    """State feedback, integral action and observer (Tsiolakis 2022, §2-4) or a PID (--pid); code for a controller."""
    from motorid import frontdoor
    from motorid.model.serialize import load_model

    _check_outputs([(json_out, "--json", None), (emit_file, "--emit-file", None)], force)
    pid_options = {"--pid-loop": pid_loop is not None, "--pid-rule": pid_rule is not None,
                   "--pid-integral": pid_integral, "--tau-c": tau_c is not None,
                   "--derivative-filter": derivative_filter is not None}
    if pid:
        from motorid.control.pid import refuse_state_feedback_options

        refuse_state_feedback_options({
            "--poles": poles is not None, "--k2": k2 is not None, "--settling-time": settling_time is not None,
            "--overshoot": overshoot is not None, "--integral": integral, "--ki": ki is not None,
            "--integral-pole": integral_pole is not None, "--observer-poles": observer_poles is not None,
            "--output": output is not None, "--sensors": sensors is not None, "--robust": robust is not None})
        _check_code_options(discrete, discrete_method, emit, emit_file, saturation)
        _design_pid(model_file, json_out, force, pid_loop, pid_rule, pid_integral, tau_c, derivative_filter, damping,
                    wn, code=(discrete, discrete_method, emit, emit_file), rails=saturation)
        return
    given = next((flag for flag, on in pid_options.items() if on), None)
    if given is not None:
        raise OptionError(f"{given} goes with --pid")
    _check_code_options(discrete, discrete_method, emit, emit_file, saturation)
    # code on the terminal is the standard output alone (``> controller.c``); the printout goes to stderr
    code_to_stdout = emit is not None and emit_file is None

    def say(text: str) -> None:
        typer.echo(text, err=code_to_stdout)

    d = frontdoor.design(  # checks the options, then reads the model (named in errors about it)
        model_file, poles=poles, damping=damping, wn=wn, k2=k2, settling_time=settling_time, overshoot=overshoot,
        integral=integral, ki=ki, integral_pole=integral_pole, observer_poles=observer_poles, output=output,
        robust_samples=robust_samples, sensors=sensors, robust_fraction=robust)
    model = load_model(model_file)  # for the sampled controller's code
    if d.model_states is not None:
        say("states: the model's " + ", ".join(d.model_states) + " re-expressed as the measured "
            + ", ".join(d.states) + " (gains on the model's own states: K_model in the JSON)")
    for i, k in enumerate(d.K):
        say(f"k{i + 1} = {sig(k)}    ({d.states[i]})")
    estimated = set(d.reduced.estimated) if d.reduced is not None else set()
    say("gains per sensor: " + ", ".join(f"k_{name} = {sig(g)} {unit}" + (" (on its estimate)" if name in
                                                                               estimated else "")
                                                for name, g, unit in d.sensor_gains()))
    if d.reduced is not None:
        r = d.reduced
        say(f"sensors: {', '.join(r.measured)}; {', '.join(r.estimated)} estimated by a reduced-order observer "
                   f"(poles {roots_text(r.poles)}; ẇ = F w + G·[{', '.join(r.measured)}] + H u, "
                   f"{', '.join(r.estimated)} = w + L·[{', '.join(r.measured)}]; F, G, H, L in the JSON)")
    elif d.sensors is not None:
        say(f"sensors: {', '.join(d.sensors)}")
    kr_unit, ki_unit = d.reference_units()
    if d.kr is not None:
        say(f"kr = {sig(d.kr)} {kr_unit}")
    if d.ki is not None:
        say(f"ki = {sig(d.ki)} {ki_unit}")
    cl_poles = sorted(d.closed_loop_poles, key=lambda p: (p.real, p.imag))
    say("closed-loop poles: " + roots_text(cl_poles))
    if d.L is not None:
        # design_controller sets L, observer_poles and output_feedback_poles together
        say("L = [" + ", ".join(sig(v) for v in d.L) + "]")
        say("observer poles: " + roots_text(cast("np.ndarray", d.observer_poles)))
        ofb_poles = sorted(cast("np.ndarray", d.output_feedback_poles), key=lambda p: (p.real, p.imag))
        say("plant + observer + feedback poles (separation): " + roots_text(ofb_poles))
    say("Routh-Hurwitz: " + "; ".join(d.routh))
    if d.margins is not None:
        say("margins: " + d.margins.text())
    if d.robust is not None:
        say("robust: " + d.robust.text())
    if d.dead_zone_v is not None:
        info = d.dead_zone_info()
        bound = info["steady_state_error_bound_v"]
        from motorid.model.units import channel_unit

        say(f"dead-zone: u0 = {sig(d.dead_zone_v)} {model.input_unit} in the model"
            + ("" if bound is None else
               f"; without compensation a position step may stop anywhere within ±{sig(bound)} "
               f"{channel_unit(model.units, 'position')} (u0 / k_position)")
            + "; simulate --compensate-dead-zone adds u0·sign(u) to the command (inverse dead-zone)")
    for w in d.warnings:
        say(f"warning: {w}")
    from motorid.control.emit import discretise_design

    _write_with_code(d.to_json(), lambda ts, how: discretise_design(model, d, ts, how, rails=saturation), model_file,
                     json_out, force, discrete, discrete_method, emit, emit_file, say)


def _write_with_code(data: dict, discretised, model_file: Path, json_out: Path | None, force: bool,
                     discrete: float | None, discrete_method: str | None, emit: str | None, emit_file: Path | None,
                     say) -> None:
    """The design JSON (with ``discrete``) and the emitted code, written together or not at all.

    ``discretised(ts, method)`` samples the controller (a DiscreteController); ``say`` prints
    the summary lines (to stderr when the code goes to the terminal).
    """
    from motorid.control.emit import emit as emit_code
    from motorid.io import atomic_outputs

    code = None
    if discrete is not None:
        dc = discretised(discrete, discrete_method or "zoh")
        data["discrete"] = dc.to_json()
        _print_discrete(dc, say)
        if emit is not None:
            code = emit_code(dc, emit, source=f"From: motorid design {model_file.name} --discrete {discrete:g} "
                                              f"--discrete-method {dc.method}")
    with atomic_outputs(exclusive=not force) as outs:  # the JSON and the code appear together, or none
        if json_out is not None:
            outs.write_text(json_out, json.dumps(data, indent=2) + "\n")
        if emit_file is not None and code is not None:
            outs.write_text(emit_file, code)
    if json_out is not None:
        say(f"design JSON: {json_out}")
    if emit_file is not None:
        say(f"{_LANGUAGE_NAMES[cast(str, emit)]} code: {emit_file}")
    elif code is not None:
        typer.echo(code, nl=False)


#: How the printout names each --emit language.
_LANGUAGE_NAMES = {"c": "C", "python": "Python", "matlab": "MATLAB"}


def _check_code_options(discrete: float | None, method: str | None, emit: str | None, emit_file: Path | None,
                        rails: float | None = None) -> None:
    """Refuse, before any work, the code options that do not go together or name nothing known."""
    from motorid.control.emit import LANGUAGES, METHODS, check_rails

    _check_numbers({"--discrete": discrete, "--saturation": rails}, positive=("--discrete", "--saturation"))
    if rails is not None and discrete is None:
        raise OptionError("--saturation needs --discrete TS: the rails are those of the sampled controller's code "
                          "(simulate --saturation runs a design with rails)")
    check_rails(rails, method or "zoh")
    if method is not None and method not in METHODS:
        raise OptionError(f"--discrete-method {method!r}: use one of {', '.join(METHODS)}")
    if emit is not None and emit not in LANGUAGES:
        raise OptionError(f"--emit {emit!r}: use one of {', '.join(LANGUAGES)}")
    if discrete is None:
        for given, option in ((method, "--discrete-method"), (emit, "--emit")):
            if given is not None:
                raise OptionError(f"{option} needs --discrete TS, the sampling interval in seconds")
    if emit_file is not None and emit is None:
        raise OptionError("--emit-file needs --emit c, python or matlab")


def _print_discrete(dc, say) -> None:
    """The sampled controller's summary and its sample-rate limits (``dc``: a DiscreteController)."""
    line = f"discrete controller: TS = {sig(dc.ts_s)} s ({sig(1 / dc.ts_s)} Hz), {dc.description()}"
    if dc.fastest_pole_rad_s is not None:
        line += (f"; fastest loop pole |p| = {sig(dc.fastest_pole_rad_s)} rad/s, TS·|p| = "
                 f"{sig(dc.ts_s * dc.fastest_pole_rad_s)} (rule of thumb ≤ 0.2), Nyquist limit TS < π/|p| = "
                 f"{sig(dc.ts_max_s)} s")
    if dc.loop_spectral_radius is not None:
        line += f"; sampled loop's largest |z| = {sig(dc.loop_spectral_radius)}"
    if dc.rails is not None:
        line += (f"; its command clamped to ±{sig(dc.rails)} {dc.units.get('u', '')}".rstrip()
                 + (", the integrator held against the rails" if dc.integrator is not None else "")
                 + (", the observer fed the clamped command" if dc.applied_column().any() else ""))
    say(line)
    for w in dc.warnings:
        say(f"warning: {w}")




def _design_pid(model_file: Path, json_out: Path | None, force: bool, loop: str | None, rule: str | None,
                integral: bool, tau_c: float | None, derivative_filter: float | None, damping: float | None,
                wn: float | None, code: tuple[float | None, str | None, str | None, Path | None] = (None,) * 4,
                rails: float | None = None) -> None:
    """``motorid design --pid``: tune, print the gains, the controller, margins, poles and a step's metrics.

    ``code``: ``--discrete``, ``--discrete-method``, ``--emit``, ``--emit-file``; ``rails``: ``--saturation``.
    """
    discrete, discrete_method, emit, emit_file = code
    code_to_stdout = emit is not None and emit_file is None

    def say(text: str) -> None:
        typer.echo(text, err=code_to_stdout)

    from motorid import frontdoor
    from motorid.model.serialize import load_model
    from motorid.model.units import channel_unit
    from motorid.options import DESIGN_PID, defaults
    from motorid.simulation.closed_loop import step_check

    given = {"loop": loop, "rule": rule, "tau_c": tau_c, "derivative_filter": derivative_filter,
             "damping": damping, "wn": wn}
    p = frontdoor.design_pid(model_file, **{**defaults(DESIGN_PID), **{
        k: v for k, v in given.items() if v is not None}, "integral": integral})
    model = load_model(model_file)  # for the step check and the sampled controller's code
    how = "SIMC (Skogestad 2003)" if p.rule == "simc" else "pole placement"
    say(f"{p.kind} on the {p.loop} ({p.output_unit}), tuned by {how} on "
               f"{p.approximation.text(p.output_unit, channel_unit(p.model_units, 'input'))}"
               + (f", τc = {sig(p.tau_c_s)} s" if p.tau_c_s is not None else ""))
    say("gains: " + ", ".join(f"{name} = {sig(v)} {unit}" for name, v, unit in p.gains()))
    say(f"u = kp·(r − y) + ki·∫(r − y)dt − kd·s/(tf·s + 1)·y   (y = {p.measured_signal}; "
               "the derivative acts on the measurement)")
    from motorid.model.notation import poly_text

    c = p.tf()
    say(f"C(s) = ({poly_text(c.num[0][0])}) / ({poly_text(c.den[0][0])})   "
               "(python-control: PidDesign.tf(); PidDesign.system() takes r and y)")
    if p.margins is not None:
        say("margins: " + p.margins.text())
    delay = f", the {sig(model.delay_s)} s dead time by a Padé approximant" if model.delay_s > 0 else ""
    cl = sorted(p.closed_loop_poles, key=lambda z: (z.real, z.imag))
    say(f"closed-loop poles (full model{delay}): " + roots_text(cl))
    res = step_check(model, p)
    m = res.metrics
    settled = f"{sig(m.settling_time_s)} s" if math.isfinite(m.settling_time_s) else "not within the record"
    say(f"step response (simulated, no rails): overshoot {sig(m.overshoot_pct)} %, settling time (2 %) "
               f"{settled}, rise time {sig(m.rise_time_s)} s, peak |u| {sig(m.peak_control_v)} {res.input_unit} per "
               f"{p.output_unit} of step")
    for w in (*p.warnings, *(w for w in res.warnings if "dead time" not in w)):
        say(f"warning: {w}")
    from motorid.control.emit import discretise_pid

    _write_with_code(p.to_json(), lambda ts, how: discretise_pid(model, p, ts, how, rails=rails), model_file,
                     json_out, force, discrete, discrete_method, emit, emit_file, say)


#: The simulation metrics printed, in order, with their units (``output``: the output channel's).
_METRIC_UNITS: tuple[tuple[str, str], ...] = (
    ("rise_time_s", "s"), ("settling_time_s", "s"), ("overshoot_pct", "%"), ("steady_state_error_v", "output"),
    ("tracking_rms_v", "output"), ("peak_control_v", "input"))


def _metric_text(key: str, value: float, unit: str) -> str:
    """One closed-loop metric in words with its unit; a time the response never reached says so (not ``nan s``)."""
    if key in ("rise_time_s", "settling_time_s") and not math.isfinite(value):
        return f"{metric_name(key)} not within the record"
    return f"{metric_name(key)} {sig(value)} {unit}"


def simulate(
    model_file: Annotated[Path, typer.Argument(help="Model JSON.")],
    design_file: Annotated[Path, typer.Argument(help="Design JSON (motorid design --json).")],
    reference: Annotated[str, typer.Option(help="step, sine, triangle or square.")] = "step",
    level: Annotated[float | None, typer.Option(
        help="Step level / sinusoid offset, in the output's unit (default: 5 on scope volts, the report's; "
             "on data in another unit, what the identification's step reached).")] = defaults(SIMULATE)["level_v"],
    initial_ref: Annotated[float, typer.Option("--initial-ref", help="Reference before --start, output's unit.")] = 0.0,
    amplitude: Annotated[float | None, typer.Option(
        help="Wave amplitude, output's unit (default: 0.4 × the level, the report's 5 + 2 sin ωt).")] = None,
    frequency: Annotated[float, typer.Option(help="Wave frequency, Hz (report: ω = π/2 → 0.25).")] = 0.25,
    start: Annotated[float, typer.Option(help="Reference start time, s.")] = 0.0,
    duration: Annotated[float, typer.Option(help="Record length, s.")] = defaults(SIMULATE)["duration_s"],
    dt: Annotated[float | None, typer.Option(help="Control interval, s (default 1 ms linear, 2 ms trainer).")] = None,
    saturation: Annotated[float | None, typer.Option(
        help="Actuator rails ±, in the input's unit (V; pwm or % for a logged duty cycle).")] = None,
    disturbance: Annotated[float | None, typer.Option(
        help="Load (magnetic brake) as input-equivalent volts.")] = defaults(SIMULATE)["disturbance"],
    disturbance_start: Annotated[float, typer.Option("--disturbance-start", help="Load applied from, s.")] = 0.0,
    x0: Annotated[str | None, typer.Option("--x0", help="Initial state, e.g. 2,0 (report: θ0 = 2 V).")] = None,
    z0: Annotated[float, typer.Option("--z0", help="Initial integrator state (report Fig. 8: -2).")] = 0.0,
    xhat0: Annotated[str | None, typer.Option("--xhat0", help="Initial observer estimate.")] = None,
    plant: Annotated[str, typer.Option(help="linear (the model) or trainer (virtual trainer, nonlinear).")] = "linear",
    preset: Annotated[str, typer.Option(
        help=f"Trainer preset for --plant trainer: {', '.join(TRAINER_PRESETS)}.")] = "lab-report",
    compensate_dead_zone: Annotated[bool, typer.Option(
        "--compensate-dead-zone",
        help="Add the model's dead-zone to the command (inverse dead-zone feed-forward; a model identified "
             "from several step levels).")] = False,
    anti_windup: Annotated[bool | None, typer.Option(
        "--anti-windup/--no-anti-windup",
        help="Hold the integrator while the command is beyond a rail and its error would push it further "
             "(conditional integration; default: on with --saturation and integral action).")] = None,
    csv_out: Annotated[Path | None, typer.Option("--csv", help="Write the time series as CSV.")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write metrics and series as JSON.")] = None,
    png: Annotated[Path | None, typer.Option("--png", help="Write a plot.")] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite existing files.")] = False,
) -> None:
    """Closed-loop simulation of a design: metrics, time series and a plot."""
    from motorid import frontdoor
    from motorid.io import atomic_outputs
    from motorid.simulation.closed_loop import ReferenceSignal, plot_simulation

    _check_outputs([(csv_out, "--csv", None), (json_out, "--json", None), (png, "--png", ".png")], force)
    _check_numbers({"--level": level, "--initial-ref": initial_ref, "--amplitude": amplitude, "--start": start,
                    "--disturbance": disturbance, "--disturbance-start": disturbance_start, "--z0": z0,
                    "--frequency": frequency if reference != "step" else None})
    with _bar(f"trainer simulation ({duration:g} s)") if plant == "trainer" else nullcontext():
        res = frontdoor.simulate(
            model_file, design_file, duration_s=duration, dt_s=dt, saturation=saturation, disturbance=disturbance,
            disturbance_start_s=disturbance_start, x0=_floats(x0, "--x0"), z0=z0, xhat0=_floats(xhat0, "--xhat0"),
            plant=plant, trainer_preset=preset, compensate_dead_zone=compensate_dead_zone,  # type: ignore[arg-type]
            anti_windup=anti_windup,
            reference=ReferenceSignal(kind=reference, level_v=level, initial_v=initial_ref, amplitude_v=amplitude,
                                      frequency_hz=frequency, start_s=start))
    m = res.metrics
    if res.reference_level is not None:
        typer.echo(res.reference_level.text())
    # a wave has no rise, settling, overshoot or final value: its tracking error and peak command say it
    shown = _METRIC_UNITS if reference == "step" else tuple(
        (key, unit) for key, unit in _METRIC_UNITS if key in ("tracking_rms_v", "peak_control_v"))
    typer.echo(", ".join(_metric_text(key, getattr(m, key), {"output": res.output_unit,
                                                              "input": res.input_unit}.get(unit, unit))
                         for key, unit in shown))
    # the design's own numbers (design --robust's "the model itself") are the continuous loop's; what
    # sampling did to its damping is measured, not assumed
    if res.sampled_damping is not None:
        typer.echo(res.sampled_damping.text())
    for w in res.warnings:
        typer.echo(f"warning: {w}")
    with atomic_outputs(exclusive=not force) as outs:  # the CSV, JSON and plot appear together, or none
        if csv_out is not None:
            outs.write_text(csv_out, res.to_csv_text())
        if json_out is not None:
            outs.write_text(json_out, res.to_json_text() + "\n")
        if png is not None:
            _plot_to(outs, png, plot_simulation, res, title=f"{model_file.name} + {design_file.name} ({plant})",
                     rails_v=saturation, disturbance_s=disturbance_start if disturbance else None)
    for label, path in (("time series CSV", csv_out), ("simulation JSON", json_out), ("plot", png)):
        if path is not None:
            typer.echo(f"{label}: {path}")


def modes(
    model_file: Annotated[Path, typer.Argument(help="Model JSON.")],
    kp: Annotated[str, typer.Option("--kp", help="Kp grid START:STOP:COUNT, e.g. 0:200:200.")],
    kv: Annotated[str, typer.Option("--kv", help="Kv grid START:STOP:COUNT, e.g. 0:10:200.")],
    step: Annotated[float, typer.Option(help="Reference step, in the position's unit (V for scope volts).")] = 1.0,
    saturation: Annotated[float, typer.Option(
        help="Actuator rails ±, in the input's unit (V; pwm or % for a logged duty cycle).")] = 10.0,
    duration: Annotated[float | None, typer.Option(help="Record length, s (default 20 τm).")] = None,
    extra_pole: Annotated[float | None, typer.Option(
        "--extra-pole",
        help="Lag pole for the 3rd-order model of a 1st-order-velocity model, rad/s (default 10/τm).")] = None,
    json_out: Annotated[Path | None, typer.Option("--json", help="Write the Modes JSON here.")] = None,
    png: Annotated[Path | None, typer.Option("--png", help="Write the side-by-side map here.")] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite existing files.")] = False,
) -> None:
    """Map the six modes of the saturated position/velocity loop (Masoud 2019, Figs. 4, 11-13)."""
    from motorid.simulation.modes import (
        MODES,
        ModeCriteria,
        mode_map,
        modes_json,
        parse_range,
        plot_mode_maps,
        servo_plants,
    )
    from motorid.io import atomic_outputs
    from motorid.model.serialize import load_model

    _check_outputs([(json_out, "--json", None), (png, "--png", ".png")], force)
    _check_numbers({"--step": step, "--saturation": saturation, "--duration": duration, "--extra-pole": extra_pole},
                   positive=("--step", "--saturation", "--duration", "--extra-pole"))
    kp_axis, kv_axis = parse_range(kp, "--kp"), parse_range(kv, "--kv")
    criteria = ModeCriteria(step_v=step, saturation_v=saturation, duration_s=duration)
    model = load_model(model_file)
    try:
        plants = servo_plants(model, extra_pole)
    except OptionError as exc:
        raise exc.with_file(str(model_file)) from None
    maps = []
    lines = []
    with _bar("mode maps", total=len(plants)) as progress:
        for i, pl in enumerate(plants):
            progress(i, label=pl.name)
            t0 = time.perf_counter()
            mm = mode_map(pl, kp_axis, kv_axis, criteria)
            elapsed = time.perf_counter() - t0
            maps.append(mm)
            counts = mm.counts()
            lines.append(f"{pl.name}: " + ", ".join(f"{m} {counts[m]}" for m in MODES)
                         + f"  ({kp_axis.size}×{kv_axis.size} grid, {mm.steps} steps, {elapsed:.2f} s)")
        progress(len(plants))
    for line in lines:
        typer.echo(line)
    with atomic_outputs(exclusive=not force) as outs:
        if json_out is not None:
            outs.write_text(json_out, json.dumps(modes_json(tuple(maps), criteria), indent=1) + "\n")
        if png is not None:
            _plot_to(outs, png, plot_mode_maps, tuple(maps))
    for label, path in (("modes JSON", json_out), ("map image", png)):
        if path is not None:
            typer.echo(f"{label}: {path}")


def register(app: typer.Typer) -> None:
    """Add ``model from-params``/``from-step-test``, ``design``, ``simulate`` and ``modes`` to ``app``."""
    app.add_typer(model_app, name="model")
    app.command()(design)
    app.command()(simulate)
    app.command()(modes)

"""The options of the front door's functions, declared once: name, command-line flag, default, unit.

The front door (:mod:`motorid.frontdoor`) takes them as keyword arguments; the web page's form
fields are the same names (:mod:`motorid.web.options`); the batch settings take the identify
options by these names with these defaults (:mod:`motorid.batch.task`); the command line
spells them as :attr:`OptionSpec.flag`.  The library's messages name an option by its flag
(they were written for the command line); :func:`in_callers_words` turns the flags of a
message into the names a Python or web caller used, so ``mi.design(m, overshoot=120)`` says
``overshoot must be …``, and ``motorid design --overshoot 120`` says ``--overshoot must be …``.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, ParamSpec, TypeVar

from motorid.errors import MotorIdError

__all__ = [
    "ADVISE",
    "COLUMNS",
    "COMMANDS",
    "COUNTED_VELOCITY",
    "DESIGN",
    "DESIGN_PID",
    "IDENTIFY",
    "IDENTIFY_LEVELS",
    "PYTHON_ONLY",
    "READ",
    "SIMULATE",
    "TRAINER_PRESETS",
    "TRAINER_RIGS",
    "VALIDATE",
    "OptionSpec",
    "callers_words",
    "command_line_words",
    "defaults",
    "in_callers_words",
    "names",
    "speaks_as_called",
]

_P = ParamSpec("_P")
_R = TypeVar("_R")


@dataclass(frozen=True, slots=True)
class OptionSpec:
    """One option of a front-door function.

    Attributes
    ----------
    name : str
        The keyword argument (and the web form field / JSON key).
    flag : str
        The command-line flag.
    default : Any
        The default value (the front door's, the batch's and the web page's).
    unit : str
        The value's unit (``""`` for none).
    help : str
        One line for help texts.
    """

    name: str
    flag: str
    default: Any = None
    unit: str = ""
    help: str = ""

    @property
    def sentence(self) -> str:
        """The help line as a command's ``--help`` shows it: capitalised, with a full stop.

        Returns
        -------
        str
        """
        return self.help[:1].upper() + self.help[1:] + ("" if self.help.endswith(".") else ".")


#: The virtual trainer's presets (``motorid demo --preset``, ``simulate --plant trainer --preset``):
#: declared here, where the command line reads them without importing the trainer.
TRAINER_PRESETS: tuple[str, ...] = ("paper", "lab-report", "first-order", "second-order", "third-order",
                                    "electrical-7ms", "underdamped")

#: The virtual trainer's real-rig presets (``motorid demo --rig``): each records its log the way that rig
#: writes it (:mod:`motorid.trainer.realsetups`, :mod:`motorid.trainer.hobbyrigs`).
TRAINER_RIGS: tuple[str, ...] = ("fast-tbs1000", "pwm-encoder", "daq-deadtime", "l298n-rpm", "arduino-millis",
                                 "host-loop", "encoder-counts", "staircase", "ms-time", "serial-plotter", "picoscope",
                                 "clock-stamps", "no-header", "arduino-pwm")

#: :func:`motorid.read_experiment`'s captures, one per role (the web page's file fields).
ROLES: tuple[OptionSpec, ...] = (
    OptionSpec("position", "--position", None, "", "the position capture"),
    OptionSpec("velocity", "--velocity", None, "", "the velocity capture"),
    OptionSpec("current", "--current", None, "", "the armature-current capture"),
)

#: ``--columns``, which every command and function that reads captures takes.
COLUMNS = OptionSpec("columns", "--columns", None, "",
                     "plain-CSV column map, e.g. time=t,input=u,velocity=rpm; a CSV without a header row names its "
                     "columns by position, e.g. time=1,input=2,velocity=3")

#: A velocity that counts encoder edges over each sample interval: read, identify and validate take it.
COUNTED_VELOCITY = OptionSpec("counted_velocity", "--counted-velocity", False, "",
                              "the velocity counts encoder edges over each sample interval (a mean speed, as Arduino "
                              "sketches print rpm), or over several and kept until the next count: the model's means "
                              "over each count's interval are fitted and scored, so "
                              "its timing is the motor's (a log whose speed times its own stamped intervals is whole "
                              "counts is read so without it)")

#: :func:`motorid.read_experiment`'s options.
READ: tuple[OptionSpec, ...] = (
    OptionSpec("step_volts", "--step-volts", None, "V", "step level for captures without an input channel"),
    OptionSpec("t0", "--t0", None, "s", "the step instant on the captures' time axis"),
    COLUMNS,
    OptionSpec("force_role", "--force-role", False, "", "keep the given roles even when a capture looks like another"),
    OptionSpec("time_unit", "--time-unit", None, "", "a plain CSV's time column unit: s, ms or us"),
    OptionSpec("units", "--units", None, "", "each channel's unit, e.g. velocity=rpm"),
    OptionSpec("scale", "--scale", None, "", "sensor constants, e.g. velocity=0.1504V/(rad/s)"),
    OptionSpec("segment", "--segment", None, "", "a log with several input steps: identify its step N alone (1-based)"),
    COUNTED_VELOCITY,
)

#: :func:`motorid.identify`'s options.
IDENTIFY: tuple[OptionSpec, ...] = (
    OptionSpec("method", "--method", "auto", "", "auto, pinv, markov, classic, oe, srivc or paper-auto"),
    OptionSpec("order", "--order", "auto", "", "auto or 1-3"),
    OptionSpec("sample_interval", "--sample-interval", "auto", "s", "sample interval after reduction"),
    OptionSpec("delay", "--delay", None, "", "fit a dead time (default: when the data show one)"),
    OptionSpec("markov_basis", "--markov-basis", "laguerre", "", "laguerre or taylor"),
    OptionSpec("markov_params", "--markov-params", None, "", "number of Markov parameters"),
    OptionSpec("markov_window_s", "--markov-window", None, "s", "Markov window Tε"),
    OptionSpec("ratio", "--ratio", None, "", "keep every n-th sample"),
    OptionSpec("record_length_s", "--record-length", None, "s", "seconds kept after the step"),
    OptionSpec("reduction", "--reduction", "subsample", "", "subsample or mean"),
    OptionSpec("derivative", "--derivative", "five_point", "", "the velocity from the position: five_point, ..."),
    OptionSpec("structure", "--structure", "free", "", "pinv's A-matrix structure"),
    OptionSpec("sync", "--sync", "interp", "", "how captures are put on one time axis"),
)

#: Keyword arguments of the front door that take Python objects (settings classes), not values a
#: command line, a form field or a batch setting can carry: declared by the function's signature
#: alone (``identify(method_options=MethodOptions(...))``).
PYTHON_ONLY: tuple[str, ...] = ("method_options",)

#: :func:`motorid.design`'s options.
DESIGN: tuple[OptionSpec, ...] = (
    OptionSpec("poles", "--poles", None, "rad/s", "closed-loop poles"),
    OptionSpec("damping", "--damping", None, "", "damping ratio ζ"),
    OptionSpec("wn", "--wn", None, "rad/s", "natural frequency"),
    OptionSpec("k2", "--k2", None, "", "velocity gain (the lab report's design)"),
    OptionSpec("settling_time", "--settling-time", None, "s", "2 % settling time"),
    OptionSpec("overshoot", "--overshoot", None, "%", "percent overshoot"),
    OptionSpec("integral", "--integral", False, "", "integral action"),
    OptionSpec("ki", "--ki", None, "", "integral gain"),
    OptionSpec("integral_pole", "--integral-pole", None, "rad/s", "the integrator's extra pole"),
    OptionSpec("observer_poles", "--observer-poles", None, "rad/s", "Luenberger observer poles"),
    OptionSpec("output", "--output", None, "", "measured channel"),
    OptionSpec("robust_samples", "--robust-samples", 2000, "", "plausible motors the design is checked on (0: none)"),
    OptionSpec("sensors", "--sensors", None, "", "what the rig measures, e.g. position,velocity"),
    OptionSpec("robust_fraction", "--robust", None, "", "tune until this fraction of plausible motors meets the spec"),
)

#: :func:`motorid.design_pid`'s options (``motorid design --pid``).
DESIGN_PID: tuple[OptionSpec, ...] = (
    OptionSpec("loop", "--pid-loop", "velocity", "", "velocity (a PI) or position (a PD; a PID with integral)"),
    OptionSpec("rule", "--pid-rule", "simc", "", "simc (Skogestad's rules) or placement (damping and wn)"),
    OptionSpec("integral", "--pid-integral", False, "", "integral action on the position loop (a PID)"),
    OptionSpec("tau_c", "--tau-c", None, "s", "SIMC's closed-loop time constant (default max(θ, 0.25 τ))"),
    OptionSpec("derivative_filter", "--derivative-filter", 10.0, "", "N of the derivative filter Td/N"),
    OptionSpec("damping", "--damping", None, "", "damping ratio ζ of the placed poles"),
    OptionSpec("wn", "--wn", None, "rad/s", "natural frequency of the placed poles"),
)

#: :func:`motorid.simulate`'s options.
SIMULATE: tuple[OptionSpec, ...] = (
    OptionSpec("duration_s", "--duration", 5.0, "s", "record length"),
    OptionSpec("reference", "--reference", "step", "", "step, sine, triangle or square"),
    OptionSpec("level_v", "--level", None, "output's unit",
               "step level or wave mean (default: 5 on scope volts, else what the identification's step reached)"),
    OptionSpec("saturation", "--saturation", None, "input's unit", "actuator rails ±"),
    OptionSpec("disturbance", "--disturbance", None, "input's unit", "load as an input-equivalent command"),
    OptionSpec("disturbance_start_s", "--disturbance-start", 0.0, "s", "load applied from"),
    OptionSpec("plant", "--plant", "linear", "", "linear (the model) or trainer"),
    OptionSpec("dt_s", "--dt", None, "s", "control interval"),
    OptionSpec("x0", "--x0", None, "", "initial state"),
    OptionSpec("z0", "--z0", 0.0, "", "initial integrator state"),
    OptionSpec("xhat0", "--xhat0", None, "", "initial observer estimate"),
    OptionSpec("trainer_preset", "--preset", "lab-report", "", "trainer preset for plant=trainer"),
    OptionSpec("anti_windup", "--anti-windup", None, "",
               "hold the integrator against the rails (default: on with saturation and integral action)"),
    OptionSpec("compensate_dead_zone", "--compensate-dead-zone", False, "",
               "add the model's dead-zone to the command (inverse dead-zone feed-forward)"),
)

#: :func:`motorid.advise`'s options (``motorid advise`` takes the captures' and identify's too).
ADVISE: tuple[OptionSpec, ...] = (
    OptionSpec("threshold", "--threshold", 0.2, "",
               "narrowing of the gain's or τ's 95 % interval a change must bring to be worth it (0.2: 20 %)"),
)

#: :func:`motorid.identify_levels`'s options (``motorid identify`` with several ``--velocity``).
IDENTIFY_LEVELS: tuple[OptionSpec, ...] = (
    OptionSpec("step_volts", "--step-volts", None, "V", "each capture's step level: one for all, or one per capture"),
    COLUMNS,
)

#: :func:`motorid.validate`'s options.
VALIDATE: tuple[OptionSpec, ...] = (
    OptionSpec("channel", "--channel", "velocity", "", "the model output the captures measured"),
    OptionSpec("step_volts", "--step-volts", None, "V", "step level for captures without an input channel"),
    OptionSpec("t0", "--t0", None, "s", "the step instant on the files' time axis"),
    OptionSpec("warmup_s", "--warmup", 0.0, "s", "seconds at the start simulated but not scored"),
    COLUMNS,
    COUNTED_VELOCITY,
)

#: Each front-door function's options, by the command's name.
COMMANDS: dict[str, tuple[OptionSpec, ...]] = {
    "read_experiment": ROLES + READ, "identify": ROLES + READ + IDENTIFY, "design": DESIGN, "simulate": SIMULATE,
    "design_pid": DESIGN_PID, "advise": ADVISE, "identify_levels": IDENTIFY_LEVELS, "validate": VALIDATE,
}

_FLAG = re.compile(r"(?<![\w-])--[A-Za-z][\w-]*")

#: True while the command line calls the front door: its messages keep their flags.
_COMMAND_LINE: ContextVar[bool] = ContextVar("motorid_command_line_words", default=False)


def names(specs: tuple[OptionSpec, ...]) -> tuple[str, ...]:
    """The keyword names of ``specs``, in order.

    Parameters
    ----------
    specs : tuple of OptionSpec
        E.g. :data:`IDENTIFY`.

    Returns
    -------
    tuple of str
        The names.
    """
    return tuple(o.name for o in specs)


def defaults(specs: tuple[OptionSpec, ...]) -> dict[str, Any]:
    """``{name: default}`` of ``specs``.

    Parameters
    ----------
    specs : tuple of OptionSpec
        E.g. :data:`IDENTIFY`.

    Returns
    -------
    dict
        The defaults by name.
    """
    return {o.name: o.default for o in specs}


def _in_python(spec: OptionSpec) -> str:
    """How a Python caller writes ``spec``.

    ``force_role=True`` for a switch, ``velocity=`` for a capture, the bare name for a value
    (``overshoot must be …``).
    """
    if spec.default is False:
        return f"{spec.name}=True"
    if spec in ROLES:
        return f"{spec.name}="
    return spec.name


def in_callers_words(message: str, command: str) -> str:
    """``message`` with the command-line flags of ``command``'s options replaced by their names.

    Parameters
    ----------
    message : str
        A message written for the command line (``--overshoot must be …``).
    command : str
        A key of :data:`COMMANDS`.

    Returns
    -------
    str
        The message as a Python or web caller reads it (``overshoot must be …``,
        ``force_role=True``, ``velocity=``); flags of other commands' options are left as they are.
    """
    table = {o.flag: _in_python(o) for o in COMMANDS[command]}
    return _FLAG.sub(lambda m: table.get(m.group(0), m.group(0)), message)


@contextmanager
def callers_words(command: str) -> Iterator[None]:
    """Re-raise a :class:`~motorid.errors.MotorIdError` with its message :func:`in_callers_words`.

    Parameters
    ----------
    command : str
        A key of :data:`COMMANDS`.

    Yields
    ------
    None
        The body runs inside.
    """
    try:
        yield
    except MotorIdError as exc:
        if _COMMAND_LINE.get():
            raise
        said = in_callers_words(exc.message, command)
        if said == exc.message:
            raise
        raise type(exc)(said, file=exc.file, row=exc.row) from exc


def speaks_as_called(command: str) -> Callable[[Callable[_P, _R]], Callable[_P, _R]]:
    """Decorate a front-door function so that its errors name options as its caller did.

    Parameters
    ----------
    command : str
        A key of :data:`COMMANDS`.

    Returns
    -------
    callable
        The decorator; the decorated function keeps its signature (for type checkers too).
    """

    def decorate(func: Callable[_P, _R]) -> Callable[_P, _R]:
        @functools.wraps(func)
        def inner(*args: _P.args, **kwargs: _P.kwargs) -> _R:
            with callers_words(command):
                return func(*args, **kwargs)

        return inner

    return decorate


def switch_words(flag: str, name: str) -> str:
    """A switch as the caller writes it: ``--force`` on the command line, ``force=True`` in Python.

    For messages of the library's own functions (the output writers' ``force``), which no
    command's option table lists.

    Parameters
    ----------
    flag : str
        The command-line flag (``--force``).
    name : str
        The keyword argument (``force``).

    Returns
    -------
    str
        The words for the current caller.
    """
    return flag if _COMMAND_LINE.get() else f"{name}=True"


@contextmanager
def command_line_words() -> Iterator[None]:
    """Inside, the front door's messages keep the command-line flags (the CLI calls it so).

    Yields
    ------
    None
        The body runs inside.
    """
    token = _COMMAND_LINE.set(True)
    try:
        yield
    finally:
        _COMMAND_LINE.reset(token)


def real_number(value: Any, flag: str, *, optional: bool = False) -> float | None:
    """``value`` as a float when it is a real number (not a bool, text or container); else refused.

    The front door's numeric keyword options pass through it before anything uses them, so a
    Python caller's ``duration_s="5"`` is a message naming the option, not a ``TypeError``
    from deep inside (the command line's parser never lets such a value through).

    Parameters
    ----------
    value : Any
        What the caller gave.
    flag : str
        The option's command-line flag (turned into the caller's words by :func:`in_callers_words`).
    optional : bool
        Whether ``None`` is allowed (returned as None).

    Returns
    -------
    float or None

    Raises
    ------
    OptionError
        Anything but a real number (NaN and infinities pass: the option's own check judges them).
    """
    from numbers import Real

    from motorid.errors import OptionError

    if value is None and optional:
        return None
    if isinstance(value, bool) or not isinstance(value, Real):
        raise OptionError(f"{flag} must be a number, got {value!r}")
    return float(value)


def real_numbers(values: Any, flag: str) -> tuple[float, ...] | None:
    """A sequence of real numbers (``x0=[2, 0]``) as floats; None stays None; anything else refused.

    Parameters
    ----------
    values : Any
        What the caller gave.
    flag : str
        The option's command-line flag.

    Returns
    -------
    tuple of float or None

    Raises
    ------
    OptionError
        Not a sequence (text included), or an element that is not a real number.
    """
    from collections.abc import Sequence

    from motorid.errors import OptionError

    if values is None:
        return None
    if isinstance(values, (str, bytes)) or not isinstance(values, Sequence):
        raise OptionError(f"{flag} must be a sequence of numbers, got {values!r}")
    return tuple(float(real_number(v, flag) or 0.0) for v in values)  # (not optional: never None)


"""The identified motor: state space with named states, its transfer functions and exports.

A :class:`MotorModel` is what every identification method returns and what the rest of the
tool (control design, reports, the ``--json``/``--matlab`` files) consumes.  The maths is
python-control's (``ss``, ``ss2tf``, ``modred``); this module only keeps the names, the
provenance (method, settings, step level, sample interval) and the warnings together.

Outputs
-------
Rows of ``C``/``D`` are *measured channels*, named in ``outputs`` from ``position``,
``velocity`` and ``current``.  Every model has a ``velocity`` output (all methods model the
tachogenerator channel).  When a model has no ``position`` output its position transfer
function is the velocity one divided by ``s`` (the position channel is the integral of the
velocity channel, in velocity-channel volts·s).
"""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np

from motorid.frozen import frozen_getstate, frozen_setstate
from motorid.errors import ModelFormatError, OptionError
from motorid.model import lti
from motorid.model.nonlinearity import StaticNonlinearity
from motorid.model.stage import Stage
from motorid.model.uncertainty import Uncertainty
from motorid.model.units import ChannelScale, channel_unit, dc_gain_unit
from motorid.model.serialize import SCHEMA, model_from_dict, model_to_dict, model_to_matlab
from motorid.model.simplify import (
    CANCEL_TOL_REL,
    EXACT_CANCEL_TOL,
    FirstOrder,
    _balance,
    _cancel_pairs,
    _dc,
    _normalise_tf,
    _roots,
    _tf_coeffs,
)

if TYPE_CHECKING:
    import control

__all__ = [
    "CHANNELS",
    "SCHEMA",
    "FirstOrder",
    "ModelFormatError",
    "MotorModel",
    "TfRealisation",
    "model_from_velocity_tf",
    "realise_tfs",
    "realise_tfs_stacked",
]

CHANNELS = ("position", "velocity", "current")
#: The input signal's name on the python-control systems: the amplifier's command, in volts.
INPUT_SIGNAL = "u [V]"





#: Largest magnitude of a state-space entry: beyond it a product of two entries can overflow.
MAX_MATRIX_ENTRY = 1e100


def _as_matrix(name: str, value: Any, shape: tuple[int | None, int | None]) -> np.ndarray:
    """Return ``value`` as a read-only float 2-D array, or raise ModelFormatError."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelFormatError(f"state-space matrix {name} is not numeric") from None
    if arr.ndim == 1 and shape[1] == 1:
        arr = arr.reshape(-1, 1)
    elif arr.ndim == 1 and shape[0] == 1:
        arr = arr.reshape(1, -1)
    elif arr.ndim == 0 and shape == (1, 1):
        arr = arr.reshape(1, 1)
    if arr.ndim != 2:
        raise ModelFormatError(f"state-space matrix {name} must be 2-D, got {arr.ndim}-D")
    for axis, want in enumerate(shape):
        if want is not None and arr.shape[axis] != want:
            raise ModelFormatError(
                f"state-space matrix {name} has shape {arr.shape}, expected "
                f"{tuple('n' if w is None else w for w in shape)} with n = {want}"
            )
    if not np.all(np.isfinite(arr)):
        raise ModelFormatError(f"state-space matrix {name} contains NaN or infinity")
    if arr.size and float(np.max(np.abs(arr))) > MAX_MATRIX_ENTRY:
        raise ModelFormatError(f"state-space matrix {name} has an entry of {float(np.max(np.abs(arr))):.3g}: not a "
                               f"motor's model (entries beyond {MAX_MATRIX_ENTRY:g} overflow every simulation)")
    arr.setflags(write=False)
    return arr


def _state_names(n: int) -> tuple[str, ...]:
    return tuple(f"x{i + 1}" for i in range(n))


@dataclass(frozen=True, slots=True)
class TfRealisation:
    """State-space matrices of an output-error fit's transfer functions (see :func:`realise_tfs`).

    Attributes
    ----------
    A, B, C, D : ndarray
        The realisation.
    states, outputs : tuple of str
        State and output names.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    states: tuple[str, ...]
    outputs: tuple[str, ...]


def _companion(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The controller canonical form (scipy's ``tf2ss``) of stacked monic TFs: ``num``, ``den`` of shape (S, n + 1).

    The same arithmetic as :func:`scipy.signal.tf2ss`, so a single system's matrices are
    bit-identical to it, for many systems at once.
    """
    s, k = den.shape
    a = np.zeros((s, k - 1, k - 1))
    a[:, 0, :] = -den[:, 1:]
    a[:, 1:, :-1] = np.eye(k - 2, k - 2)
    b = np.zeros((s, k - 1, 1))
    b[:, 0, 0] = 1.0
    c = num[:, 1:] - num[:, :1] * den[:, 1:]
    return a, b, c[:, None, :], num[:, :1, None]


def realise_tfs_stacked(velocity_num: Any, den: Any, *, current_num: Any = None,
                        position_scale: Any = None) -> TfRealisation:
    """:func:`realise_tfs` of many motors of one structure at once (matrices stacked on a first axis).

    Parameters
    ----------
    velocity_num, den : array_like, shape (S, n + 1)
        Velocity TFs (``den[:, 0] == 1``; numerators padded with leading zeros to ``n + 1``).
    current_num : array_like, shape (S, n + 1), optional
        Current numerators over ``den``.
    position_scale : array_like, shape (S,), optional
        ``c`` of ``position = c·∫velocity`` of each motor.

    Returns
    -------
    TfRealisation
        ``A`` of shape (S, N, N), ``B`` (S, N, 1), ``C`` and ``D`` (S, outputs, N) and (S, outputs, 1).
    """
    dd = np.atleast_2d(np.asarray(den, float))
    num = np.atleast_2d(np.asarray(velocity_num, float))
    if dd.shape[1] < 2 or num.shape != dd.shape:
        raise ModelFormatError("stacked transfer functions need numerators padded to their denominators' length")
    a, b, c, d = _companion(num, dd)
    s, n = a.shape[0], a.shape[1]
    states: tuple[str, ...] = tuple(f"x{i + 1}" for i in range(n))
    rows, drows, outputs = [c], [d], ["velocity"]
    if current_num is not None:
        _, _, ci, di = _companion(np.atleast_2d(np.asarray(current_num, float)), dd)
        rows.append(ci)
        drows.append(di)
        outputs.append("current")
    cmat, dmat = np.concatenate(rows, axis=1), np.concatenate(drows, axis=1)
    if position_scale is not None:
        # position = c·∫velocity: an integrator state fed by the velocity row
        scale = np.broadcast_to(np.asarray(position_scale, float), (s,))
        big_a = np.zeros((s, n + 1, n + 1))
        big_a[:, 0, 1:] = scale[:, None] * c[:, 0, :]
        big_a[:, 1:, 1:] = a
        big_b = np.concatenate([(scale * d[:, 0, 0])[:, None, None], b], axis=1)
        top = np.zeros((s, 1, n + 1))
        top[:, 0, 0] = 1.0
        cmat = np.concatenate([top, np.concatenate([np.zeros((s, cmat.shape[1], 1)), cmat], axis=2)], axis=1)
        dmat = np.concatenate([np.zeros((s, 1, 1)), dmat], axis=1)
        return TfRealisation(big_a, big_b, cmat, dmat, ("position", *states), ("position", *outputs))
    return TfRealisation(a, b, cmat, dmat, states, tuple(outputs))


def realise_tfs(velocity_num: Any, den: Any, *, current_num: Any = None,
                position_scale: float | None = None) -> TfRealisation:
    """Realise the velocity TF, with the current TF over the same denominator and a position state.

    The output-error fit's models and every motor sampled from its covariance are built this
    one way (:func:`realise_tfs_stacked`), so that a sampled motor has the identified model's states.

    Parameters
    ----------
    velocity_num, den : array_like
        Velocity transfer function, highest power first (``den[0] == 1``).
    current_num : array_like, optional
        Numerator of the current TF over ``den``.
    position_scale : float, optional
        ``c`` of ``position = c·∫velocity``: adds a ``position`` state (first) and output.

    Returns
    -------
    TfRealisation
        Companion states ``x1…xn`` (as scipy's ``tf2ss``), ``position`` first when asked for;
        outputs ``[position,] velocity[, current]``.
    """
    dd = np.asarray(den, float)

    def padded(x: Any) -> np.ndarray:
        x = np.atleast_1d(np.asarray(x, float))
        return np.concatenate([np.zeros(dd.size - x.size), x])[None]

    r = realise_tfs_stacked(padded(velocity_num), dd[None],
                            current_num=None if current_num is None else padded(current_num),
                            position_scale=None if position_scale is None else [position_scale])
    return TfRealisation(r.A[0], r.B[0], r.C[0], r.D[0], r.states, r.outputs)


def model_from_velocity_tf(
    num: Any,
    den: Any,
    *,
    with_position: bool = False,
    **meta: Any,
) -> MotorModel:
    """Realise a velocity transfer function as a :class:`MotorModel`.

    Parameters
    ----------
    num, den : array_like
        Velocity transfer function (input volts → velocity-channel volts), highest power
        first; ``deg num <= deg den``, ``deg den >= 1``.
    with_position : bool
        Add a ``position`` state that integrates the velocity output, as the paper's
        reduced model ``[θ, θ̇]`` (eq. 42).
    **meta
        Other :class:`MotorModel` fields (``method``, ``step_volts``, ...).

    Returns
    -------
    MotorModel
        First-order strictly proper TFs get the single state ``velocity`` (so
        ``k/(s+p)`` becomes ``A = [[0, 1], [0, -p]]``, ``B = [0, k]`` with a position
        state, exactly eq. 42); higher orders get companion states ``x1, x2, ...``.

    Raises
    ------
    ModelFormatError
        If the transfer function is static or improper.
    """
    num, den = _normalise_tf(num, den)
    if den.size < 2:
        raise ModelFormatError("a velocity transfer function needs at least one pole")
    if num.size > den.size:
        raise ModelFormatError("the velocity transfer function is improper (more zeros than poles)")
    if den.size == 2:
        # k/(s+p) (+ direct term): keep the state equal to the velocity when D == 0.
        d = num[0] if num.size == 2 else 0.0
        b = num[-1] - d * den[-1]
        a = np.array([[-den[-1]]])
        b_col = np.array([[b]])
        c_row = np.array([[1.0]])
        d_val = np.array([[d]])
        vstates: tuple[str, ...] = ("velocity",) if d == 0.0 else ("x1",)
    else:
        # python-control's tf2ss (without slycot) is this call: the same realisation, without
        # importing python-control (half a second of a command's start-up) to build a model
        a, b_col, c_row, d_val = (np.asarray(m, dtype=float) for m in lti.tf2ss(num, den))
        vstates = _state_names(a.shape[0])
    if not with_position:
        return MotorModel(A=a, B=b_col, C=c_row, D=d_val, states=vstates,
                          outputs=("velocity",), **meta)
    n = a.shape[0]
    a_ext = np.zeros((n + 1, n + 1))
    a_ext[0, 1:] = c_row[0]
    a_ext[1:, 1:] = a
    b_ext = np.vstack([d_val, b_col])
    c_ext = np.zeros((2, n + 1))
    c_ext[0, 0] = 1.0
    c_ext[1, 1:] = c_row[0]
    d_ext = np.vstack([[[0.0]], d_val])
    return MotorModel(A=a_ext, B=b_ext, C=c_ext, D=d_ext, states=("position", *vstates),
                      outputs=("position", "velocity"), **meta)


#: The fields a model's transfer functions are computed from (:meth:`MotorModel.replace` keeps
#: what was computed when none of them changes).
_DYNAMICS_FIELDS = frozenset({"A", "B", "C", "D", "outputs"})


@dataclass(frozen=True, slots=True, eq=False)
class MotorModel:
    """An identified DC servo-motor: ``ẋ = A x + B u``, ``y = C x + D u``.

    Parameters
    ----------
    A, B, C, D : ndarray
        State-space matrices, shapes (n, n), (n, 1), (p, n), (p, 1); ``u`` is the amplifier
        input in volts, ``y`` the measured channels in volts.
    states : tuple of str
        One name per state: ``position``, ``velocity``, ``current`` for physical states,
        ``x1``, ``x2``, ... for realisation (companion) states.
    outputs : tuple of str
        The channel each row of ``C``/``D`` gives; must include ``velocity``.
    step_volts : float or None
        Input step level the model was identified from.
    method : str
        Identification method (``pinv``, ``markov``, ``classic``, ...).
    settings : Mapping
        The method's settings (JSON-able), so a model records how it was obtained.
    sample_interval_s : float or None
        Sample interval of the data the method used (after sample reduction).
    fit : Mapping of str to float
        Goodness of fit, e.g. ``velocity_nrmse``.
    warnings : tuple of str
        Everything the method was unsure about (ill-conditioning, unsettled record, ...).
    extras : Mapping
        JSON blobs of later stages (uncertainty, validation, ...), written as-is.
    uncertainty : Uncertainty or None
        Standard errors and 95 % intervals of the DC gain, time constants, poles, zeros, dead
        time and each channel's step instant (:class:`~motorid.model.uncertainty.Uncertainty`;
        the JSON's top-level ``uncertainty`` and ``timing``); a mapping with the JSON's keys
        given here is read by :meth:`Uncertainty.from_dict`, an empty one means none.
    stages : tuple of Stage
        What each stage of ``--method auto`` found (the top-level ``stages`` key); plain
        mappings given here are converted.
    delay_s : float
        Dead time between the input and every output, seconds (0: none).  Not part of the
        state-space matrices (a delay has no finite realisation): responses and fits apply
        it, and the JSON carries it as the top-level ``delay_s`` (docs/formats.md).
    static_nonlinearity : StaticNonlinearity or None
        A dead-zone (and rails) in front of the linear part (a Hammerstein model identified
        from several step levels): the linear model's input is ``f(u)``, not ``u``.  The JSON
        carries it as the top-level ``static_nonlinearity``.
    units : Mapping
        Unit of each channel's data (``{"velocity": "rpm"}``; ``input`` for the input);
        missing channels are volts.  Top-level ``units`` and ``dc_gain_unit`` in the JSON.
    scales : Mapping
        Sensor constants (:class:`~motorid.model.units.ChannelScale`) that turn a volts
        channel into a physical quantity (``scales`` in the JSON).

    Raises
    ------
    ModelFormatError
        On inconsistent shapes, unknown channel names or non-finite entries.
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    states: tuple[str, ...]
    outputs: tuple[str, ...] = ("velocity",)
    step_volts: float | None = None
    method: str = "unknown"
    settings: Mapping[str, Any] = field(default_factory=dict)
    sample_interval_s: float | None = None
    fit: Mapping[str, float] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    extras: Mapping[str, Any] = field(default_factory=dict)
    uncertainty: Uncertainty | None = None
    stages: tuple[Stage | Mapping[str, Any], ...] = ()
    delay_s: float = 0.0
    static_nonlinearity: StaticNonlinearity | None = None
    units: Mapping[str, str] = field(default_factory=dict)
    scales: Mapping[str, ChannelScale] = field(default_factory=dict)
    #: Each channel's transfer function and the first-order approximations, computed once (the
    #: model is immutable and its matrices read-only; an identification asks for them dozens of
    #: times).
    _tf_cache: dict[Any, Any] = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        a = _as_matrix("A", self.A, (None, None))
        n = a.shape[0]
        if a.shape != (n, n) or n == 0:
            raise ModelFormatError(f"state-space matrix A must be square and non-empty, got {a.shape}")
        outputs = tuple(str(o) for o in self.outputs)
        p = len(outputs)
        b = _as_matrix("B", self.B, (n, 1))
        c = _as_matrix("C", self.C, (p, n))
        d = _as_matrix("D", np.zeros((p, 1)) if self.D is None else self.D, (p, 1))
        states = tuple(str(s) for s in self.states)
        if len(states) != n:
            raise ModelFormatError(f"{len(states)} state names given for {n} states")
        if len(set(states)) != n:
            raise ModelFormatError(f"state names must be unique, got {list(states)}")
        bad = [o for o in outputs if o not in CHANNELS]
        if bad or len(set(outputs)) != p:
            raise ModelFormatError(f"outputs must be distinct names from {list(CHANNELS)}, got {list(outputs)}")
        if "velocity" not in outputs:
            raise ModelFormatError("a motor model needs a 'velocity' output row in C")
        step = None if self.step_volts is None else float(self.step_volts)
        dt = None if self.sample_interval_s is None else float(self.sample_interval_s)
        for name, value in (("A", a), ("B", b), ("C", c), ("D", d)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "states", states)
        object.__setattr__(self, "outputs", outputs)
        object.__setattr__(self, "step_volts", step)
        object.__setattr__(self, "sample_interval_s", dt)
        object.__setattr__(self, "method", str(self.method))
        object.__setattr__(self, "settings", MappingProxyType(dict(self.settings)))
        object.__setattr__(self, "fit", MappingProxyType({str(k): float(v) for k, v in self.fit.items()}))
        object.__setattr__(self, "warnings", tuple(str(w) for w in self.warnings))
        object.__setattr__(self, "extras", MappingProxyType(dict(self.extras)))
        u = self.uncertainty
        if u is not None and not isinstance(u, Uncertainty):
            if not isinstance(u, Mapping):
                raise ModelFormatError(f"uncertainty must be an Uncertainty or a mapping, got {type(u).__name__}")
            u = Uncertainty.from_dict(u) if u else None
        object.__setattr__(self, "uncertainty", u)
        object.__setattr__(self, "stages", tuple(st if isinstance(st, Stage) else Stage.from_dict(st)
                                                 for st in self.stages))
        delay = float(self.delay_s or 0.0)
        if not (math.isfinite(delay) and delay >= 0.0):
            raise ModelFormatError(f"delay_s must be a finite number ≥ 0, got {self.delay_s!r}")
        object.__setattr__(self, "delay_s", delay)
        object.__setattr__(self, "units", MappingProxyType({str(k): str(v) for k, v in self.units.items() if v}))
        object.__setattr__(self, "scales", MappingProxyType(dict(self.scales)))
        if self.static_nonlinearity is not None and not isinstance(self.static_nonlinearity, StaticNonlinearity):
            raise ModelFormatError("static_nonlinearity must be a StaticNonlinearity")

    # ------------------------------------------------------------------ basics
    @property
    def dc_gain_unit(self) -> str:
        """Unit of the velocity DC gain: ``rpm/V`` for data in rpm, ``V/V`` for scope volts."""
        return dc_gain_unit(self.units)

    @property
    def input_unit(self) -> str:
        """Unit of the command ``u``: ``V``, or the logged command's (``pwm``, ``%``)."""
        return channel_unit(self.units, "input")

    @property
    def order(self) -> int:
        """Number of states."""
        return int(self.A.shape[0])

    def replace(self, **changes: Any) -> MotorModel:
        """Return a copy with some fields changed (``dataclasses.replace``).

        Parameters
        ----------
        **changes
            Fields to change, by name.

        Returns
        -------
        MotorModel
            The copy (checked like a new model); the transfer functions and first order taken
            of this model so far are the copy's too when the fields they come from are unchanged.
        """
        new = dataclasses.replace(self, **changes)
        if not changes.keys() & _DYNAMICS_FIELDS:
            # a channel's TF depends on the matrices and outputs; the first order also on the
            # settings (the record length that decides which pole-zero pairs are artefacts)
            keep = {k: v for k, v in self._tf_cache.items() if isinstance(k, str) or "settings" not in changes}
            new._tf_cache.update(keep)
        return new

    @property
    def state_space(self) -> control.StateSpace:
        """The model as a python-control ``StateSpace`` (one output per channel).

        A property, as :attr:`velocity_tf`, :attr:`position_tf` and :attr:`current_tf` are: the
        model's python-control systems are all read the same way.

        Returns
        -------
        control.StateSpace
            Outputs in the order of :attr:`outputs`, named with their units (``velocity [rpm]``).
        """
        import control

        return control.ss(self.A, self.B, self.C, self.D, inputs=[INPUT_SIGNAL],
                          outputs=[self.signal_name(ch) for ch in self.outputs], states=list(self.states))

    def ss(self) -> control.StateSpace:
        """:attr:`state_space`, as a call (kept for code written before the property).

        Returns
        -------
        control.StateSpace
            The same system as :attr:`state_space`.
        """
        return self.state_space

    def signal_name(self, channel: str) -> str:
        """A channel's name with its unit, as the python-control systems carry it (``velocity [rpm]``).

        Parameters
        ----------
        channel : str
            ``velocity``, ``position`` or ``current``.

        Returns
        -------
        str
            ``"<channel> [<unit>]"``, the unit being the data's (``V`` for scope volts).
        """
        return f"{channel} [{channel_unit(self.units, channel)}]"

    def _row(self, channel: str) -> tuple[np.ndarray, np.ndarray]:
        i = self.outputs.index(channel)
        return self.C[i:i + 1], self.D[i:i + 1]

    def _row_tf(self, channel: str) -> tuple[np.ndarray, np.ndarray]:
        hit = self._tf_cache.get(channel)
        if hit is None:
            hit = self._tf_cache[channel] = self._compute_row_tf(channel)
        return hit[0].copy(), hit[1].copy()

    def _compute_row_tf(self, channel: str) -> tuple[np.ndarray, np.ndarray]:
        c, d = self._row(channel)
        # scipy's conversion (what python-control runs without slycot) without wrapping it in a
        # TransferFunction first: a model's TFs are taken dozens of times in one identification
        nums, den = lti.ss2tf(self.A, self.B, c, d)
        num, den = _normalise_tf(nums[0], den)
        # ss2tf does not remove states the channel cannot see (e.g. the position integrator
        # seen from the velocity row); cancel pairs that coincide to round-off.
        num, den, _ = _cancel_pairs(num, den, EXACT_CANCEL_TOL, "leading")
        return _normalise_tf(num, den)

    @overload
    def tf_coefficients(self, channel: Literal["velocity", "position"]) -> tuple[np.ndarray, np.ndarray]: ...

    @overload
    def tf_coefficients(self, channel: str) -> tuple[np.ndarray, np.ndarray] | None: ...

    def tf_coefficients(self, channel: str) -> tuple[np.ndarray, np.ndarray] | None:
        """Numerator and denominator of a channel's transfer function, as its ``*_tf`` property holds them.

        Plain arrays (highest power first, ``den[0] == 1``): for printing and JSON, where building
        a python-control object (and importing python-control) is not needed.

        Parameters
        ----------
        channel : str
            ``velocity``, ``position`` (the velocity's integral when the model has no position
            output) or ``current``.

        Returns
        -------
        (ndarray, ndarray) or None
            ``(num, den)``; None for ``current`` when the model has no current output.

        Raises
        ------
        OptionError
            An unknown channel.
        """
        if channel not in ("velocity", "position", "current"):
            raise OptionError(f"no transfer function for channel {channel!r}: use velocity, position or current")
        if channel == "current" and "current" not in self.outputs:
            return None
        if channel == "position" and "position" not in self.outputs:
            num, den = self._row_tf("velocity")
            return num, np.polymul(den, [1.0, 0.0])
        return self._row_tf(channel)

    @property
    def velocity_tf(self) -> control.TransferFunction:
        """Input volts → velocity-channel volts, ``den[0] == 1`` (Masoud 2019, eq. 9)."""
        import control

        return control.tf(*self._row_tf("velocity"), inputs=INPUT_SIGNAL, outputs=self.signal_name("velocity"))

    @property
    def position_tf(self) -> control.TransferFunction:
        """Input volts → position channel; velocity TF / s when there is no position output."""
        import control

        return control.tf(*self.tf_coefficients("position"), inputs=INPUT_SIGNAL,
                          outputs=self.signal_name("position"))

    @property
    def current_tf(self) -> control.TransferFunction | None:
        """Input volts → current channel, or None when the model has no current output."""
        coeffs = self.tf_coefficients("current")
        if coeffs is None:
            return None
        import control

        return control.tf(*coeffs, inputs=INPUT_SIGNAL, outputs=self.signal_name("current"))

    def poles(self) -> np.ndarray:
        """Poles of the velocity transfer function (complex array).

        Returns
        -------
        ndarray
            The poles.
        """
        return _roots(self._row_tf("velocity")[1])

    def zeros(self) -> np.ndarray:
        """Zeros of the velocity transfer function (complex array).

        Returns
        -------
        ndarray
            The zeros (empty when there are none).
        """
        return _roots(self._row_tf("velocity")[0])

    def dc_gain(self) -> float:
        """Steady-state velocity per input volt (``inf`` for an integrating velocity TF).

        Returns
        -------
        float
            The DC gain in (velocity volts)/(input volt).
        """
        return _dc(*self._row_tf("velocity"))

    def first_order(self, cancel_tol_rel: float = CANCEL_TOL_REL) -> FirstOrder:
        """Dominant first-order approximation of the velocity channel.

        Near pole-zero pairs are cancelled first (tolerance ``cancel_tol_rel``; pass 0 to
        skip), but only artifacts the record cannot show: a pair slower than the poles that
        remain and than the record (``settings["record_length_s"]``, written by
        ``identify``) as in the paper (eq. 39 → 41, the factors dropped); any other pair is
        left in (see ``_cancel_pairs``), so the result is the model's own DC gain and τ.
        Then the time constant is the mean residence
        time (first moment of the impulse response over its area),
        ``τ = −G'(0)/G(0) = Σ 1/z_i − Σ 1/p_i = d1/d0 − n1/n0`` for ``G = N/D`` with
        ``N = … + n1 s + n0``, ``D = … + d1 s + d0``: exact for a first-order system and the
        first-order model that matches ``G`` best at low frequency (same DC gain and same
        low-frequency phase slope).

        Parameters
        ----------
        cancel_tol_rel : float
            Tolerance of the pole-zero cancellation, relative to the fastest pole.

        Returns
        -------
        FirstOrder
            ``dc_gain`` and ``time_constant_s``; both NaN when the DC gain is zero or
            infinite (an integrating or differentiating velocity channel).
        """
        key = ("first_order", float(cancel_tol_rel))
        if key not in self._tf_cache:
            self._tf_cache[key] = self._first_order(cancel_tol_rel)
        return self._tf_cache[key]

    def _first_order(self, cancel_tol_rel: float) -> FirstOrder:
        num, den = self._row_tf("velocity")
        if cancel_tol_rel > 0:
            record = self.settings.get("record_length_s")
            record_s = float(record) if isinstance(record, (int, float)) and record > 0 else None
            num, den, _ = _cancel_pairs(num, den, cancel_tol_rel, "auto", record_s)
        n0, d0 = num[-1], den[-1]
        n1 = num[-2] if num.size >= 2 else 0.0
        d1 = den[-2] if den.size >= 2 else 0.0
        if n0 == 0.0 or d0 == 0.0:
            return FirstOrder(float("nan"), float("nan"))
        return FirstOrder(float(n0 / d0), float(d1 / d0 - n1 / n0))

    # --------------------------------------------------------- simplification
    def cancel_near(self, tol_rel: float = CANCEL_TOL_REL, *, keep: str = "leading") -> MotorModel:
        """Cancel near pole-zero pairs of the velocity transfer function.

        Parameters
        ----------
        tol_rel : float
            A pole and a zero cancel when they are closer than ``tol_rel`` times the
            magnitude of the fastest pole.
        keep : {'leading', 'dc'}
            ``'leading'`` drops the factors and keeps the high-frequency gain, as the paper
            does (eq. 39 → 41: the pair near the origin is an artefact whose DC effect is
            spurious); ``'dc'`` rescales so the DC gain is unchanged.

        Returns
        -------
        MotorModel
            ``self`` when nothing cancels; otherwise a model realised from the simplified
            velocity TF (with a position state when this model has a position output).
            The current output, if any, is not carried over.

        Raises
        ------
        OptionError
            On a negative tolerance or an unknown ``keep``.

        References
        ----------
        Masoud 2019, eqs. 39–42.
        """
        if not (tol_rel >= 0) or keep not in ("leading", "dc"):
            raise OptionError(f"cancel_near needs tol_rel >= 0 and keep 'leading' or 'dc', got {tol_rel!r}, {keep!r}")
        num, den = self._row_tf("velocity")
        new_num, new_den, n = _cancel_pairs(num, den, tol_rel, keep)
        if n == 0:
            return self
        if new_den.size < 2:
            raise OptionError("cancel_near would cancel every pole; use a smaller tolerance")
        note = f"cancel_near: cancelled {n} pole-zero pair(s) within {tol_rel:g} of the fastest pole (keep={keep})"
        return self._derived(new_num, new_den, note, {"cancel_tol_rel": tol_rel, "cancel_keep": keep})

    def reduce(self, order: int) -> MotorModel:
        """Reduce the velocity transfer function to ``order`` poles, keeping its DC gain.

        Balanced truncation with singular-perturbation (``matchdc``) elimination of the
        weakest balanced states, which keeps the DC gain exactly.  Exact pole-zero
        cancellations (e.g. a position integrator cancelled by a zero at the origin) are
        removed first; the position state, if any, is added back as the integral of the
        reduced velocity.

        Parameters
        ----------
        order : int
            Number of poles of the reduced velocity TF (>= 1).

        Returns
        -------
        MotorModel

        Raises
        ------
        OptionError
            On ``order < 1`` or when the velocity TF is not asymptotically stable (cancel
            near pole-zero pairs with :meth:`cancel_near` first).
        """
        if not isinstance(order, (int, np.integer)) or order < 1:
            raise OptionError(f"reduce needs an order >= 1, got {order!r}")
        num, den = self._row_tf("velocity")
        num, den, n_exact = _cancel_pairs(num, den, EXACT_CANCEL_TOL, "leading")
        if den.size - 1 <= order:
            if n_exact == 0:
                return self
            return self._derived(num, den, "reduce: removed exact pole-zero cancellations",
                                 {"reduce_order": int(order)})
        poles = _roots(den)
        if np.any(poles.real >= 0):
            raise OptionError("reduce needs a stable velocity transfer function; "
                              "cancel near pole-zero pairs first (cancel_near)")
        import control  # python-control is imported where its objects or algorithms are used

        a, b, c, d = (np.asarray(m, dtype=float) for m in lti.tf2ss(num, den))
        ab, bb, cb = _balance(a, b, c)
        bal = control.ss(ab, bb, cb, d)
        if ab.shape[0] > order:
            # modred(matchdc) = singular perturbation: G_r(0) == G(0) exactly.
            bal = control.modred(bal, list(range(order, ab.shape[0])), method="matchdc")
        red_num, red_den = _tf_coeffs(control.ss2tf(bal))
        note = f"reduce: balanced truncation (DC-matched) of the velocity TF to order {order}"
        return self._derived(red_num, red_den, note, {"reduce_order": int(order)})

    def _derived(self, num: np.ndarray, den: np.ndarray, note: str, extra_settings: Mapping[str, Any]) -> MotorModel:
        return model_from_velocity_tf(
            num, den,
            with_position="position" in self.outputs,
            step_volts=self.step_volts,
            method=self.method,
            settings={**self.settings, **extra_settings},
            sample_interval_s=self.sample_interval_s,
            fit={},
            warnings=(*self.warnings, note),
            extras={**self.extras, "derived_from_order": self.order},
            delay_s=self.delay_s,
            static_nonlinearity=self.static_nonlinearity,
            units=self.units,
            scales=self.scales,
        )

    # ------------------------------------------------------------- responses
    def step_response(self, time_s: Any, step_volts: float | None = None) -> dict[str, np.ndarray]:
        """Exact response of every output channel to a step applied at ``t = 0``.

        See :func:`motorid.model.response.step_response`.

        Parameters
        ----------
        time_s : array_like
            Times in seconds (any grid).
        step_volts : float, optional
            Step level; defaults to the model's ``step_volts``.

        Returns
        -------
        dict of str to ndarray
            One array per output channel, in volts.
        """
        from motorid.model.response import step_response

        return step_response(self, time_s, step_volts)

    def t63_s(self) -> float:
        """Seconds from the step until the velocity first reaches 63.2 % of its final change.

        The time a student reads off the scope (dead time included); for more than one pole it is
        not the mean residence time :meth:`residence_time_s`.

        Returns
        -------
        float
            NaN for a velocity channel that does not settle (an unstable or integrating model).
        """
        fo = self.first_order()
        dc = self.dc_gain()
        if not (np.isfinite(dc) and dc != 0 and np.isfinite(fo.time_constant_s)) or np.any(np.real(self.poles()) >= 0):
            return float("nan")
        slowest = float(np.max(1.0 / np.abs(np.real(self.poles())))) if self.poles().size else 0.0
        horizon = self.delay_s + 10.0 * max(abs(fo.time_constant_s), slowest)
        t = np.linspace(0.0, horizon, 4001)
        y = self.step_response(t, 1.0)["velocity"] / dc
        above = np.flatnonzero(y >= 1.0 - np.exp(-1.0))
        if above.size == 0 or above[0] == 0:
            return float("nan")
        i = int(above[0])
        # linear interpolation between two samples 1/400 of the horizon apart
        return float(t[i - 1] + (t[i] - t[i - 1]) * ((1.0 - np.exp(-1.0)) - y[i - 1]) / (y[i] - y[i - 1]))

    def residence_time_s(self) -> float:
        """Mean residence time of the velocity step response: τ by moments plus the dead time (s).

        Returns
        -------
        float
            ``first_order().time_constant_s + delay_s``.
        """
        return self.first_order().time_constant_s + self.delay_s

    def fit_nrmse(self, time_s: Any, measured: Any, channel: str = "velocity",
                  step_volts: float | None = None) -> float:
        """NRMSE of this model's step response against a measured one (see :func:`step_nrmse`).

        Parameters
        ----------
        time_s : array_like
            Times of the measured samples in s (the step at 0).
        measured : array_like
            The measured channel in volts.
        channel : str
            The output channel compared (default ``velocity``).
        step_volts : float, optional
            Step level; defaults to the model's.

        Returns
        -------
        float
            The NRMSE (RMS error over the measured steady-state change).
        """
        from motorid.model.response import step_nrmse

        return step_nrmse(self, time_s, measured, channel=channel, step_volts=step_volts)

    # ----------------------------------------------------------------- export
    def to_json(self) -> dict[str, Any]:
        """The model as the docs/formats.md "Model JSON" dict (schema ``motorid.model/1``).

        See :func:`motorid.model.serialize.model_to_dict`.

        Returns
        -------
        dict
            Plain JSON types only.
        """
        return model_to_dict(self)

    def to_dict(self) -> dict[str, Any]:
        """The model JSON as a dict (:meth:`to_json` is the older name of the same).

        Returns
        -------
        dict
            JSON-able; :meth:`to_json_text` is its text.
        """
        return self.to_json()

    def to_json_text(self) -> str:
        """:meth:`to_json` as indented JSON text (non-finite numbers written as null).

        Returns
        -------
        str
            The JSON text.
        """
        return json.dumps(self.to_json(), indent=2)

    @classmethod
    def from_json(cls, data: Mapping[str, Any], *, file: str | None = None) -> MotorModel:
        """Rebuild a model from :meth:`to_json` output.

        Parameters
        ----------
        data : Mapping
            The decoded JSON object.
        file : str, optional
            Where it came from, named in error messages.

        Returns
        -------
        MotorModel

        Raises
        ------
        ModelFormatError
            On a wrong schema, a missing key or inconsistent matrix shapes.
        """
        try:
            return model_from_dict(cls, data)
        except ModelFormatError as exc:
            raise ModelFormatError(f"not a motorid model: {exc.message}", file=file) from None
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
            raise ModelFormatError(f"not a motorid model: bad or missing entry ({exc!s})", file=file) from None

    def to_matlab(self, name: str = "motor") -> str:
        """An Octave/MATLAB script defining ``A, B, C, D``, ``sys = ss(A,B,C,D)`` and TFs.

        See :func:`motorid.model.serialize.model_to_matlab`.

        Parameters
        ----------
        name : str
            Name given in the script's header comment.

        Returns
        -------
        str
            The script text.
        """
        return model_to_matlab(self, name)

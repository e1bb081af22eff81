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
from typing import Any

import control
import numpy as np
import scipy.linalg

from motorid.errors import ModelFormatError, OptionError

__all__ = [
    "SCHEMA",
    "CHANNELS",
    "ModelFormatError",
    "FirstOrder",
    "MotorModel",
    "model_from_velocity_tf",
    "step_nrmse",
]

SCHEMA = "motorid.model/1"
CHANNELS = ("position", "velocity", "current")

#: Default relative tolerance of :meth:`MotorModel.cancel_near`: a pole and a zero closer
#: than 2 % of the fastest pole's magnitude are treated as one numerical artefact
#: (paper eq. 39: the pair at -0.0189/-0.0048 is 0.6 % of 2.30 apart).
CANCEL_TOL_REL = 0.02
#: Pole-zero pairs closer than this (relative to the fastest pole) are one and the same
#: root split by round-off, and are always removed from a channel's transfer function.
EXACT_CANCEL_TOL = 1e-8


# ModelFormatError lives in motorid.errors with every other user-facing error; importable here


@dataclass(frozen=True, slots=True)
class FirstOrder:
    """Dominant first-order approximation ``dc_gain / (time_constant_s·s + 1)``.

    The paper writes the same model as ``k / (s + p)`` (Masoud 2019, eqs. 41, 43, 45), so
    ``k = dc_gain / time_constant_s`` and ``p = 1 / time_constant_s``.
    """

    dc_gain: float
    time_constant_s: float

    @property
    def k(self) -> float:
        """The paper's motor coefficient ``k`` in ``k/(s+p)``."""
        if not (math.isfinite(self.dc_gain) and math.isfinite(self.time_constant_s)):
            return float("nan")
        if self.time_constant_s == 0.0:
            return float("inf")
        return self.dc_gain / self.time_constant_s

    @property
    def p(self) -> float:
        """The paper's pole magnitude ``p`` in ``k/(s+p)`` (1/s)."""
        if not math.isfinite(self.time_constant_s):
            return float("nan")
        if self.time_constant_s == 0.0:
            return float("inf")
        return 1.0 / self.time_constant_s


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
    arr.setflags(write=False)
    return arr


def _normalise_tf(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Strip leading zeros and scale so that ``den[0] == 1``.

    A leading numerator coefficient that is round-off of a state-space → TF conversion
    (``-4e-16 s + 2.1``: a "zero" at 10¹⁶ rad/s) is dropped too: its term weighs less than
    1e-10 of the largest one at the fastest pole's frequency.
    """
    num = np.trim_zeros(np.atleast_1d(np.asarray(num, dtype=float)), "f")
    den = np.trim_zeros(np.atleast_1d(np.asarray(den, dtype=float)), "f")
    if num.size == 0:
        num = np.zeros(1)
    w = float(np.max(np.abs(np.roots(den)))) if den.size > 1 else 1.0
    w = w if np.isfinite(w) and w > 0 else 1.0
    while num.size > 1:
        weight = np.abs(num) * w ** np.arange(num.size - 1, -1, -1)
        if weight[0] >= 1e-10 * weight.max():
            break
        num = num[1:]
    lead = den[0]
    return num / lead, den / lead


def _tf_coeffs(tf: control.TransferFunction) -> tuple[np.ndarray, np.ndarray]:
    return _normalise_tf(np.asarray(tf.num[0][0]), np.asarray(tf.den[0][0]))


def _roots(poly: np.ndarray) -> np.ndarray:
    poly = np.trim_zeros(np.asarray(poly, dtype=float), "f")
    if poly.size <= 1:
        return np.zeros(0, dtype=complex)
    return np.roots(poly).astype(complex)


def _cancel_pairs(
    num: np.ndarray, den: np.ndarray, tol_rel: float, keep: str, record_s: float | None = None
) -> tuple[np.ndarray, np.ndarray, int]:
    """Cancel pole-zero pairs of ``num/den`` closer than ``tol_rel`` × the fastest pole.

    Real zeros pair only with real poles and complex ones with complex ones (whole
    conjugate pairs), so the polynomials stay real.  ``keep='leading'`` drops the factors
    as the paper does (eq. 39 → 41); ``keep='dc'`` rescales so the DC gain is unchanged;
    ``keep='auto'`` cancels only pairs slower than every pole that remains, as the paper does
    (what an equation-error fit leaves of the position integrator: a record cannot show
    their DC factor ``z/p``), and leaves a faster pair in (the record shows the steady state
    and the time constant it shapes).  With ``record_s`` (the length of the record the model
    was identified from) a pair whose pole the record resolves (``|p|·record ≥ 1``) is left
    in too, however slow against the other poles: the record shows its DC factor, so
    cancelling it would change the gain the data show (issue 11: a pole at −35.4 and a zero
    at −40.2 beside a 6972 rad/s pole took 12 % off the DC gain).
    """
    zeros = list(_roots(num))
    poles = list(_roots(den))
    if not zeros or not poles:
        return num, den, 0
    scale = max(abs(p) for p in poles)
    if scale == 0.0:
        scale = max(abs(z) for z in zeros)
    if scale == 0.0:
        return num, den, 0
    tol = tol_rel * scale
    imag_tol = 1e-9 * scale

    def is_real(x: complex) -> bool:
        return abs(x.imag) <= imag_tol

    n_cancelled = 0
    pairs: list[tuple[complex, complex]] = []
    while True:
        best: tuple[float, int, int] | None = None
        for iz, z in enumerate(zeros):
            if not is_real(z) and z.imag < 0:
                continue  # the upper-half member stands for the conjugate pair
            for ip, p in enumerate(poles):
                if is_real(z) != is_real(p) or (not is_real(p) and p.imag < 0):
                    continue
                d = abs(z - p)
                if d <= tol and (best is None or d < best[0]):
                    best = (d, iz, ip)
        if best is None:
            break
        _, iz, ip = best
        z, p = zeros[iz], poles[ip]
        drop_z = [iz]
        drop_p = [ip]
        if not is_real(z):
            drop_z.append(int(np.argmin([abs(w - z.conjugate()) if k != iz else np.inf
                                         for k, w in enumerate(zeros)])))
            drop_p.append(int(np.argmin([abs(w - p.conjugate()) if k != ip else np.inf
                                         for k, w in enumerate(poles)])))
        pairs += [(zeros[a], poles[b]) for a, b in zip(drop_z, drop_p)]
        zeros = [w for k, w in enumerate(zeros) if k not in drop_z]
        poles = [w for k, w in enumerate(poles) if k not in drop_p]
        n_cancelled += len(drop_z)
    if keep == "auto":
        # a pair at or above the slowest pole that remains is seen by the record: left in
        slowest = min((abs(w) for w in poles), default=np.inf)
        seen = [(z, p) for z, p in pairs
                if abs(p) >= slowest or (record_s is not None and abs(p) * record_s >= 1.0)]
        zeros += [z for z, _ in seen]
        poles += [p for _, p in seen]
        n_cancelled -= len(seen)
    if n_cancelled == 0:
        return num, den, 0
    new_num = num[0] * np.real(np.poly(zeros)) if zeros else np.array([num[0]])
    new_den = np.real(np.poly(poles)) if poles else np.array([1.0])
    if keep == "dc":
        old_dc = _dc(num, den)
        new_dc = _dc(new_num, new_den)
        if math.isfinite(old_dc) and math.isfinite(new_dc) and old_dc != 0 and new_dc != 0:
            new_num = new_num * (old_dc / new_dc)
    return np.atleast_1d(new_num), np.atleast_1d(new_den), n_cancelled


def _dc(num: np.ndarray, den: np.ndarray) -> float:
    if den[-1] == 0.0:
        return float("inf") if num[-1] != 0.0 else float("nan")
    return float(num[-1] / den[-1])


def _state_names(n: int) -> tuple[str, ...]:
    return tuple(f"x{i + 1}" for i in range(n))


def model_from_velocity_tf(
    num: Any,
    den: Any,
    *,
    with_position: bool = False,
    **meta: Any,
) -> "MotorModel":
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
        vstates = ("velocity",) if d == 0.0 else ("x1",)
    else:
        sys = control.tf2ss(control.tf(num, den))
        a, b_col, c_row, d_val = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
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
    return MotorModel(A=a_ext, B=b_ext, C=c_ext, D=d_ext, states=("position",) + vstates,
                      outputs=("position", "velocity"), **meta)


def _jsonable(value: Any) -> Any:
    """Convert numpy scalars/arrays, tuples and mappings to plain JSON types."""
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, (np.floating, float)):
        f = float(value)
        return f if math.isfinite(f) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return _jsonable(dataclasses.asdict(value))
    return value


def _complex_pairs(values: np.ndarray) -> list[list[float]]:
    order = np.lexsort((np.imag(values), np.real(values)))
    return [[float(np.real(values[i])), float(np.imag(values[i]))] for i in order]


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
    uncertainty : Mapping
        Standard deviations and 95% intervals of ``dc_gain``, ``time_constant``, poles and
        zeros (written as the top-level ``uncertainty`` key when present).
    stages : tuple of Mapping
        What each stage of ``--method auto`` found (the top-level ``stages`` key).
    delay_s : float
        Dead time between the input and every output, seconds (0: none).  Not part of the
        state-space matrices (a delay has no finite realisation): responses and fits apply
        it, and the JSON carries it as the top-level ``delay_s`` (CONTRACT.md).

    Raises
    ------
    ModelFormatError
        On inconsistent shapes, unknown channel names or non-finite entries.
    """

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
    uncertainty: Mapping[str, Any] = field(default_factory=dict)
    stages: tuple[Mapping[str, Any], ...] = ()
    delay_s: float = 0.0

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
        object.__setattr__(self, "uncertainty", MappingProxyType(dict(self.uncertainty)))
        object.__setattr__(self, "stages", tuple(MappingProxyType(dict(st)) for st in self.stages))
        delay = float(self.delay_s or 0.0)
        if not (math.isfinite(delay) and delay >= 0.0):
            raise ModelFormatError(f"delay_s must be a finite number ≥ 0, got {self.delay_s!r}")
        object.__setattr__(self, "delay_s", delay)

    # ------------------------------------------------------------------ basics
    @property
    def order(self) -> int:
        """Number of states."""
        return int(self.A.shape[0])

    def replace(self, **changes: Any) -> "MotorModel":
        """Return a copy with some fields changed (``dataclasses.replace``)."""
        return dataclasses.replace(self, **changes)

    def ss(self) -> control.StateSpace:
        """The model as a python-control ``StateSpace`` (one output per channel)."""
        return control.ss(self.A, self.B, self.C, self.D, inputs=["u"],
                          outputs=list(self.outputs), states=list(self.states))

    def _row(self, channel: str) -> tuple[np.ndarray, np.ndarray]:
        i = self.outputs.index(channel)
        return self.C[i:i + 1], self.D[i:i + 1]

    def _row_tf(self, channel: str) -> tuple[np.ndarray, np.ndarray]:
        c, d = self._row(channel)
        num, den = _tf_coeffs(control.ss2tf(self.A, self.B, c, d))
        # ss2tf does not remove states the channel cannot see (e.g. the position integrator
        # seen from the velocity row); cancel pairs that coincide to round-off.
        num, den, _ = _cancel_pairs(num, den, EXACT_CANCEL_TOL, "leading")
        return _normalise_tf(num, den)

    def velocity_tf(self) -> control.TransferFunction:
        """Input volts → velocity-channel volts, ``den[0] == 1`` (Masoud 2019, eq. 9)."""
        return control.tf(*self._row_tf("velocity"))

    def position_tf(self) -> control.TransferFunction:
        """Input volts → position channel; velocity TF / s when there is no position output."""
        if "position" in self.outputs:
            return control.tf(*self._row_tf("position"))
        num, den = self._row_tf("velocity")
        return control.tf(num, np.polymul(den, [1.0, 0.0]))

    def current_tf(self) -> control.TransferFunction | None:
        """Input volts → current channel, or None when the model has no current output."""
        if "current" not in self.outputs:
            return None
        return control.tf(*self._row_tf("current"))

    def poles(self) -> np.ndarray:
        """Poles of the velocity transfer function (complex array)."""
        return _roots(self._row_tf("velocity")[1])

    def zeros(self) -> np.ndarray:
        """Zeros of the velocity transfer function (complex array)."""
        return _roots(self._row_tf("velocity")[0])

    def dc_gain(self) -> float:
        """Steady-state velocity per input volt (``inf`` for an integrating velocity TF)."""
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
    def cancel_near(self, tol_rel: float = CANCEL_TOL_REL, *, keep: str = "leading") -> "MotorModel":
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

    def reduce(self, order: int) -> "MotorModel":
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
        sys = control.tf2ss(control.tf(num, den))
        a, b, c, d = (np.asarray(m, dtype=float) for m in (sys.A, sys.B, sys.C, sys.D))
        ab, bb, cb = _balance(a, b, c)
        bal = control.ss(ab, bb, cb, d)
        if ab.shape[0] > order:
            # modred(matchdc) = singular perturbation: G_r(0) == G(0) exactly.
            bal = control.modred(bal, list(range(order, ab.shape[0])), method="matchdc")
        red_num, red_den = _tf_coeffs(control.ss2tf(bal))
        note = f"reduce: balanced truncation (DC-matched) of the velocity TF to order {order}"
        return self._derived(red_num, red_den, note, {"reduce_order": int(order)})

    def _derived(self, num: np.ndarray, den: np.ndarray, note: str, extra_settings: Mapping[str, Any]) -> "MotorModel":
        return model_from_velocity_tf(
            num, den,
            with_position="position" in self.outputs,
            step_volts=self.step_volts,
            method=self.method,
            settings={**self.settings, **extra_settings},
            sample_interval_s=self.sample_interval_s,
            fit={},
            warnings=self.warnings + (note,),
            extras={**self.extras, "derived_from_order": self.order},
        )

    # ------------------------------------------------------------- responses
    def step_response(self, time_s: Any, step_volts: float | None = None) -> dict[str, np.ndarray]:
        """Exact response of every output channel to a step applied at ``t = 0``.

        Exact for a step on any grid: the matrix exponential of ``[[A, B], [0, 0]]`` once
        per sample interval on a uniform grid (then a recursion), at each time otherwise;
        samples before 0 (before ``delay_s`` for a model with a dead time) are zero.

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

        Raises
        ------
        OptionError
            When no step level is given or known.
        """
        step = self.step_volts if step_volts is None else float(step_volts)
        if step is None:
            raise OptionError("step_response needs step_volts (the model has none)")
        t = np.asarray(time_s, dtype=float).ravel() - self.delay_s
        n = self.order
        m = np.zeros((n + 1, n + 1))
        m[:n, :n] = self.A
        m[:n, n] = self.B[:, 0]
        after = t >= 0
        x = np.zeros((t.size, n))
        if np.any(after):
            ta = t[after]
            d = np.diff(ta)
            with np.errstate(over="ignore", invalid="ignore"):  # unstable models overflow
                if ta.size > 2 and np.all(np.abs(d - d[0]) <= 1e-9 * max(abs(d[0]), 1e-300)):
                    # uniform grid: one exact step matrix, then the recursion
                    # x[k+1] = Φ x[k] + Γ·step (exact for a step; 100x faster than an expm
                    # per sample)
                    e1 = scipy.linalg.expm(m * d[0])
                    x0 = scipy.linalg.expm(m * ta[0])[:n, n] * step
                    x[after] = _affine_orbit(e1[:n, :n], e1[:n, n] * step, x0, ta.size)
                else:
                    e = scipy.linalg.expm(m[None, :, :] * ta[:, None, None])
                    x[after] = e[:, :n, n] * step
        with np.errstate(over="ignore", invalid="ignore"):
            y = x @ self.C.T + np.where(after[:, None], self.D[:, 0] * step, 0.0)
        return {name: y[:, i] for i, name in enumerate(self.outputs)}

    def fit_nrmse(self, time_s: Any, measured: Any, channel: str = "velocity",
                  step_volts: float | None = None) -> float:
        """NRMSE of this model's step response against a measured one (see :func:`step_nrmse`)."""
        return step_nrmse(self, time_s, measured, channel=channel, step_volts=step_volts)

    # ----------------------------------------------------------------- export
    def to_json(self) -> dict[str, Any]:
        """The model as the CONTRACT.md "Model JSON" dict (schema ``motorid.model/1``).

        ``state_space.C``/``D`` are the velocity row (the paper's ``C = [0 1 0]``); every
        output row is kept in ``state_space.outputs``.  Extra keys: ``outputs``,
        ``current_tf``, ``first_order.k``/``p``, ``settings``, ``extras``.
        """
        cv, dv = self._row("velocity")
        vnum, vden = self._row_tf("velocity")
        pnum, pden = _tf_coeffs(self.position_tf())
        fo = self.first_order()
        data: dict[str, Any] = {
            "schema": SCHEMA,
            "method": self.method,
            "order": self.order,
            "step_volts": self.step_volts,
            "sample_interval": self.sample_interval_s,
            "states": list(self.states),
            "outputs": list(self.outputs),
            "state_space": {
                "A": self.A.tolist(),
                "B": self.B.tolist(),
                "C": cv.tolist(),
                "D": dv.tolist(),
                "outputs": {name: {"C": self.C[i].tolist(), "D": float(self.D[i, 0])}
                            for i, name in enumerate(self.outputs)},
            },
            "velocity_tf": {"num": vnum.tolist(), "den": vden.tolist()},
            "position_tf": {"num": pnum.tolist(), "den": pden.tolist()},
            "first_order": {"dc_gain": fo.dc_gain, "time_constant": fo.time_constant_s,
                            "k": fo.k, "p": fo.p},
            "poles": _complex_pairs(_roots(vden)),
            "zeros": _complex_pairs(_roots(vnum)),
            "fit": dict(self.fit),
            "warnings": list(self.warnings),
            "settings": dict(self.settings),
            "extras": dict(self.extras),
        }
        cur = self.current_tf()
        if cur is not None:
            cnum, cden = _tf_coeffs(cur)
            data["current_tf"] = {"num": cnum.tolist(), "den": cden.tolist()}
        if self.uncertainty:
            data["uncertainty"] = dict(self.uncertainty)
        if self.stages:
            data["stages"] = [dict(st) for st in self.stages]
        if self.delay_s > 0:
            data["delay_s"] = self.delay_s
        return _jsonable(data)

    def to_json_text(self) -> str:
        """:meth:`to_json` as indented JSON text (non-finite numbers written as null)."""
        return json.dumps(self.to_json(), indent=2)

    @classmethod
    def from_json(cls, data: Mapping[str, Any], *, file: str | None = None) -> "MotorModel":
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
            return cls._from_json(data)
        except ModelFormatError as exc:
            raise ModelFormatError(f"not a motorid model: {exc.message}", file=file) from None
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
            raise ModelFormatError(f"not a motorid model: bad or missing entry ({exc!s})", file=file) from None

    @classmethod
    def _from_json(cls, data: Mapping[str, Any]) -> "MotorModel":
        if not isinstance(data, Mapping):
            raise ModelFormatError("expected a JSON object")
        schema = data.get("schema")
        if schema != SCHEMA:
            raise ModelFormatError(f"schema is {schema!r}, expected {SCHEMA!r}")
        for key in ("method", "states", "state_space"):
            if key not in data:
                raise ModelFormatError(f"missing key {key!r}")
        ss = data["state_space"]
        if not isinstance(ss, Mapping):
            raise ModelFormatError("state_space must be an object")
        for key in ("A", "B", "C", "D"):
            if key not in ss:
                raise ModelFormatError(f"missing key 'state_space.{key}'")
        rows = ss.get("outputs")
        if rows:
            outputs = tuple(rows)
            c = [rows[o]["C"] for o in outputs]
            d = [[rows[o]["D"]] for o in outputs]
        else:
            outputs, c, d = ("velocity",), ss["C"], ss["D"]
        fit = data.get("fit") or {}
        return cls(
            A=ss["A"], B=ss["B"], C=c, D=d,
            states=tuple(data["states"]),
            outputs=outputs,
            step_volts=data.get("step_volts"),
            method=data["method"],
            settings=data.get("settings") or {},
            sample_interval_s=data.get("sample_interval"),
            fit={k: (float("nan") if v is None else v) for k, v in fit.items()},
            warnings=tuple(data.get("warnings") or ()),
            extras=data.get("extras") or {},
            uncertainty=data.get("uncertainty") or {},
            stages=tuple(data.get("stages") or ()),
            delay_s=data.get("delay_s") or 0.0,
        )

    def to_matlab(self, name: str = "motor") -> str:
        """An Octave/MATLAB script defining ``A, B, C, D``, ``sys = ss(A,B,C,D)`` and TFs.

        ``C``/``D`` are the velocity row (the paper's convention, eq. 8); every output row
        is also given as ``C_<channel>``/``D_<channel>``.
        """

        def mat(m: np.ndarray) -> str:
            return "[" + "; ".join(" ".join(f"{v:.17g}" for v in row) for row in m) + "]"

        def vec(v: np.ndarray) -> str:
            return "[" + " ".join(f"{x:.17g}" for x in v) + "]"

        cv, dv = self._row("velocity")
        vnum, vden = self._row_tf("velocity")
        pnum, pden = _tf_coeffs(self.position_tf())
        fo = self.first_order()
        lines = [
            f"% {name}: DC servo-motor model identified by motorid (method: {self.method})",
            f"% states x = [{', '.join(self.states)}]; input u = amplifier volts"
            + ("" if self.step_volts is None else f" (step {self.step_volts:g} V)"),
            "% outputs: " + ", ".join(self.outputs) + " (volts); C, D give the velocity channel",
            f"A = {mat(self.A)};",
            f"B = {mat(self.B)};",
            f"C = {mat(cv)};",
            f"D = {mat(dv)};",
        ]
        for i, ch in enumerate(self.outputs):
            lines.append(f"C_{ch} = {mat(self.C[i:i + 1])};")
            lines.append(f"D_{ch} = {mat(self.D[i:i + 1])};")
        lines += [
            "sys = ss(A, B, C, D);",
            *([f"sys.InputDelay = {self.delay_s:.17g};  % dead time, s"] if self.delay_s > 0 else []),
            f"Hv = tf({vec(vnum)}, {vec(vden)});  % velocity TF",
            f"Hp = tf({vec(pnum)}, {vec(pden)});  % position TF",
            f"% first-order approximation: dc_gain = {fo.dc_gain:.6g}, tau = {fo.time_constant_s:.6g} s"
            f" (k = {fo.k:.6g}, p = {fo.p:.6g})",
        ]
        for w in self.warnings:
            lines.append(f"% warning: {w}")
        return "\n".join(lines) + "\n"


def _affine_orbit(phi: np.ndarray, gam: np.ndarray, x0: np.ndarray, count: int) -> np.ndarray:
    """``x[0] = x0``, ``x[k] = Φ x[k−1] + Γ`` for ``k < count``, without a Python loop per sample.

    The affine map ``x ↦ Φx + Γ`` composed with itself ``m`` times is ``x ↦ Φᵐx + c_m`` with
    ``c_2m = Φᵐ c_m + c_m``: each doubling extends the orbit by a batched product, so a
    300 000-sample record costs 19 numpy products instead of 300 000 Python iterations
    (scipy's ``dlsim`` loops in Python; ``lfilter`` would need ``ss2tf``, ill-conditioned
    for the wide pole spreads of motor models).
    """
    n = x0.size
    out = np.empty((count, n))
    out[0] = x0
    power, offset, m = phi.copy(), gam.copy(), 1
    while m < count:
        k = min(m, count - m)
        out[m : m + k] = out[:k] @ power.T + offset
        offset = power @ offset + offset
        power = power @ power
        m *= 2
    return out


def _balance(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Square-root balanced realisation of a stable system, dropping zero Hankel values.

    Hand-written because python-control's ``balred``/``balreal`` need slycot, which is not
    a dependency; the gramians come from scipy's Lyapunov solver.
    """
    wc = scipy.linalg.solve_continuous_lyapunov(a, -b @ b.T)
    wo = scipy.linalg.solve_continuous_lyapunov(a.T, -c.T @ c)

    def factor(w: np.ndarray) -> np.ndarray:
        lam, vec = np.linalg.eigh((w + w.T) / 2)
        return vec * np.sqrt(np.clip(lam, 0.0, None))

    lc, lo = factor(wc), factor(wo)
    u, hsv, vt = np.linalg.svd(lo.T @ lc)
    keep = hsv > hsv[0] * 1e-12
    u, hsv, v = u[:, keep], hsv[keep], vt[keep].T
    t = lc @ v / np.sqrt(hsv)
    ti = (u / np.sqrt(hsv)).T @ lo.T
    return ti @ a @ t, ti @ b, c @ t


def step_nrmse(
    model: MotorModel,
    time_s: Any,
    measured: Any,
    *,
    channel: str = "velocity",
    step_volts: float | None = None,
) -> float:
    """RMS of (measured − model) step response divided by the measured steady state.

    Parameters
    ----------
    model : MotorModel
    time_s : array_like
        Sample times in seconds, 0 at the step edge.
    measured : array_like
        The measured channel in volts, same length as ``time_s``.
    channel : str
        Output channel to compare.
    step_volts : float, optional
        Step level; defaults to the model's.

    Returns
    -------
    float
        ``sqrt(mean((y − ŷ)²)) / |mean of the last 10 % of y|`` (CONTRACT.md,
        ``fit.velocity_nrmse``).

    Raises
    ------
    OptionError
        On mismatched lengths, an unknown channel or a zero steady state.
    """
    t = np.asarray(time_s, dtype=float).ravel()
    y = np.asarray(measured, dtype=float).ravel()
    if t.size != y.size or t.size < 2:
        raise OptionError(f"step_nrmse needs equally long time and data arrays, got {t.size} and {y.size}")
    if channel not in model.outputs and channel != "position":
        raise OptionError(f"the model has no {channel!r} output; it has {list(model.outputs)}")
    if channel in model.outputs:
        yhat = model.step_response(t, step_volts)[channel]
    else:
        # Position of a velocity-only model: integral of the velocity output.
        step = model.step_volts if step_volts is None else float(step_volts)
        if step is None:
            raise OptionError("step_nrmse needs step_volts (the model has none)")
        integ = model_from_velocity_tf(*model._row_tf("velocity"), with_position=True)
        yhat = integ.step_response(t, step)["position"]
    tail = y[-max(1, y.size // 10):]
    final = float(np.mean(tail))
    if final == 0.0:
        raise OptionError(f"the measured {channel} has a zero steady state; NRMSE is undefined")
    # an unstable model's response overflows: its NRMSE is infinite, not a warning
    with np.errstate(over="ignore", invalid="ignore"):
        value = float(np.sqrt(np.mean((y - yhat) ** 2)) / abs(final))
    return value if np.isfinite(value) else float("inf")

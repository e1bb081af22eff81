"""What the data say about a model's parameters, typed: estimates, standard errors, intervals.

The model JSON's ``uncertainty`` and ``timing`` objects are produced from these types by
:meth:`Uncertainty.to_dict` and read back by :meth:`Uncertainty.from_dict`, and nowhere else:
the identification builds the typed objects from its fit, and every reader (the printout, the
report, the sanity gate, the robustness check, the front door's ``params``) reads their fields,
not JSON-shaped dicts.  It lives with the model because a
:class:`~motorid.model.motor.MotorModel` carries it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

import numpy as np

from motorid.conditioning.response import STEP_TIMINGS
from motorid.model.jsonview import JsonView
from motorid.frozen import frozen_getstate, frozen_setstate

__all__ = ["TIMING_KINDS", "TIMING_SOURCES", "ChannelTiming", "JointCovariance", "ParameterEstimate", "PolePair",
           "Uncertainty"]


@dataclass(frozen=True, slots=True)
class ParameterEstimate:
    """One identified quantity with its uncertainty (as lmfit's ``Parameter``).

    Attributes
    ----------
    value : float or complex
        The estimate (a complex pole or zero is a complex number).
    stderr : float
        Standard error (NaN when the method gives no interval).
    ci95 : tuple of (float, float) or None
        95 % interval (``None`` when the method gives none); for a complex pole or zero,
        the interval of its real part.
    unit : str
        The unit of ``value``, ``stderr`` and ``ci95`` (``rpm/V``, ``V/V``, ``s``, ``1/s``; empty
        when not set).
    structure_std : float or None
        The part of ``stderr`` that comes from the spread between candidate structures (model
        averaging); ``None`` when the interval is the chosen structure's own.
    """

    value: float | complex
    stderr: float = float("nan")
    ci95: tuple[float, float] | None = None
    unit: str = ""
    structure_std: float | None = None

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], *, root: bool = False) -> ParameterEstimate:
        """Read one ``{"value", "std", "ci95"[, "structure_std"]}`` object of the model JSON.

        Parameters
        ----------
        data : Mapping
            The JSON object; missing or ``null`` entries read as "not given".
        root : bool
            The value is a pole or zero written as ``[re, im]`` (kept complex, with its signs).

        Returns
        -------
        ParameterEstimate
        """
        raw = data.get("value")
        value: float | complex
        if root or isinstance(raw, (list, tuple)):
            re_, im_ = (_number(x) for x in (raw if isinstance(raw, (list, tuple)) else (raw, 0.0)))
            value = complex(re_, im_)
        else:
            value = _number(raw)
        ci = data.get("ci95")
        interval = None
        if isinstance(ci, (list, tuple)) and len(ci) == 2 and all(math.isfinite(_number(x)) for x in ci):
            interval = (float(ci[0]), float(ci[1]))
        extra = data.get("structure_std")
        return cls(value, _number(data.get("std")), interval, "", None if extra is None else float(extra))

    def to_dict(self) -> dict[str, Any]:
        """The model JSON's object: ``value`` (``[re, im]`` for a complex one), ``std``, ``ci95``.

        Returns
        -------
        dict
            ``ci95`` is ``[NaN, NaN]`` (JSON ``null``) when there is no interval.
        """
        value: Any = self.value
        if isinstance(value, complex):
            value = [float(value.real), float(value.imag)]
        lo, hi = self.ci95 if self.ci95 is not None else (float("nan"), float("nan"))
        out: dict[str, Any] = {"value": value, "std": float(self.stderr), "ci95": [lo, hi]}
        if self.structure_std is not None:
            out["structure_std"] = float(self.structure_std)
        return out

    def interval_or_nan(self) -> tuple[float, float]:
        """``ci95``, or ``(NaN, NaN)`` when there is none.

        Returns
        -------
        tuple of (float, float)
        """
        return self.ci95 if self.ci95 is not None else (float("nan"), float("nan"))


def _number(value: Any) -> float:
    """A JSON number as a float; ``null`` (and anything not a number) as NaN."""
    try:
        return float(value)
    except (TypeError, ValueError):
        return float("nan")


def _estimate(data: Any, *, root: bool = False) -> ParameterEstimate | None:
    return ParameterEstimate.from_dict(data, root=root) if isinstance(data, Mapping) else None


@dataclass(frozen=True, slots=True)
class PolePair:
    """Two neighbouring poles the data know only as a pair (each one's interval holds the other).

    Attributes
    ----------
    poles : tuple of (int, int)
        Their indices in :attr:`Uncertainty.poles` (slowest first, from 0).
    natural_frequency : ParameterEstimate
        ``√(p₁ p₂)``, rad/s.
    damping : ParameterEstimate
        ``−(p₁ + p₂) / (2 √(p₁ p₂))``.
    """

    poles: tuple[int, int]
    natural_frequency: ParameterEstimate
    damping: ParameterEstimate

    def to_dict(self) -> dict[str, Any]:
        """The model JSON's ``uncertainty.pole_pairs`` entry.

        Returns
        -------
        dict
        """
        return {"poles": list(self.poles), "natural_frequency": self.natural_frequency.to_dict(),
                "damping": self.damping.to_dict()}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> PolePair:
        """Read a ``pole_pairs`` entry (a missing estimate reads as NaN)."""
        i, j = (int(k) for k in data["poles"])
        nan = ParameterEstimate(float("nan"))
        return cls((i, j), _estimate(data.get("natural_frequency")) or nan, _estimate(data.get("damping")) or nan)


@dataclass(frozen=True, slots=True, eq=False)
class JointCovariance:
    """The parameters that define the motor and their joint covariance (``uncertainty.joint``).

    What a robustness check draws plausible motors from
    (:func:`motorid.model.motor.realise_tfs` rebuilds each).

    Attributes
    ----------
    parameters : tuple of str
        ``K``, ``log_tau_i``, ``Tz_j``, ``delay``, ``c``, ``cur_j`` (the output-error fit's names).
    values : ndarray, shape (k,)
        Their estimates (read-only).
    covariance : ndarray, shape (k, k)
        Their covariance, rows in the same order (read-only).
    """

    parameters: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray

    def __post_init__(self) -> None:
        names = tuple(str(n) for n in self.parameters)
        values = np.array(self.values, dtype=float)
        cov = np.array(self.covariance, dtype=float)
        k = len(names)
        if values.shape != (k,) or cov.shape != (k, k):
            raise ValueError(f"joint covariance: {k} parameters, values of shape {values.shape}, covariance of "
                             f"shape {cov.shape}")
        values.flags.writeable = False
        cov.flags.writeable = False
        object.__setattr__(self, "parameters", names)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "covariance", cov)

    def to_dict(self) -> dict[str, Any]:
        """The model JSON's ``uncertainty.joint``.

        Returns
        -------
        dict
        """
        return {"parameters": list(self.parameters), "values": [float(v) for v in self.values],
                "covariance": [[float(x) for x in row] for row in self.covariance]}


#: How each kind of step instant is described in the model JSON's ``uncertainty.timing``
#: (``step_instant``; its ``kind`` is the key).
TIMING_SOURCES: Mapping[str, str] = MappingProxyType({
    "logged": "the logged input's change (exact)",
    "sampled": "the scope's input edge, in the sample interval before the first sample at the new level: the "
               "captures' phases relative to each other are fitted (shift_s), their common instant is the "
               "interval's middle (±dt/√(12·n) in the intervals)",
    "onset": "read off the response (no input channel): its shift is fitted",
    "given": "--t0 (t0_s)",
})
#: The kinds of step instant (:attr:`ChannelTiming.kind`): the conditioning's own.
TIMING_KINDS = STEP_TIMINGS


@dataclass(frozen=True, slots=True)
class ChannelTiming:
    """Where one channel's step instant comes from, and its fitted shift (``timing`` in the JSON).

    Attributes
    ----------
    step_instant : str
        In words (the logged input's change, the scope's input edge, read off the response, ``--t0``).
    edge_s : float
        The instant on the file's time axis, seconds.
    shift : ParameterEstimate or None
        The fitted shift, seconds (positive: the model's step is that much later than the edge);
        ``None`` when the channel's instant is fixed.
    note : str or None
        What else the reader needs to know (a shift that is the dead time).
    kind : str or None
        The same source as a word a program can test (:data:`TIMING_KINDS`): ``logged``,
        ``sampled``, ``onset`` (read off the response: no input channel) or ``given`` (``--t0``);
        ``None`` when not known.
    window_s : float
        The window each of the channel's samples is the mean over, ending at its time (a speed
        counted over each sample interval, fitted as such means); 0 for samples.
    count_hold : int
        Lines each count is kept for (1: a new one every line): its window ends at the last line
        that logged it, and only those lines are fitted.
    """

    step_instant: str
    edge_s: float
    shift: ParameterEstimate | None = None
    note: str | None = None
    kind: str | None = None
    window_s: float = 0.0
    count_hold: int = 1

    @property
    def counting_lag_s(self) -> float:
        """How much a read-off on the counted record lags the motor: half the window, and half the hold.

        Returns
        -------
        float
            ``window·(2·hold − 1)/(2·hold)``; 0 for samples.
        """
        return self.window_s * (2 * self.count_hold - 1) / (2 * self.count_hold)

    def to_dict(self) -> dict[str, Any]:
        """The model JSON's ``timing`` entry of this channel.

        Returns
        -------
        dict
        """
        out: dict[str, Any] = {"step_instant": self.step_instant, "edge_s": float(self.edge_s)}
        if self.shift is not None:
            item = self.shift.to_dict()
            out.update(shift_s=item["value"], std=item["std"], ci95=item["ci95"])
        if self.note is not None:
            out["note"] = self.note
        if self.kind is not None:
            out["kind"] = self.kind
        if self.window_s > 0:
            out["window_s"] = float(self.window_s)
        if self.count_hold > 1:
            out["count_hold"] = int(self.count_hold)
        return out

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> ChannelTiming:
        """Read a ``timing`` entry (one written before ``kind`` existed gets it from its words)."""
        shift = None
        if isinstance(data.get("shift_s"), (int, float)):
            shift = ParameterEstimate.from_dict({"value": data["shift_s"], "std": data.get("std"),
                                                 "ci95": data.get("ci95")})
        note = data.get("note")
        words = str(data.get("step_instant", ""))
        kind = data.get("kind")
        if kind not in TIMING_KINDS:
            kind = next((k for k, text in TIMING_SOURCES.items() if words.startswith(text[:24])), None)
        window = data.get("window_s")
        hold = data.get("count_hold")
        return cls(words, _number(data.get("edge_s")), shift, None if note is None else str(note), kind,
                   float(window) if isinstance(window, (int, float)) and not isinstance(window, bool) else 0.0,
                   int(hold) if isinstance(hold, int) and not isinstance(hold, bool) and hold > 1 else 1)


def _quantiser(entry: Any, other: dict[str, Any]) -> dict[str, float]:
    """The JSON's ``quantiser`` (channel → code step); anything else is kept in ``other`` as it was."""
    if entry is None:
        return {}
    try:
        steps = {str(k): float(v) for k, v in entry.items()}
    except (AttributeError, TypeError, ValueError):
        steps = None
    if steps is None or not all(math.isfinite(v) and v > 0 for v in steps.values()):
        other["quantiser"] = entry
        return {}
    return steps


def _allowance(key: str, entry: Any, other: dict[str, Any]) -> float:
    """The JSON's ``onset_lag_s`` or ``counting_lag_s`` (s, at least 0); anything else is kept in ``other``."""
    if entry is None:
        return 0.0
    if isinstance(entry, (int, float)) and not isinstance(entry, bool) and math.isfinite(entry) and entry >= 0:
        return float(entry)
    other[key] = entry
    return 0.0


#: The typed top-level keys of ``uncertainty``, in the order the JSON has them.
_HEADLINE = ("dc_gain", "time_constant", "residence_time_s", "t63_s")


@dataclass(frozen=True, slots=True, eq=False)
class Uncertainty(JsonView):
    """A model's parameters with their standard errors and 95 % intervals.

    Also a read-only mapping with the model JSON's keys (``u["dc_gain"]["ci95"]``), as the JSON
    is; :meth:`to_dict` gives that object.

    Attributes
    ----------
    dc_gain, time_constant, residence_time_s, t63_s : ParameterEstimate or None
        The headline quantities (the data's gain unit; seconds).
    poles, zeros : tuple of ParameterEstimate
        The velocity transfer function's poles and zeros (complex values), slowest first.
    pole_pairs : tuple of PolePair
        Neighbouring poles known only as a pair.
    delay : ParameterEstimate or None
        The fitted dead time, seconds.
    joint : JointCovariance or None
        The motor's parameters and their joint covariance.
    timing : Mapping of str to ChannelTiming
        Each fitted channel's step instant and shift (the JSON's top-level ``timing``).
    method : str
        How the intervals were obtained, in words.
    quantiser : Mapping of str to float
        The channels whose intervals hold their quantiser's error along the record, each with
        its code step in the channel's unit (the JSON's ``quantiser``; empty for none).
    onset_lag_s : float
        How much higher the intervals of τ, the residence time and the 63 % time reach because
        the step instant was read off the response (no input channel): a lag shorter than half
        a sample cannot be told from a later instant (the JSON's ``onset_lag_s``; 0 for none).
    counting_lag_s : float
        How much lower the intervals of τ, the residence time and the 63 % time reach because a
        speed fitted as samples comes in whole counts: if it counts encoder edges over each line,
        each value is the mean over the line before it and the motor is quicker by half a line
        (``(2·h − 1)/2`` lines for a count kept over ``h`` lines; the JSON's ``counting_lag_s``; 0
        for none).
    other : Mapping
        Keys of the JSON object this type does not hold (written back as they were).
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    dc_gain: ParameterEstimate | None = None
    time_constant: ParameterEstimate | None = None
    residence_time_s: ParameterEstimate | None = None
    t63_s: ParameterEstimate | None = None
    poles: tuple[ParameterEstimate, ...] = ()
    zeros: tuple[ParameterEstimate, ...] = ()
    pole_pairs: tuple[PolePair, ...] = ()
    delay: ParameterEstimate | None = None
    joint: JointCovariance | None = None
    timing: Mapping[str, ChannelTiming] = field(default_factory=dict)
    method: str = ""
    quantiser: Mapping[str, float] = field(default_factory=dict)
    onset_lag_s: float = 0.0
    counting_lag_s: float = 0.0
    other: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        object.__setattr__(self, "quantiser", MappingProxyType({str(k): float(v) for k, v in self.quantiser.items()}))
        object.__setattr__(self, "onset_lag_s", float(self.onset_lag_s))
        object.__setattr__(self, "counting_lag_s", float(self.counting_lag_s))
        object.__setattr__(self, "poles", tuple(self.poles))
        object.__setattr__(self, "zeros", tuple(self.zeros))
        object.__setattr__(self, "pole_pairs", tuple(self.pole_pairs))
        object.__setattr__(self, "timing", MappingProxyType(dict(self.timing)))
        object.__setattr__(self, "other", MappingProxyType(dict(self.other)))

    def headline(self, key: str) -> ParameterEstimate | None:
        """``dc_gain``, ``time_constant``, ``residence_time_s`` or ``t63_s`` by its JSON key.

        Parameters
        ----------
        key : str
            One of the four keys.

        Returns
        -------
        ParameterEstimate or None
        """
        if key not in _HEADLINE:
            raise KeyError(key)
        return getattr(self, key)

    def paired_poles(self) -> set[int]:
        """Indices of the poles reported as part of a pair.

        Returns
        -------
        set of int
        """
        return {i for pair in self.pole_pairs for i in pair.poles}

    def replace(self, **changes: Any) -> Uncertainty:
        """A copy with some fields changed (:func:`dataclasses.replace`).

        Parameters
        ----------
        **changes
            Field names and their new values.

        Returns
        -------
        Uncertainty
        """
        return replace(self, **changes)

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Uncertainty:
        """Read the model JSON's ``uncertainty`` object (with ``timing`` in it, as the model holds it).

        Parameters
        ----------
        data : Mapping
            The decoded object.  Entries it does not know, and a ``joint`` whose shapes do not
            agree, are kept in :attr:`other` and written back unchanged.

        Returns
        -------
        Uncertainty
        """
        known = {*_HEADLINE, "poles", "zeros", "pole_pairs", "delay", "joint", "timing", "method", "quantiser",
                 "onset_lag_s", "counting_lag_s"}
        other = {k: v for k, v in data.items() if k not in known}
        joint = None
        entry = data.get("joint")
        if isinstance(entry, Mapping):
            try:
                joint = JointCovariance(tuple(entry["parameters"]), np.asarray(entry["values"], dtype=float),
                                        np.asarray(entry["covariance"], dtype=float))
            except (KeyError, TypeError, ValueError):
                other["joint"] = entry
        elif entry is not None:
            other["joint"] = entry
        timing = data.get("timing") or {}
        return cls(
            **{key: _estimate(data.get(key)) for key in _HEADLINE},
            poles=tuple(ParameterEstimate.from_dict(p, root=True) for p in data.get("poles") or ()),
            zeros=tuple(ParameterEstimate.from_dict(z, root=True) for z in data.get("zeros") or ()),
            pole_pairs=tuple(PolePair.from_dict(p) for p in data.get("pole_pairs") or ()),
            delay=_estimate(data.get("delay")),
            joint=joint,
            timing={str(k): ChannelTiming.from_dict(v) for k, v in timing.items() if isinstance(v, Mapping)},
            method=str(data.get("method") or ""),
            quantiser=_quantiser(data.get("quantiser"), other),
            onset_lag_s=_allowance("onset_lag_s", data.get("onset_lag_s"), other),
            counting_lag_s=_allowance("counting_lag_s", data.get("counting_lag_s"), other),
            other=other,
        )

    def to_dict(self) -> dict[str, Any]:
        """The ``uncertainty`` object of the model JSON, ``timing`` last.

        The serializer moves ``timing`` to the JSON's top level.

        Returns
        -------
        dict
        """
        out: dict[str, Any] = {}
        for key in _HEADLINE:
            item = getattr(self, key)
            if item is not None:
                out[key] = item.to_dict()
        out["poles"] = [p.to_dict() for p in self.poles]
        out["zeros"] = [z.to_dict() for z in self.zeros]
        if self.method:
            out["method"] = self.method
        if self.quantiser:
            out["quantiser"] = dict(self.quantiser)
        if self.onset_lag_s:
            out["onset_lag_s"] = self.onset_lag_s
        if self.counting_lag_s:
            out["counting_lag_s"] = self.counting_lag_s
        if self.pole_pairs:
            out["pole_pairs"] = [p.to_dict() for p in self.pole_pairs]
        if self.delay is not None:
            out["delay"] = self.delay.to_dict()
        if self.joint is not None:
            out["joint"] = self.joint.to_dict()
        out.update(self.other)
        if self.timing:
            out["timing"] = {role: t.to_dict() for role, t in self.timing.items()}
        return out

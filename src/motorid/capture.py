"""The capture data types: raw samples of one oscilloscope acquisition plus its metadata.

A *capture* is one acquisition of the step experiment: CH1 = the step input (volts),
CH2 = the measured quantity (volts).  Readers in :mod:`motorid.io` produce captures; the
virtual trainer produces them too; conditioning consumes them.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, overload

import numpy as np

from motorid.frozen import frozen_getstate, frozen_setstate
from motorid.errors import CaptureDataError

__all__ = ["ROLES", "Capture", "ChannelInfo", "ScopeInfo", "validate_samples"]

#: The measured quantities a capture's output channel can be.
ROLES: tuple[str, ...] = ("position", "velocity", "current")


@dataclass(frozen=True, slots=True)
class ChannelInfo:
    """Metadata of one recorded channel.

    Attributes
    ----------
    name : str
        ``"CH1"``, ``"CH2"`` … for scope files, the column header for plain CSV.
    units : str
        Vertical units as recorded (``"V"`` for scope channels).
    vertical_scale : float or None
        Volts per division (the 8-bit LSB is ``vertical_scale / 25``).
    vertical_offset : float or None
        Vertical offset in volts.
    probe_atten : float or None
        Probe attenuation factor as set on the scope (values are already scaled by it).
    yzero : float or None
        The scope's ``Yzero`` field.
    """

    name: str
    units: str = "V"
    vertical_scale: float | None = None
    vertical_offset: float | None = None
    probe_atten: float | None = None
    yzero: float | None = None

    @property
    def lsb(self) -> float | None:
        """Quantisation step in volts (8-bit, 25 levels per division), if known."""
        return None if self.vertical_scale is None else self.vertical_scale / 25.0


@dataclass(frozen=True, slots=True)
class ScopeInfo:
    """Acquisition metadata common to the channels of one capture.

    Attributes
    ----------
    model, serial, firmware : str or None
        ``Model Number``, ``Serial Number``, ``Firmware Version`` as written by the scope.
    record_length : int or None
        ``Record Length`` (2500 on the TDS1000/2000 series).
    horizontal_scale_s : float or None
        Seconds per division.
    trigger_index : int or None
        ``Trigger Point``: 0-based sample index of t = 0 on the file's time axis.
    """

    model: str | None = None
    serial: str | None = None
    firmware: str | None = None
    record_length: int | None = None
    horizontal_scale_s: float | None = None
    trigger_index: int | None = None


@overload
def _frozen_array(a: np.ndarray, copy: bool = True) -> np.ndarray: ...


@overload
def _frozen_array(a: None, copy: bool = True) -> None: ...


def _frozen_array(a: np.ndarray | None, copy: bool = True) -> np.ndarray | None:
    """A read-only float64 array of ``a``: a copy, or ``a`` itself when the caller hands it over.

    Handed over (``copy=False``), a contiguous float64 array is frozen in place (no second 80 MB
    column for a 10 M-row log); anything else is still converted.
    """
    if a is None:
        return None
    out = np.array(a, dtype=float, copy=True) if copy else np.ascontiguousarray(a, dtype=float)
    out.setflags(write=False)
    return out


@dataclass(frozen=True, slots=True)
class Capture:
    """One oscilloscope acquisition (or one logged experiment) as raw samples.

    Attributes
    ----------
    source : str
        The file or folder it was read from (``"<trainer>"`` for simulated data).
    format : str
        ``"tds2000-csv"``, ``"xlsx"``, ``"plain-csv"`` or ``"trainer"``.
    time_s : ndarray, shape (n,)
        Strictly increasing sample times, on the file's own time axis.
    output_v : ndarray, shape (n,)
        The measured channel (CH2), in its recorded units (volts for scope files).
    output_info : ChannelInfo
        Metadata of the output channel.
    input_v : ndarray or None
        The step input (CH1), or ``None`` when no input channel was recorded.
    input_info : ChannelInfo or None
        Metadata of the input channel.
    scope : ScopeInfo
        Acquisition metadata.
    role_hint : str or None
        Role declared by the file itself (column names, channel labels): one of
        :data:`ROLES`, else ``None``.  Guessing from the signal is done elsewhere.
    extra : Mapping[str, ndarray]
        Further channels of the same acquisition (plain CSV logs with more columns, CH3/CH4),
        keyed by their name.
    warnings : tuple of str
        Problems noticed while reading (clipping at the rails, re-saved files, …).
    stamp_resolution_s : float
        The resolution a log's jittered stamps were rounded to (``millis()``: 1 ms), so that a
        logged step instant carries it in the timing intervals; 0 for stamps taken as exact.
    sample_window_s : float
        The interval (s) each output sample is the mean over, ending at its time: a speed counted
        from the encoder edges since the last sample (``counted_velocity`` of
        :func:`motorid.read_experiment`, or the reader itself for ``count_over_stamps``); 0 for
        samples taken at their instant.
    count_step : float
        The step a log's output column comes in when it may count encoder edges over each line
        (its values, or their products with their stamped intervals, are whole multiples of one
        count: read off the raw column); 0 when it does not.  A sampled signal through an ADC
        comes in steps too: this says that the column may count, ``sample_window_s`` that it does.
    count_over_stamps : bool
        The output's values are on no grid, their products with their (jittered) stamped intervals
        are (``count_step`` times the median interval): each is a count over the interval its own
        clock measured, which no sampled reading is.  The reader then reads it as counted
        (``sample_window_s`` its median interval) unless it is declared, or named, a position or a
        current.
    count_hold : int
        Lines each value of such a column is kept for (a firmware that counts over several loops
        and logs every loop): 1 when it changes from line to line.
    """

    __getstate__ = frozen_getstate
    __setstate__ = frozen_setstate

    source: str
    format: str
    time_s: np.ndarray
    output_v: np.ndarray
    output_info: ChannelInfo
    input_v: np.ndarray | None = None
    input_info: ChannelInfo | None = None
    scope: ScopeInfo = field(default_factory=ScopeInfo)
    role_hint: str | None = None
    extra: Mapping[str, np.ndarray] = field(default_factory=dict)
    warnings: tuple[str, ...] = ()
    stamp_resolution_s: float = 0.0
    sample_window_s: float = 0.0
    count_step: float = 0.0
    count_over_stamps: bool = False
    count_hold: int = 1

    def __post_init__(self) -> None:
        self._freeze(copy=True)

    @classmethod
    def adopt(cls, **fields: Any) -> Capture:
        """A capture that takes over the arrays it is given instead of copying them.

        For the readers, which make their columns and keep no other reference to them: the
        arrays are made read-only in place (a contiguous float64 array is not copied), so a
        10 M-row log holds each column once.  The constructor copies (a caller's array stays its
        own); the checks are the same.

        Parameters
        ----------
        **fields
            The fields of :class:`Capture` by name (the same defaults).

        Returns
        -------
        Capture
            Whose arrays are the given ones, now read-only; the caller must not keep writable
            views of them.
        """
        self = cls.__new__(cls)
        for f in dataclasses.fields(cls):
            if f.name in fields:
                value = fields.pop(f.name)
            elif f.default is not dataclasses.MISSING:
                value = f.default
            elif f.default_factory is not dataclasses.MISSING:
                value = f.default_factory()
            else:
                raise TypeError(f"Capture.adopt() missing required field {f.name!r}")
            object.__setattr__(self, f.name, value)
        if fields:
            raise TypeError(f"Capture.adopt() got unexpected fields {sorted(fields)}")
        self._freeze(copy=False)
        return self

    def _freeze(self, *, copy: bool) -> None:
        """Check the fields and make the arrays read-only (copies of them unless ``copy=False``)."""
        t = _frozen_array(self.time_s, copy)
        y = _frozen_array(self.output_v, copy)
        u = _frozen_array(self.input_v, copy)
        if t.ndim != 1 or y.shape != t.shape or (u is not None and u.shape != t.shape):
            raise CaptureDataError(
                "time and channel columns have different lengths", file=self.source
            )
        if t.size < 2:
            raise CaptureDataError("fewer than 2 samples: not a usable capture", file=self.source)
        extra = {k: _frozen_array(v, copy) for k, v in self.extra.items()}
        for k, v in extra.items():
            if v.shape != t.shape:
                raise CaptureDataError(f"channel {k!r} has a different length", file=self.source)
        if self.role_hint is not None and self.role_hint not in ROLES:
            raise ValueError(f"role_hint must be one of {ROLES}, got {self.role_hint!r}")
        window = self.sample_window_s
        if isinstance(window, bool) or not isinstance(window, (int, float)) or not (math.isfinite(window)
                                                                                  and window >= 0):
            raise ValueError(f"sample_window_s must be a finite number ≥ 0, got {window!r}")
        step = self.count_step
        if isinstance(step, bool) or not isinstance(step, (int, float)) or not (math.isfinite(step) and step >= 0):
            raise ValueError(f"count_step must be a finite number ≥ 0, got {step!r}")
        if isinstance(self.count_hold, bool) or not isinstance(self.count_hold, int) or self.count_hold < 1:
            raise ValueError(f"count_hold must be a whole number ≥ 1, got {self.count_hold!r}")
        object.__setattr__(self, "time_s", t)
        object.__setattr__(self, "output_v", y)
        object.__setattr__(self, "input_v", u)
        object.__setattr__(self, "extra", MappingProxyType(extra))
        object.__setattr__(self, "warnings", tuple(self.warnings))

    @property
    def n_samples(self) -> int:
        """Number of samples in the record."""
        return int(self.time_s.size)

    @property
    def sample_interval_s(self) -> float:
        """Sample interval in seconds (median spacing of the time axis)."""
        return float(np.median(np.diff(self.time_s)))

    def counted(self) -> Capture:
        """The capture with each output sample the mean over its sample interval (a counted speed).

        What ``counted_velocity`` of :func:`motorid.read_experiment` and :func:`motorid.validate`
        declare: :attr:`sample_window_s` is the capture's own :attr:`sample_interval_s`, times
        :attr:`count_hold` for a count kept over several lines (a firmware that counts over five
        loops and logs every loop: each count spans five intervals); a capture that has a window
        already is returned as it is.

        Returns
        -------
        Capture
        """
        if self.sample_window_s:
            return self
        return dataclasses.replace(self, sample_window_s=self.sample_interval_s * self.count_hold)


def validate_samples(
    time_s: np.ndarray,
    channels: Mapping[str, np.ndarray],
    *,
    file: str,
    first_row: int = 1,
    rel_jitter: float = 0.01,
) -> None:
    """Check a record's samples and raise naming the first bad row.

    Parameters
    ----------
    time_s : ndarray
        Sample times as read.
    channels : Mapping[str, ndarray]
        The value columns, by name, same length as ``time_s``.
    file : str
        File name for the error message.
    first_row : int
        1-based file row of sample 0, so that errors name the row a user can open.
    rel_jitter : float
        Allowed deviation of any time step from the median step, relative.  Scope and DAQ
        records are uniformly sampled; a larger deviation means a gap or a corrupt file.

    Raises
    ------
    CaptureDataError
        On NaN/inf, non-increasing or duplicated times, or a non-uniform time axis.
    """
    t = np.asarray(time_s, dtype=float)
    for name, col in (("time", t), *channels.items()):
        col = np.asarray(col, dtype=float)
        if col.shape != t.shape:
            raise CaptureDataError(
                f"column {name!r} has {col.size} values but time has {t.size}", file=file
            )
        bad = np.flatnonzero(~np.isfinite(col))
        if bad.size:
            raise CaptureDataError(
                f"{name} is not a finite number (NaN or inf)", file=file, row=first_row + int(bad[0])
            )
    if t.size < 2:
        raise CaptureDataError("fewer than 2 samples: not a usable capture", file=file)
    dt = np.diff(t)
    bad = np.flatnonzero(dt <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        what = "duplicated" if dt[bad[0]] == 0 else "goes backwards"
        raise CaptureDataError(f"time {what} ({float(t[i - 1]):.10g} then {float(t[i]):.10g})",
                               file=file, row=first_row + i)
    med = float(np.median(dt))
    bad = np.flatnonzero(np.abs(dt - med) > rel_jitter * med + 1e-12 * max(1.0, float(np.max(np.abs(t)))))
    if bad.size:
        i = int(bad[0]) + 1
        raise CaptureDataError(
            f"time step {dt[bad[0]]:.6g} s differs from the sample interval {med:.6g} s "
            "(gap or corrupt record)",
            file=file,
            row=first_row + i,
        )

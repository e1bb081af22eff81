"""The SCPI dialogue of a TDS1000/TDS2000/TBS1000 acquisition (programmer manual 071-1075).

``HEADer OFF``; with ``single``: ``ACQuire:STOPAfter SEQuence``, ``ACQuire:STATE RUN`` and
``ACQuire:STATE?`` polled until the scope has triggered and stopped; without it the scope is
stopped (``ACQuire:STATE STOP``) so that every channel comes from the same record on screen.
Then per channel: ``SELect:CH<n>?`` (is it on?), ``DATa:SOUrce CH<n>``, ``DATa:ENCdg RIBinary``
(or ``ASCii``), ``DATa:WIDth 1``, ``DATa:STARt 1``, ``DATa:STOP 2500``, the preamble by keyword,
``CH<n>:SCAle?``, ``CH<n>:PRObe?`` and ``CURVe?``.

The instrument is anything with pyvisa's ``write``, ``query``, ``read_raw`` and ``read_bytes`` (a
``pyvisa.resources.MessageBasedResource``, or a test's fake).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from motorid.capture import ChannelInfo, ScopeInfo
from motorid.errors import AcquisitionTimeoutError, ChannelOffError, InstrumentError, OptionError
from motorid.io.acquire.curve import clipping_warning, decode_ascii_curve, decode_binary_curve
from motorid.io.acquire.preamble import Preamble, parse_field, query_preamble

__all__ = [
    "ENCODINGS",
    "RECORD_POINTS",
    "AcquireSettings",
    "Acquisition",
    "Identity",
    "Instrument",
    "Waveform",
    "acquire_waveforms",
    "parse_idn",
]

#: Points per record of the TDS1000/2000/TBS1000 (``DATa:STOP``).
RECORD_POINTS = 2500
#: Transfer encodings: binary (``RIBinary``, one signed byte a point) or ``ASCii``.
ENCODINGS: tuple[str, ...] = ("binary", "ascii")


class Instrument(Protocol):
    """What the acquisition needs of a VISA resource (pyvisa's message-based API)."""

    def write(self, message: str) -> object:
        """Send a command.

        Parameters
        ----------
        message : str
            The command, without termination.

        Returns
        -------
        object
            Whatever the resource returns (pyvisa: the byte count).
        """

    def query(self, message: str) -> str:
        """Send a query and return the answer.

        Parameters
        ----------
        message : str
            The query, without termination.

        Returns
        -------
        str
            The answer, termination stripped.
        """

    def read_raw(self) -> bytes:
        """Read one whole answer as bytes.

        Returns
        -------
        bytes
            Up to the end indicator (or a termination character, on interfaces that honour one).
        """

    def read_bytes(self, count: int) -> bytes:
        """Read exactly ``count`` bytes.

        Parameters
        ----------
        count : int
            How many.

        Returns
        -------
        bytes
            The bytes read.
        """


@dataclass(frozen=True, slots=True)
class AcquireSettings:
    """How to acquire.

    Attributes
    ----------
    channels : tuple of int
        Channels to read, 1–4 (CH1 = the step input, CH2 = the response on the trainer).
    single : bool
        Arm a single acquisition and wait for the trigger (``ACQuire:STOPAfter SEQuence``);
        ``False``: stop the scope and read the record on screen.
    timeout_s : float
        How long to wait for the trigger with ``single``.
    encoding : str
        ``"binary"`` (``RIBinary``; falls back to ASCII when the block is unreadable) or ``"ascii"``.
    poll_s : float
        Interval between ``ACQuire:STATE?`` polls.

    Raises
    ------
    OptionError
        A channel outside 1–4 or given twice, a non-positive timeout, an unknown encoding.
    """

    channels: tuple[int, ...] = (1, 2)
    single: bool = False
    timeout_s: float = 10.0
    encoding: str = "binary"
    poll_s: float = 0.05

    def __post_init__(self) -> None:
        chans = tuple(int(c) for c in self.channels)
        object.__setattr__(self, "channels", chans)
        if not chans or any(not 1 <= c <= 4 for c in chans) or len(set(chans)) != len(chans):
            raise OptionError(f"channels {self.channels!r}: give distinct channel numbers 1 to 4, e.g. 1,2")
        if not self.timeout_s > 0:
            raise OptionError(f"timeout must be > 0 s, got {self.timeout_s!r}")
        if self.encoding not in ENCODINGS:
            raise OptionError(f"encoding {self.encoding!r} is unknown: use one of {', '.join(ENCODINGS)}")
        if not self.poll_s > 0:
            raise OptionError(f"poll interval must be > 0 s, got {self.poll_s!r}")


@dataclass(frozen=True, slots=True)
class Identity:
    """The ``*IDN?`` answer: ``TEKTRONIX,TDS 2012C,C010001,CF:91.1CT FV:v24.26``.

    Attributes
    ----------
    maker, model, serial, firmware : str
        The four fields; ``firmware`` keeps the ``FV:`` part the scope writes into its CSV files.
    raw : str
        The answer as received.
    """

    maker: str
    model: str
    serial: str
    firmware: str
    raw: str


def parse_idn(answer: str) -> Identity:
    """Split an ``*IDN?`` answer into maker, model, serial and firmware.

    Parameters
    ----------
    answer : str
        The answer (``HEADer`` on or off).

    Returns
    -------
    Identity
        Missing fields are empty strings; the firmware is the ``FV:`` token when there is one
        (what the scope's own CSV files call ``Firmware Version``).
    """
    raw = answer.strip()
    text = raw.split(" ", 1)[1] if raw.upper().startswith(("*IDN ", "ID ")) else raw
    parts = [p.strip() for p in text.split(",")] + ["", "", "", ""]
    fw = parts[3]
    fv = next((tok for tok in fw.split() if tok.upper().startswith("FV:")), fw)
    return Identity(parts[0], parts[1], parts[2], fv, raw)


@dataclass(frozen=True, slots=True)
class Waveform:
    """One channel's record as the scope sent it.

    Attributes
    ----------
    channel : int
        1–4.
    codes : ndarray of int
        Digitiser codes, −128 … 127.
    preamble : Preamble
        The scaling (``WFMPre``).
    volts_per_div : float
        ``CH<n>:SCAle?``.
    probe_atten : float
        ``CH<n>:PRObe?``.
    warnings : tuple of str
        Clipping.
    """

    channel: int
    codes: np.ndarray
    preamble: Preamble
    volts_per_div: float
    probe_atten: float
    warnings: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        a = np.array(self.codes, dtype=np.int16, copy=True)
        a.setflags(write=False)
        object.__setattr__(self, "codes", a)
        object.__setattr__(self, "warnings", tuple(self.warnings))

    @property
    def name(self) -> str:
        """``"CH<n>"``."""
        return f"CH{self.channel}"

    @property
    def volts(self) -> np.ndarray:
        """The samples in volts (``(code − YOFF)·YMULT + YZERO``)."""
        return self.preamble.volts(self.codes)

    @property
    def time_s(self) -> np.ndarray:
        """The sample times (``XZERO + XINCR·(i − PT_OFF)``)."""
        return self.preamble.times(self.codes.size)

    @property
    def info(self) -> ChannelInfo:
        """The channel's metadata as the scope's CSV files record it.

        ``Vertical Offset`` is ``YOFF·YMULT``, so that the screen centre is ``Yzero −
        Vertical Offset`` as :func:`motorid.io._common.rail_clipping_warning` reads it.
        """
        p = self.preamble
        return ChannelInfo(name=self.name, units="V", vertical_scale=self.volts_per_div,
                           vertical_offset=p.yoff * p.ymult + 0.0, probe_atten=self.probe_atten, yzero=p.yzero)


@dataclass(frozen=True, slots=True)
class Acquisition:
    """The channels of one acquisition and the scope that made it.

    Attributes
    ----------
    resource : str
        The VISA resource name.
    identity : Identity
        ``*IDN?``.
    horizontal_scale_s : float
        ``HORizontal:MAIn:SCAle?``.
    waveforms : tuple of Waveform
        In the order of ``AcquireSettings.channels``.
    warnings : tuple of str
        Clipping, an ASCII fallback.
    """

    resource: str
    identity: Identity
    horizontal_scale_s: float
    waveforms: tuple[Waveform, ...]
    warnings: tuple[str, ...] = field(default=())

    @property
    def scope(self) -> ScopeInfo:
        """The scope metadata the CSV files record (``Model Number``, ``Serial Number``, …)."""
        n = self.waveforms[0].codes.size if self.waveforms else None
        return ScopeInfo(model=self.identity.model or None, serial=self.identity.serial or None,
                         firmware=self.identity.firmware or None, record_length=n,
                         horizontal_scale_s=self.horizontal_scale_s, trigger_index=None)


def _number(inst: Instrument, query: str) -> float:
    return parse_field(inst.query(query), query)


def _wait_for_trigger(inst: Instrument, settings: AcquireSettings, clock: Callable[[], float],
                      sleep: Callable[[float], None]) -> None:
    """Arm one acquisition and poll until the scope has stopped after it."""
    inst.write("ACQuire:STOPAfter SEQuence")
    inst.write("ACQuire:STATE RUN")
    deadline = clock() + settings.timeout_s
    while True:
        state = inst.query("ACQuire:STATE?").strip().rsplit(" ", 1)[-1]
        if state in ("0", "STOP", "OFF"):
            return
        if clock() >= deadline:
            inst.write("ACQuire:STATE STOP")
            raise AcquisitionTimeoutError(
                f"the scope did not trigger within --timeout {settings.timeout_s:g} s: check the trigger "
                "(source CH1, edge, a level the step crosses) and give the step while it waits, or a longer --timeout")
        sleep(settings.poll_s)


def _read_block(inst: Instrument) -> bytes:
    """The answer to ``CURVe?`` in binary: an IEEE 488.2 block read whole.

    A read that stops at a line-feed byte inside the data (interfaces that honour the
    termination character) is completed from the length the block's header gives, plus
    the scope's closing line feed, as pyvisa's ``read_binary_values`` does.
    """
    from pyvisa.util import parse_ieee_block_header

    inst.write("CURVe?")
    block = bytes(inst.read_raw())
    try:
        offset, length = parse_ieee_block_header(block)
    except ValueError:
        return block  # not a block: the decoder says so
    missing = offset + length - len(block)
    if missing > 0:
        block += bytes(inst.read_bytes(missing + 1))
    return block


def _read_curve(inst: Instrument, encoding: str, n_points: int, warnings: list[str], name: str) -> np.ndarray:
    if encoding == "ascii":
        return decode_ascii_curve(inst.query("CURVe?"), n_points=n_points)
    try:
        return decode_binary_curve(_read_block(inst), n_points=n_points)
    except InstrumentError as exc:
        # some interfaces (and simulators) garble binary blocks: the ASCII transfer is slower but plain text
        warnings.append(f"{name}: the binary transfer failed ({exc.message.split(';')[0]}); read as ASCII instead")
        inst.write("DATa:ENCdg ASCii")
        return decode_ascii_curve(inst.query("CURVe?"), n_points=n_points)


def _channel_on(inst: Instrument, n: int) -> bool:
    answer = inst.query(f"SELect:CH{n}?").strip().rsplit(" ", 1)[-1].upper()
    return answer in ("1", "ON")


def acquire_waveforms(
    inst: Instrument,
    settings: AcquireSettings,
    *,
    resource: str = "",
    clock: Callable[[], float] = time.monotonic,
    sleep: Callable[[float], None] = time.sleep,
) -> Acquisition:
    """Acquire (or read the stopped record of) the channels of a TDS1000/2000/TBS1000.

    Parameters
    ----------
    inst : Instrument
        An open pyvisa message-based resource (line-feed terminations).
    settings : AcquireSettings
        Channels, single acquisition, trigger timeout, encoding.
    resource : str
        The resource name, recorded in the result.
    clock, sleep : callable
        Time source and pause between ``ACQuire:STATE?`` polls (``time.monotonic``, ``time.sleep``).

    Returns
    -------
    Acquisition
        Codes, preambles and scales of every channel; warnings for clipped channels.

    Raises
    ------
    ChannelOffError
        A channel asked for is not displayed.
    AcquisitionTimeoutError
        With ``single``: the scope did not trigger within ``timeout_s``.
    InstrumentError
        An answer that cannot be read (preamble, curve).
    """
    inst.write("HEADer OFF")
    identity = parse_idn(inst.query("*IDN?"))
    off = [n for n in settings.channels if not _channel_on(inst, n)]
    if off:
        names = ", ".join(f"CH{n}" for n in off)
        raise ChannelOffError(f"{names} {'is' if len(off) == 1 else 'are'} switched off on the scope: press the "
                              f"{names} MENU button to show it, or leave it out of --channels")
    if settings.single:
        _wait_for_trigger(inst, settings, clock, sleep)
    else:
        inst.write("ACQuire:STATE STOP")  # freeze the screen: every channel from the same record
    horizontal = _number(inst, "HORizontal:MAIn:SCAle?")
    warnings: list[str] = []
    waves: list[Waveform] = []
    for n in settings.channels:
        inst.write(f"DATa:SOUrce CH{n}")
        encoding = "ASCii" if settings.encoding == "ascii" else "RIBinary"
        for command in (f"DATa:ENCdg {encoding}", "DATa:WIDth 1", "DATa:STARt 1", f"DATa:STOP {RECORD_POINTS}"):
            inst.write(command)
        pre = query_preamble(inst.query)
        scale = _number(inst, f"CH{n}:SCAle?")
        probe = _number(inst, f"CH{n}:PRObe?")
        codes = _read_curve(inst, settings.encoding, pre.n_points, warnings, f"CH{n}")
        clip = clipping_warning(codes, f"CH{n}", scale, pre.screen_centre_v, probe)
        waves.append(Waveform(n, codes, pre, scale, probe, () if clip is None else (clip,)))
        if clip is not None:
            warnings.append(clip)
    return Acquisition(resource, identity, horizontal, tuple(waves), tuple(warnings))

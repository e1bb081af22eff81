"""A simulated Tektronix TDS 2012C for pyvisa-sim: rehearse an acquisition without a scope.

``tds2000.yaml`` (shipped beside this module) is a pyvisa-sim device file answering the
dialogue of :mod:`motorid.io.acquire`; as shipped its records are empty.  pyvisa-sim device
files are static, so :func:`write_sim_device` writes a copy with records filled in and
returns the ``--visa-library`` spec that opens it (``path@sim``).  The records come from
the caller: the virtual trainer fills them in :mod:`motorid.trainer.scope_sim` (the trainer
sits above this layer).
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from motorid.errors import OptionError
from motorid.io.acquire.preamble import Preamble

__all__ = ["SIM_MODEL", "SIM_TEMPLATE", "SimChannel", "load_template", "sim_resource", "write_sim_device"]

#: The device file shipped in the package (empty records).
SIM_TEMPLATE = Path(__file__).with_name("tds2000.yaml")
#: The device's name in the file.
SIM_MODEL = "TDS2012C"


@dataclass(frozen=True, slots=True)
class SimChannel:
    """What one simulated channel answers.

    Attributes
    ----------
    codes : ndarray of int
        The record, −128 … 127 (sent as ASCII).
    preamble : Preamble
        Its scaling; ``n_points`` is taken from ``codes``.
    volts_per_div : float
        ``CH<n>:SCAle?``.
    probe_atten : float
        ``CH<n>:PRObe?``.
    displayed : bool
        ``SELect:CH<n>?`` (``False``: the channel is off).

    Raises
    ------
    OptionError
        Codes outside −128 … 127 or an empty record.
    """

    codes: np.ndarray
    preamble: Preamble
    volts_per_div: float
    probe_atten: float = 1.0
    displayed: bool = True

    def __post_init__(self) -> None:
        a = np.array(self.codes, dtype=np.int64, copy=True)
        if a.ndim != 1 or a.size == 0 or a.min() < -128 or a.max() > 127:
            raise OptionError("a simulated record needs 1 or more codes, each -128 … 127")
        a.setflags(write=False)
        object.__setattr__(self, "codes", a)


def load_template() -> dict[str, Any]:
    """The shipped device file as a dict.

    Returns
    -------
    dict
        Parsed YAML (``spec``, ``devices``, ``resources``).
    """
    import yaml  # a dependency of pyvisa-sim (the visa extra)

    return yaml.safe_load(SIM_TEMPLATE.read_text(encoding="utf-8"))


def sim_resource(library: str | None = None) -> str:
    """The VISA resource name of the simulated scope, as pyvisa lists it.

    Parameters
    ----------
    library : str, optional
        A ``path@sim`` spec from :func:`write_sim_device` (default: the shipped file).

    Returns
    -------
    str
        ``USB0::0x0699::0x03A4::C010001::0::INSTR`` (pyvisa adds the USB interface number 0).
    """
    import yaml

    path = Path(library.rsplit("@", 1)[0]) if library else SIM_TEMPLATE
    name = next(iter(yaml.safe_load(path.read_text(encoding="utf-8"))["resources"]))
    parts = name.split("::")
    return "::".join([*parts[:4], "0", parts[4]]) if name.startswith("USB") and len(parts) == 5 else name


def _set(dialogues: list[dict[str, str]], query: str, answer: str) -> None:
    for d in dialogues:
        if d["q"] == query:
            d["r"] = answer
            return
    dialogues.append({"q": query, "r": answer})


def write_sim_device(
    path: str | Path,
    channels: Mapping[int, SimChannel],
    *,
    horizontal_scale_s: float,
    idn: str | None = None,
    triggers: bool = True,
    settable: bool = False,
) -> str:
    """Write a device file with the records filled in; return its ``--visa-library`` spec.

    Parameters
    ----------
    path : path
        The ``.yaml`` file to write (a temporary folder's).
    channels : mapping of int to SimChannel
        CH1 and CH2 (the TDS 2012C has two).
    horizontal_scale_s : float
        ``HORizontal:MAIn:SCAle?``.
    idn : str, optional
        ``*IDN?`` (default: the template's); its serial number becomes the USB resource's, as
        on a real scope.
    triggers : bool
        ``False``: ``ACQuire:STATE?`` answers 1 for ever (a scope that never triggers).
    settable : bool
        Also accept the front-panel settings ``acquire --apply-advice`` sends (``CH<n>:SCAle``,
        ``HORizontal:MAIn:SCAle``, ``HORizontal:MAIn:POSition``, ``ACQuire:MODe``,
        ``ACQuire:NUMAVg``) and answer their queries with the value set (the records are the ones
        given: fill them at those settings).

    Returns
    -------
    str
        ``"<path>@sim"`` for ``pyvisa.ResourceManager``.

    Raises
    ------
    OptionError
        A channel other than 1 or 2.
    """
    import yaml

    doc = copy.deepcopy(load_template())
    device = doc["devices"][SIM_MODEL]
    top = device["dialogues"]
    if idn is not None:
        _set(top, "*IDN?", idn)
        serial = [*idn.split(","), "", "", ""][2].strip()
        if serial:
            name, entry = next(iter(doc["resources"].items()))
            parts = name.split("::")
            doc["resources"] = {"::".join([*parts[:3], serial, *parts[4:]]): entry}
    _set(top, "ACQuire:STATE?", "0" if triggers else "1")
    _set(top, "HORizontal:MAIn:SCAle?", repr(float(horizontal_scale_s)))
    for n, ch in channels.items():
        if n not in (1, 2):
            raise OptionError(f"the simulated TDS 2012C has channels 1 and 2, not {n}")
        _set(top, f"SELect:CH{n}?", "1" if ch.displayed else "0")
        _set(top, f"CH{n}:SCAle?", repr(float(ch.volts_per_div)))
        _set(top, f"CH{n}:PRObe?", repr(float(ch.probe_atten)))
        p = ch.preamble
        record = [{"q": f"WFMPre:{kw}?", "r": repr(float(v))} for kw, v in (
            ("YMUlt", p.ymult), ("YZEro", p.yzero), ("YOFf", p.yoff), ("XINcr", p.xincr), ("XZEro", p.xzero),
            ("PT_Off", p.pt_off))]
        record.append({"q": "WFMPre:NR_Pt?", "r": str(ch.codes.size)})
        record.append({"q": "CURVe?", "r": ",".join(str(int(c)) for c in ch.codes)})
        device["channels"][f"ch{n}"]["dialogues"] = record
    if settable:
        _settable(device, channels, horizontal_scale_s)
    target = Path(path)
    target.write_text(yaml.safe_dump(doc, sort_keys=False, width=1 << 30), encoding="utf-8")
    return f"{target}@sim"


def _settable(device: dict[str, Any], channels: Mapping[int, SimChannel], horizontal_scale_s: float) -> None:
    """The scale, position and acquisition-mode queries as pyvisa-sim properties: set, then read back."""
    top = device["dialogues"]
    props = device.setdefault("properties", {})

    def prop(name: str, command: str, default: str) -> None:
        top[:] = [d for d in top if d["q"] != f"{command}?"]
        props[name] = {"default": default, "getter": {"q": f"{command}?", "r": "{:s}"},
                       "setter": {"q": f"{command} {{:s}}"}, "specs": {"type": "str"}}

    prop("horizontal_scale", "HORizontal:MAIn:SCAle", repr(float(horizontal_scale_s)))
    first = next(iter(channels.values()), None)
    pt_off = first.preamble.pt_off / max(first.codes.size, 1) if first is not None else 0.5
    prop("horizontal_position", "HORizontal:MAIn:POSition", repr((0.5 - pt_off) * 10.0 * float(horizontal_scale_s)))
    for n, ch in channels.items():
        prop(f"ch{n}_scale", f"CH{n}:SCAle", repr(float(ch.volts_per_div)))
    prop("acquire_mode", "ACQuire:MODe", "SAMple")
    prop("average_count", "ACQuire:NUMAVg", "16")

"""The simulated TDS 2012C filled from the virtual trainer: ``--simulate`` on the scope commands.

One acquisition of the trainer (:func:`motorid.trainer.run_experiment`, one role) is turned
into what the scope would send: the 8-bit codes of CH1 (the step) and CH2 (the measured
signal) and their preambles, written into a pyvisa-sim device file by
:func:`motorid.io.sim.write_sim_device`.  The capture is the one ``motorid demo`` writes for
the same preset, seed and role, so an acquisition from the simulated scope can be checked
against the demo's files and the trainer's truth.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from motorid.capture import Capture
from motorid.errors import OptionError
from motorid.io.acquire.preamble import Preamble
from motorid.io.sim import SimChannel, sim_resource, write_sim_device
from motorid.trainer.experiment import VOLTS_PER_DIV, run_experiment
from motorid.trainer.scope import RECORD_LENGTH

__all__ = ["SimulatedScope", "capture_channels", "simulated_tds2012"]


@dataclass(frozen=True, slots=True)
class SimulatedScope:
    """A simulated scope ready to open.

    Attributes
    ----------
    visa_library : str
        ``"<file>.yaml@sim"``: the ``--visa-library`` (``pyvisa.ResourceManager``) spec.
    resource : str
        Its VISA resource name.
    capture : Capture
        The trainer's capture its records hold (CH1 = input, CH2 = output).
    role : str
        What CH2 measures.
    """

    visa_library: str
    resource: str
    capture: Capture
    role: str


def capture_channels(capture: Capture, *, displayed: tuple[int, ...] = (1, 2)) -> dict[int, SimChannel]:
    """The records a TDS 2012C would send for a trainer capture.

    Parameters
    ----------
    capture : Capture
        A quantised trainer capture (:func:`motorid.trainer.scope.acquire`).
    displayed : tuple of int
        Channels switched on; the others answer ``SELect:CH<n>? 0``.

    Returns
    -------
    dict of int to SimChannel
        CH1 (the input) and CH2 (the output): codes ``v / (V/div / 25)``, ``YMUlt = V/div / 25``,
        ``YOFf = YZEro = 0``, ``XINcr`` the sample interval, ``XZEro = 0`` at ``PT_Off`` = the
        trigger point.

    Raises
    ------
    OptionError
        The capture has no input channel, no scales, or is not on the 8-bit grid.
    """
    if capture.input_v is None or capture.input_info is None:
        raise OptionError("the simulated scope needs a capture with CH1 (the step input)")
    scope = capture.scope
    if scope.horizontal_scale_s is None or scope.trigger_index is None:
        raise OptionError("the simulated scope needs the capture's horizontal scale and trigger point")
    # the same expression as ScopeSettings.sample_interval_s, so the times are the same floats
    xincr = 10.0 * scope.horizontal_scale_s / RECORD_LENGTH
    out: dict[int, SimChannel] = {}
    for n, values, info in ((1, capture.input_v, capture.input_info), (2, capture.output_v, capture.output_info)):
        if info.vertical_scale is None:
            raise OptionError(f"the simulated scope needs CH{n}'s volts/div")
        ymult = info.vertical_scale / 25.0
        codes = np.rint(np.asarray(values) / ymult)
        if np.max(np.abs(codes * ymult - values)) > 1e-9 * info.vertical_scale:
            raise OptionError(f"CH{n} of the capture is not on the 8-bit grid: record it with quantise=True")
        pre = Preamble(ymult=ymult, yzero=0.0, yoff=0.0, xincr=xincr, xzero=0.0, pt_off=float(scope.trigger_index),
                       n_points=int(codes.size))
        out[n] = SimChannel(codes.astype(int), pre, info.vertical_scale, info.probe_atten or 1.0, n in displayed)
    return out


def simulated_tds2012(
    folder: str | Path,
    *,
    role: str = "velocity",
    preset: str = "paper",
    seed: int = 0,
    step_volts: float = 5.92,
    triggers: bool = True,
    displayed: tuple[int, ...] = (1, 2),
    volts_per_div: Mapping[str, float] | None = None,
    sec_per_div: float = 1.0,
    trigger_position_pct: float | None = None,
    averages: int = 1,
    settable: bool = False,
) -> SimulatedScope:
    """Record one acquisition on the virtual trainer and write the simulated scope holding it.

    Parameters
    ----------
    folder : path
        Where to write the device file (``tds2012-sim.yaml``); a temporary folder.
    role : str
        What CH2 measures: ``position``, ``velocity`` or ``current``.
    preset : str
        Trainer preset.
    seed : int
        Seed of noise and trigger point (the demo's captures for the same seed).
    step_volts : float
        Step level of switch S1.
    triggers : bool
        ``False``: a scope that never triggers (``ACQuire:STATE?`` stays 1).
    displayed : tuple of int
        Channels switched on.
    volts_per_div : Mapping[str, float], optional
        Vertical scales of ``input`` (CH1) and of the role (CH2) the trainer records at.
    sec_per_div : float
        Horizontal scale the trainer records at.
    trigger_position_pct : float, optional
        Part of the record before the trigger (default: drawn, as the demo's).
    averages : int
        Average mode's count the trainer records with (1: Sample mode).
    settable : bool
        The scope accepts those settings over SCPI and answers their queries with the values set
        (``acquire --apply-advice``): fill it with the trainer recorded at the settings that will be sent.

    Returns
    -------
    SimulatedScope
        The ``--visa-library`` spec, the resource name and the capture.

    Raises
    ------
    OptionError
        An unknown role or preset, a step level outside ±10 V.
    """
    if role not in VOLTS_PER_DIV:
        raise OptionError(f"--sim-role {role!r} is unknown: use one of {', '.join(VOLTS_PER_DIV)}")
    exp = run_experiment(preset, step_volts=step_volts, seed=seed, roles=(role,), validation=False,
                         volts_per_div=volts_per_div, sec_per_div=sec_per_div,
                         trigger_position_pct=trigger_position_pct, averages=averages)
    capture = exp.captures[role]
    scope = capture.scope
    idn = f"TEKTRONIX,{scope.model},{scope.serial},CF:91.1CT {scope.firmware}"
    # a trainer capture always records its horizontal scale; else the record's 10 divisions
    scale = scope.horizontal_scale_s or float(capture.time_s[-1] - capture.time_s[0]) / 10
    spec = write_sim_device(Path(folder) / "tds2012-sim.yaml", capture_channels(capture, displayed=displayed),
                            horizontal_scale_s=float(scale), idn=idn, triggers=triggers, settable=settable)
    return SimulatedScope(spec, sim_resource(spec), capture, role)

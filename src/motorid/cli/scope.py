"""``motorid scope list`` and ``motorid acquire``: read a TDS1000/TDS2000/TBS1000 over VISA.

``scope list`` shows the instruments a VISA backend finds with their ``*IDN?``; ``acquire``
reads the channels of one, saves them in the scope's own "Save All" layout (``ALLnnnn/
FnnnnCH<n>.CSV``) and, with ``--identify``, runs ``motorid identify`` on the saved files.
``--simulate`` replaces the scope by a simulated TDS 2012C whose records come from the
virtual trainer (pyvisa-sim), so the whole procedure can be rehearsed without one.
"""

from __future__ import annotations

import contextlib
import json
import shlex
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer
from rich.console import Console
from rich.table import Table

from motorid.errors import OptionError

if TYPE_CHECKING:
    from motorid.io.acquire import Acquisition
    from motorid.io.acquire.setup import ScopeSetup

__all__ = ["ROLE_NAMES", "parse_channels", "parse_roles", "register"]

#: What a channel can be given as with ``--role``.
ROLE_NAMES: tuple[str, ...] = ("input", "position", "velocity", "current")

scope_app = typer.Typer(no_args_is_help=True, help="Oscilloscopes over VISA (USB, LAN): list them.")

VisaLibrary = Annotated[str, typer.Option(
    "--visa-library", help="VISA backend, passed to pyvisa.ResourceManager as is: @py (pyvisa-py, default), "
                           "@ivi (NI-VISA), or FILE.yaml@sim (pyvisa-sim).")]
Simulate = Annotated[bool, typer.Option(
    "--simulate", help="Use a simulated TDS 2012C whose traces come from the virtual trainer (no scope needed).")]


def _console() -> Console:
    return Console(highlight=False, width=None if sys.stdout.isatty() else 120)


def parse_channels(spec: str) -> tuple[int, ...]:
    """``"1,2"`` → ``(1, 2)``.

    Parameters
    ----------
    spec : str
        Comma-separated channel numbers (``CH`` prefixes allowed).

    Returns
    -------
    tuple of int

    Raises
    ------
    OptionError
        Not numbers 1–4, or one given twice.
    """
    try:
        chans = tuple(int(p.strip().upper().removeprefix("CH")) for p in spec.split(",") if p.strip())
    except ValueError:
        raise OptionError(f"--channels {spec!r}: give channel numbers, e.g. 1,2") from None
    if not chans or any(not 1 <= c <= 4 for c in chans) or len(set(chans)) != len(chans):
        raise OptionError(f"--channels {spec!r}: give distinct channel numbers 1 to 4, e.g. 1,2")
    return chans


def parse_roles(specs: list[str] | None, channels: tuple[int, ...]) -> dict[int, str]:
    """``["CH2=velocity"]`` → ``{2: "velocity"}``; CH1 is the input unless said otherwise.

    Parameters
    ----------
    specs : list of str
        ``CH<n>=ROLE`` (or ``<n>=ROLE``), ROLE one of :data:`ROLE_NAMES`.
    channels : tuple of int
        The channels acquired.

    Returns
    -------
    dict of int to str
        The roles given (CH1 → ``input`` when acquired and not given).

    Raises
    ------
    OptionError
        A malformed item, an unknown role, a channel not acquired, one given twice, or two inputs.
    """
    roles: dict[int, str] = {}
    for spec in specs or []:
        for item in (p for p in spec.split(",") if p.strip()):
            ch, sep, role = item.partition("=")
            role = role.strip().lower()
            try:
                n = int(ch.strip().upper().removeprefix("CH"))
            except ValueError:
                n = 0
            if not sep or not 1 <= n <= 4:
                raise OptionError(f"--role {item!r} is not CH<n>=ROLE (e.g. CH2=velocity)")
            if role not in ROLE_NAMES:
                raise OptionError(f"--role {item!r}: unknown role {role!r}; use one of {', '.join(ROLE_NAMES)}")
            if n not in channels:
                raise OptionError(f"--role {item!r}: CH{n} is not acquired; add it to --channels")
            if n in roles:
                raise OptionError(f"--role gives CH{n} twice; give each channel one role")
            roles[n] = role
    if 1 in channels and 1 not in roles and "input" not in roles.values():
        roles[1] = "input"
    if list(roles.values()).count("input") > 1:
        raise OptionError("--role gives two input channels; the step input is one channel (CH1 on the trainer)")
    return roles


@dataclass(frozen=True, slots=True)
class _Target:
    """The backend and resource to use (a real one, or the simulated scope)."""

    visa_library: str
    resource: str | None
    note: str | None = None


@contextlib.contextmanager
def _target(visa_library: str, resource: str | None, simulate: bool, *, sim_role: str = "velocity",
            sim_seed: int = 0, sim_preset: str = "paper", sim_record: dict | None = None) -> Iterator[_Target]:
    if not simulate:
        yield _Target(visa_library, resource)
        return
    if visa_library != "@py":
        raise OptionError("--simulate and --visa-library both choose the backend: give one of them")
    import importlib.util

    missing = [m for m in ("pyvisa", "pyvisa_sim", "yaml") if importlib.util.find_spec(m) is None]
    if missing:
        raise OptionError(f"--simulate needs the visa extra ({', '.join(missing)} missing): "
                          "pip install 'motorid[visa]'")
    from motorid.trainer.scope_sim import simulated_tds2012

    with tempfile.TemporaryDirectory(prefix="motorid-sim-") as tmp:
        # with --apply-advice the simulated scope accepts the settings, and its records are the trainer's
        # recorded at them
        sim = simulated_tds2012(tmp, role=sim_role, preset=sim_preset, seed=sim_seed, **(sim_record or {}))
        yield _Target(sim.visa_library, resource or sim.resource,
                      f"simulated TDS 2012C: virtual trainer '{sim_preset}', seed {sim_seed}, CH2 = {sim_role}")


@contextlib.contextmanager
def _manager(visa_library: str) -> Iterator[object]:
    from motorid.io.acquire import resource_manager

    rm = resource_manager(visa_library)
    try:
        yield rm
    finally:
        with contextlib.suppress(Exception):
            rm.close()


@scope_app.command("list")
def scope_list(
    visa_library: VisaLibrary = "@py",
    simulate: Simulate = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print a JSON list.")] = False,
) -> None:
    """List the VISA instruments found, with their *IDN? answer."""
    from motorid.io.acquire import list_instruments
    from motorid.io.acquire.visa import no_instrument_error

    with _target(visa_library, None, simulate) as target, _manager(target.visa_library) as rm:
        found = list_instruments(rm)
    if not found:
        raise no_instrument_error(target.visa_library)
    if as_json:
        typer.echo(json.dumps([{"resource": f.resource, "idn": f.idn, "problem": f.problem} for f in found], indent=2))
        return
    con = _console()
    table = Table(title=f"VISA instruments ({target.note or '--visa-library ' + target.visa_library})")
    table.add_column("resource", overflow="fold")
    table.add_column("*IDN?", overflow="fold")
    for f in found:
        table.add_row(f.resource, f.idn if f.idn is not None else f"[yellow]{f.problem}[/yellow]")
    con.print(table)
    # the hint names a resource that answered (the first), quoted for the shell
    answering = [f.resource for f in found if f.idn is not None] or [found[0].resource]
    con.print(f"acquire: motorid acquire --resource {shlex.quote(answering[0])} --out ALL0000"
              + (" --simulate" if simulate else ""), markup=False)


def _pick_resource(rm: object, target: _Target) -> str:
    if target.resource:
        return target.resource
    from motorid.io.acquire import list_instruments
    from motorid.io.acquire.visa import no_instrument_error

    found = [f for f in list_instruments(rm) if f.idn is not None]
    if not found:
        raise no_instrument_error(target.visa_library)
    if len(found) > 1:
        raise OptionError(f"{len(found)} instruments found ({', '.join(f.resource for f in found)}): "
                          "choose one with --resource")
    return found[0].resource


def _role_specs(folder: Path, index: int, channels: tuple[int, ...], roles: dict[int, str]) -> dict[str, str]:
    """The capture each measured role is identified from (``motorid identify --velocity SPEC``)."""
    from motorid.conditioning.role import guess_role
    from motorid.io import read_capture
    from motorid.io.acquire import channel_file

    inputs = [n for n, r in roles.items() if r == "input"]
    given: dict[str, str] = {}
    for n in channels:
        if roles.get(n) == "input":
            continue
        if inputs:
            ch_in = inputs[0]
            # the folder itself when it is just CH1 + CH2: what a user would type
            spec = str(folder) if (ch_in, n) == (1, 2) and set(channels) == {1, 2} else \
                f"{channel_file(folder, index, ch_in)}+{channel_file(folder, index, n)}"
        else:
            spec = str(channel_file(folder, index, n))
        role = roles.get(n)
        if role is None:
            guess = guess_role(read_capture(spec if "+" not in spec else spec.split("+")))
            if guess.role not in ROLE_NAMES:
                raise OptionError(f"cannot tell what CH{n} measures ({guess.reason}): give --role CH{n}=velocity "
                                  "(or position, current)")
            role = guess.role
        if role in given:
            raise OptionError(f"two channels are {role} ({given[role]} and CH{n}): give each its own --role")
        given[role] = spec
    if not given:
        raise OptionError("--identify needs a measured channel (position, velocity or current) besides the input: "
                          "add it to --channels")
    return given


def _advice_setup(path: Path, chans: tuple[int, ...], roles: dict[int, str], simulate: bool,
                  sim_role: str) -> tuple[ScopeSetup, dict | None]:
    """The advice's settings by channel (a channel without ``--role`` takes the advice's one measured role)."""
    from motorid.io.acquire.setup import read_advice_setup
    from motorid.io.jsonfile import read_json

    doc = read_json(path, "advice")
    combined = (doc.get("combined") or {}).get("settings") if isinstance(doc, dict) else None
    advised = combined.get("volts_per_div") if isinstance(combined, dict) else None
    measured = [r for r in (advised if isinstance(advised, dict) else {}) if r != "input"]
    named = dict(roles)
    unnamed = [n for n in chans if n not in named]
    if simulate and 2 in unnamed:
        named[2] = sim_role  # the simulated scope's CH2 is the trainer's --sim-role
    elif len(unnamed) == 1 and len(measured) == 1:
        named[unnamed[0]] = measured[0]
    setup, settings = read_advice_setup(path, named)
    if not simulate:
        return setup, None
    vpd = {("input" if named.get(n) == "input" else sim_role): v for n, v in setup.volts_per_div.items()}
    record = {"volts_per_div": vpd, "settable": True}
    if setup.time_per_div_s is not None:
        record["sec_per_div"] = setup.time_per_div_s
    if setup.trigger_position_pct is not None:
        record["trigger_position_pct"] = setup.trigger_position_pct
    if setup.averages is not None:
        record["averages"] = setup.averages
    if isinstance(settings.get("step_volts"), (int, float)):
        record["step_volts"] = float(settings["step_volts"])
    return setup, record


def _not_taken(acq: Acquisition, setup: ScopeSetup | None) -> list[str]:
    """Settings the scope reports back otherwise than they were sent."""
    if setup is None:
        return []
    notes = []
    tpd = setup.time_per_div_s
    if tpd is not None and abs(acq.horizontal_scale_s - tpd) > 1e-6 * tpd:
        notes.append(f"the scope reports {acq.horizontal_scale_s:g} s/div, not the advised {tpd:g}")
    for w in acq.waveforms:
        want = setup.volts_per_div.get(w.channel)
        if want is not None and abs(w.volts_per_div - want) > 1e-6 * want:
            notes.append(f"{w.name} reports {w.volts_per_div:g} V/div, not the advised {want:g}")
    return notes


def acquire(
    out: Annotated[Path, typer.Option(
        "--out", help="ALLnnnn folder to save into, or a folder to create the next free ALLnnnn in.")],
    resource: Annotated[str | None, typer.Option(
        "--resource", help="VISA resource (motorid scope list); default: the only instrument found.")] = None,
    channels: Annotated[str, typer.Option(
        "--channels", help="Channels to read, e.g. 1,2 (CH1 = step input, CH2 = response).")] = "1,2",
    single: Annotated[bool, typer.Option(
        "--single", help="Arm a single acquisition and wait for the trigger "
                         "(default: stop the scope and read the record on screen).")] = False,
    timeout: Annotated[float, typer.Option("--timeout", help="Seconds to wait for the trigger with --single.")] = 10.0,
    role: Annotated[list[str] | None, typer.Option(
        "--role", help="What a channel measures, CH<n>=ROLE (input, position, velocity, current); repeat "
                       "per channel. Default: CH1 = input, the others guessed.")] = None,
    encoding: Annotated[str | None, typer.Option(
        "--encoding", help="Curve transfer: binary (default; falls back to ascii) or ascii "
                           "(default with --simulate).")] = None,
    identify: Annotated[bool, typer.Option("--identify", help="Run motorid identify on the saved files.")] = False,
    json_out: Annotated[Path | None, typer.Option("--json", help="With --identify: write the model JSON here.")] = None,
    step_volts: Annotated[float | None, typer.Option(
        "--step-volts", help="With --identify and no input channel: the step level.")] = None,
    force: Annotated[bool, typer.Option("--force", help="Overwrite existing files.")] = False,
    visa_library: VisaLibrary = "@py",
    simulate: Simulate = False,
    sim_role: Annotated[str, typer.Option(
        "--sim-role", help="--simulate: what CH2 measures (position, velocity, current).")] = "velocity",
    sim_seed: Annotated[int, typer.Option(
        "--sim-seed", help="--simulate: seed of the trainer's noise and trigger point.")] = 0,
    sim_preset: Annotated[str, typer.Option("--sim-preset", help="--simulate: virtual trainer preset.")] = "paper",
    apply_advice: Annotated[Path | None, typer.Option(
        "--apply-advice", help="An advice JSON (motorid advise --json): set its volts/div, time/div, trigger "
                               "position and Average mode on the scope, then acquire a fresh record.")] = None,
) -> None:
    """Acquire channels from the oscilloscope and save them as ALLnnnn/FnnnnCH<n>.CSV."""
    from motorid.io import check_writable
    from motorid.io.acquire import (
        AcquireSettings,
        acquire_waveforms,
        channel_file,
        open_instrument,
        save_acquisition,
        save_all_folder,
    )

    chans = parse_channels(channels)
    roles = parse_roles(role, chans)
    settings = AcquireSettings(channels=chans, single=single, timeout_s=timeout,
                               encoding=encoding or ("ascii" if simulate else "binary"))
    if json_out is not None and not identify:
        raise OptionError("--json writes the identified model: add --identify")
    if simulate:
        from motorid.trainer.presets import PRESET_NAMES

        if sim_preset not in PRESET_NAMES:
            raise OptionError(f"--sim-preset {sim_preset!r} is unknown: use one of {', '.join(PRESET_NAMES)}")
    setup: ScopeSetup | None = None
    sim_record: dict | None = None
    if apply_advice is not None:
        setup, sim_record = _advice_setup(apply_advice, chans, roles, simulate, sim_role)
        # the record on the screen was taken at the old settings: arm a fresh one
        settings = replace(settings, single=True)
    folder, index = save_all_folder(out)
    check_writable([channel_file(folder, index, n) for n in chans], force=force)
    check_writable({"--json": json_out}, force=force, create_parents=False)
    sent: tuple[str, ...] = ()
    with _target(visa_library, resource, simulate, sim_role=sim_role, sim_seed=sim_seed,
                 sim_preset=sim_preset, sim_record=sim_record) as target, _manager(target.visa_library) as rm:
        name = _pick_resource(rm, target)
        with open_instrument(rm, name) as inst:
            if setup is not None:
                from motorid.io.acquire.setup import apply_setup

                sent = apply_setup(inst, setup)
            acq = acquire_waveforms(inst, settings, resource=name)
    saved = save_acquisition(acq, folder, force=force)
    con = _console()
    if sent:
        con.print(f"applied ({apply_advice}): {'; '.join(sent)}", markup=False)
        for note in _not_taken(acq, setup):
            con.print(f"[yellow]warning:[/yellow] {note}")
    title = f"{acq.identity.model or 'scope'} {acq.identity.serial} ({target.note or name})"
    table = Table(title=title)
    for head in ("channel", "file", "V/div", "points", "Δt (s)", "min (V)", "max (V)"):
        table.add_column(head)
    for w in acq.waveforms:
        v = w.volts
        table.add_row(w.name, channel_file(saved, index, w.channel).name, f"{w.volts_per_div:g}", str(v.size),
                      f"{w.preamble.xincr:.6g}", f"{v.min():.4g}", f"{v.max():.4g}")
    con.print(table)
    for note in acq.warnings:
        con.print(f"[yellow]warning:[/yellow] {note}")
    con.print(f"saved: {saved}")
    if not identify:
        return
    specs = _role_specs(saved, index, chans, roles)
    rerun = " ".join(f"--{r} {s}" for r, s in specs.items())
    con.print(f"identify: motorid identify {rerun}")
    from motorid.cli.app import identify as identify_command  # the same command: same output and checks

    identify_command(position=[specs["position"]] if "position" in specs else None,
                     velocity=[specs["velocity"]] if "velocity" in specs else None,
                     current=[specs["current"]] if "current" in specs else None,
                     step_volts=None if step_volts is None else repr(step_volts), json_out=json_out, force=force)


def register(app: typer.Typer) -> None:
    """Add ``scope list`` and ``acquire`` to the main app.

    Parameters
    ----------
    app : typer.Typer
        The ``motorid`` app.
    """
    app.add_typer(scope_app, name="scope")
    app.command("acquire")(acquire)

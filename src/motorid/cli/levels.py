"""``motorid identify`` with several step levels: the Hammerstein path.

Called by :func:`motorid.cli.app.identify` when ``--velocity`` is given more than once,
``--experiment`` is used or ``--dead-zone`` is asked for; prints the static characteristic, the
per-level dynamics and the linear part, and writes the model JSON (with
``static_nonlinearity``), the MATLAB script and the report.
"""

from __future__ import annotations

from pathlib import Path

from rich.console import Console
from rich.table import Table

from motorid.errors import OptionError

__all__ = ["experiment_capture", "identify_levels_cmd", "parse_levels"]


def parse_levels(text: str | None) -> list[float] | None:
    """``--step-volts`` as a list: ``5.92`` or ``2,4,6,8,10`` (one per capture, in order).

    Parameters
    ----------
    text : str or None
        The option's value.

    Returns
    -------
    list of float or None

    Raises
    ------
    OptionError
        When an entry is not a finite non-zero number.
    """
    if text is None:
        return None
    out = []
    for part in str(text).split(","):
        try:
            v = float(part)
        except ValueError:
            raise OptionError(f"--step-volts {text!r}: not a number or a comma-separated list of numbers") from None
        if not (abs(v) < float("inf") and v != 0):
            raise OptionError(f"--step-volts must be finite and non-zero (a negative value is a step down), got {v:g}")
        out.append(v)
    return out


def experiment_capture(folder: str):  # -> Capture
    """The velocity capture of one step experiment folder.

    A folder holding ``ALLnnnn`` captures (the scope's Save All of one experiment: position,
    velocity, current) gives the one whose data look like a velocity; any other folder or file
    is read as one capture.

    Parameters
    ----------
    folder : str
        The ``--experiment`` argument.

    Returns
    -------
    Capture

    Raises
    ------
    OptionError
        When the folder holds no capture that looks like a velocity.
    """
    from motorid.conditioning.role import guess_role
    from motorid.io import read_capture

    path = Path(folder)
    subs = sorted(p for p in path.glob("ALL[0-9][0-9][0-9][0-9]") if p.is_dir()) if path.is_dir() else []
    if not subs:
        return read_capture(folder, role="velocity")
    for sub in subs:
        cap = read_capture(str(sub))
        if guess_role(cap).role == "velocity":
            return cap
    raise OptionError("no capture in the experiment folder looks like a velocity step", file=folder)


def identify_levels_cmd(
    con: Console,
    captures: list,
    step_volts: list[float] | None,
    *,
    ignored: list[str],
) -> object:
    """Identify, print and return the :class:`~motorid.identification.hammerstein.MultiLevelResult`.

    Parameters
    ----------
    con : Console
        Where to print.
    captures : list of Capture
        One velocity capture per step experiment.
    step_volts : list of float or None
        Levels for captures without an input channel: one per capture, or one for all.
    ignored : list of str
        Options given that this path does not use (printed as a note).

    Returns
    -------
    MultiLevelResult

    Raises
    ------
    OptionError
        Fewer than two moving levels, or a step-volts list of the wrong length.
    """
    from motorid import frontdoor
    from motorid.model.units import channel_unit

    result = frontdoor.identify_levels(captures, step_volts=step_volts)
    st = result.static
    table = Table(title="static characteristic (one row per step experiment)")
    out_unit, in_unit = channel_unit(result.model.units, "velocity"), result.model.input_unit
    for col in ("capture", f"step ({in_unit})", f"steady output ({out_unit})", "± 95 %", "status"):
        table.add_column(col, justify="left" if col in ("capture", "status") else "right")
    for point, _ in result.responses:
        table.add_row(Path(point.source).name or point.source, f"{point.step_volts:.4g}",
                      f"{point.steady_state:.4g}", f"{1.96 * point.stderr:.2g}", point.status)
    con.print(table)
    lo, hi = st.dead_zone_ci95
    con.print(f"dead-zone u0 = {st.dead_zone_v:.4g} {in_unit} (95 % interval [{lo:.4g}, {hi:.4g}] {in_unit}), "
              "input-referred: "
              "amplifier dead-zone plus Coulomb friction")
    con.print(f"static gain K = {st.gain:.4g} {result.model.dc_gain_unit} "
              f"(95 % interval [{st.gain_ci95[0]:.4g}, {st.gain_ci95[1]:.4g}])")
    if st.negative is not None:
        n = st.negative
        con.print(f"negative steps: dead-zone {n.dead_zone_v:.4g} {in_unit} [{n.dead_zone_ci95[0]:.4g}, "
                  f"{n.dead_zone_ci95[1]:.4g}], gain {n.gain:.4g}")
    if st.saturation_input_v is not None:
        con.print(f"saturation: output ≈ {st.saturation_output_v:.4g} {out_unit}, "
                  f"reached from u ≈ {st.saturation_input_v:.4g} {in_unit}")
    con.print(f"dynamics: {result.dynamics_note}")
    for w in result.warnings:
        if w != result.dynamics_note:
            con.print(f"[yellow]warning:[/yellow] {w}")
    if ignored:
        con.print(f"note: {', '.join(ignored)} not used by the several-level fit (velocity captures only)")
    return result

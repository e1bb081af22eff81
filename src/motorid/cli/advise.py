"""``motorid advise``: from a first capture, how to record the next one.

The captures are identified as ``motorid identify`` does (same capture options), then each scope
setting's predicted 95 % interval widths are printed (:mod:`motorid.analysis.advice`): a table of
the settings worth changing, one at a time, and all of them together; ``--json`` prints the advice
JSON (docs/formats.md).
"""


import json
import math
import sys
from typing import Annotated, Any

import typer
from rich.console import Console
from rich.table import Table

from motorid.numfmt import sig
from motorid.options import ADVISE, IDENTIFY, READ, ROLES, OptionSpec

__all__ = ["advise", "register"]


def _spec(table: tuple[OptionSpec, ...], name: str) -> OptionSpec:
    return next(o for o in table if o.name == name)


def _help(table: tuple[OptionSpec, ...], name: str) -> str:
    """An option's help line as :mod:`motorid.options` declares it (with its unit)."""
    o = _spec(table, name)
    unit = f" [{o.unit}]" if o.unit else ""
    return f"{o.help[:1].upper()}{o.help[1:]}{unit}."


def advise(
    position: Annotated[str | None, typer.Option(help=_help(ROLES, "position"))] = None,
    velocity: Annotated[str | None, typer.Option(help=_help(ROLES, "velocity"))] = None,
    current: Annotated[str | None, typer.Option(help=_help(ROLES, "current"))] = None,
    method: Annotated[str, typer.Option(help="auto or oe: the output-error fit whose intervals are predicted.")]
    = _spec(IDENTIFY, "method").default,
    order: Annotated[str, typer.Option(help=_help(IDENTIFY, "order"))] = _spec(IDENTIFY, "order").default,
    record_length: Annotated[float | None, typer.Option(
        "--record-length", help=_help(IDENTIFY, "record_length_s"))] = None,
    delay: Annotated[bool | None, typer.Option("--delay/--no-delay", help=_help(IDENTIFY, "delay"))] = None,
    step_volts: Annotated[float | None, typer.Option("--step-volts", help=_help(READ, "step_volts"))] = None,
    t0: Annotated[float | None, typer.Option("--t0", help=_help(READ, "t0"))] = None,
    force_role: Annotated[bool, typer.Option("--force-role", help=_help(READ, "force_role"))] = False,
    threshold: Annotated[float, typer.Option("--threshold", help=_help(ADVISE, "threshold"))]
    = _spec(ADVISE, "threshold").default,
    as_json: Annotated[bool, typer.Option("--json", help="Print the advice JSON (docs/formats.md).")] = False,
) -> None:
    """How to record the next capture: each scope setting's predicted interval widths.

    Volts/div of each channel, time/div (record after the step, sample interval), trigger
    position, Average mode and step level, each with the 95 % interval widths of the DC gain,
    the time constant, the dead time and the electrical pole a capture at that setting would
    give, and all the free settings together.
    """
    from motorid import frontdoor
    from motorid.cli.app import _check_options, _read_experiment

    if method not in ("auto", "oe"):
        from motorid.errors import OptionError

        raise OptionError(f"--method {method}: advise predicts the output-error fit's intervals; use auto or oe")
    _check_options(method=method, order=order, reduction="subsample", derivative="five_point", structure="free",
                   sync="interp", ratio=None, sample_interval=None, record_length=record_length,
                   step_volts=step_volts, t0=t0, markov_params=None, markov_window=None, markov_basis="laguerre")
    exp = _read_experiment(position, velocity, current, None, step_volts=step_volts, t0=t0, force_role=force_role)
    fit = frontdoor.identify(exp, method=method, order=order if order == "auto" else int(order),  # type: ignore[arg-type]
                             record_length_s=record_length, delay=delay)
    adv = frontdoor.advise(fit, threshold=threshold)
    if as_json:
        typer.echo(json.dumps(adv.to_dict(), indent=2, allow_nan=False))
        return
    print_advice(Console(highlight=False, width=None if sys.stdout.isatty() else 120), adv)


def _width(w: float | None) -> str:
    if w is None:
        return "—"
    return "undetermined" if not math.isfinite(w) else f"±{sig(50 * w, 2)} %"


def _pole(widths: Any) -> str:
    if widths.electrical_pole is None:
        return "—"
    return _width(widths.electrical_pole) + ("" if widths.electrical_pole_resolvable else " (not resolved)")


def _settings_text(settings: Any) -> str:
    vpd = ", ".join(f"{c} {sig(v)} V/div" for c, v in settings.volts_per_div.items())
    return (f"{vpd}; {sig(settings.time_per_div_s)} s/div ({sig(settings.sample_interval_s)} s samples); "
            f"{sig(settings.trigger_position_pct)} % before the trigger; step {sig(settings.step_volts)} V; "
            f"{'Sample mode' if settings.averages == 1 else f'Average {settings.averages}'}")


def print_advice(con: Console, adv: Any) -> None:
    """The advice as a table of settings with their predicted widths.

    Parameters
    ----------
    con : rich.console.Console
        Where to print.
    adv : motorid.analysis.advice.Advice
        The advice.
    """
    con.print(f"recorded at: {_settings_text(adv.settings)}", markup=False)
    now = adv.now
    con.print(f"95 % intervals now (predicted = identify's): gain {_width(now.dc_gain)}, τ {_width(now.time_constant)}"
              + (f", dead time {_width(now.dead_time)}" if now.dead_time is not None else "")
              + (f", electrical pole {_pole(now)}" if now.electrical_pole is not None else ""), markup=False)
    for note in adv.notes:
        con.print(f"note: {note}", markup=False)
    if not adv.suggestions:
        con.print(f"advice: {adv.summary_line()}", markup=False)
        return
    table = Table(title="one setting at a time (the most useful first)")
    for col in ("setting", "now", "suggested", "gain", "τ", "dead time", "electrical pole", "why"):
        table.add_column(col, overflow="fold")
    for s in adv.suggestions:
        name = f"{s.setting} ({s.channel})" if s.channel else s.setting
        why = s.why + (f" — costs: {s.cost}" if s.cost else "")
        table.add_row(name, sig(s.now), sig(s.suggested), _width(s.predicted.dc_gain),
                      _width(s.predicted.time_constant), _width(s.predicted.dead_time), _pole(s.predicted), why)
    con.print(table)
    if adv.worth_changing:
        c = adv.combined_predicted
        con.print(f"all together: {_settings_text(adv.combined)}", markup=False)
        con.print(f"  predicted: gain {_width(c.dc_gain)}, τ {_width(c.time_constant)}"
                  + (f", dead time {_width(c.dead_time)}" if c.dead_time is not None else "")
                  + (f", electrical pole {_pole(c)}" if c.electrical_pole is not None else ""), markup=False)
        con.print("  apply them: motorid acquire ... --apply-advice ADVICE.json (motorid advise --json > ADVICE.json)",
                  markup=False)
    else:
        con.print(f"advice: {adv.summary_line()} (the rows above cost more acquisitions or another operating point)",
                  markup=False)


def register(app: typer.Typer) -> None:
    """Add ``advise`` to the main app.

    Parameters
    ----------
    app : typer.Typer
        The ``motorid`` app.
    """
    app.command("advise")(advise)

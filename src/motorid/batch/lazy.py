"""Lazy reports (``motorid batch --reports lazy``): a small page now, the full report on demand.

A full per-experiment report costs about 1.5–2 s of CPU (its seven figures, the sensitivity
sweep and the advice), four times the identification itself; a class of 200 spends most of its
batch on reports nobody opens.  With lazy reports the batch writes, in place of each report, a
page of a few kilobytes without figures: the experiment's numbers as the summary shows them,
its warnings, and the exact command that renders the full report of this experiment (the same
``motorid batch`` call with ``--reports full --only NAME``: the stored result's hash is the
same, so only this experiment is computed again, now with its report, and the page is
replaced by it).  A teacher who opens the summary from a folder, with no server, gets a page
for every link — never a dead link — and renders the reports that are worth a look.
"""

from __future__ import annotations

import html
import shlex
from collections.abc import Mapping, Sequence
from typing import Any

__all__ = ["render_command", "report_stub"]


def render_command(command: Sequence[str] | None, name: str) -> str:
    """The shell command that renders the full report of experiment ``name``.

    Parameters
    ----------
    command : sequence of str or None
        The batch's own command line without ``--reports``/``--only`` (None: a library call,
        then the command is a generic ``motorid batch`` one with placeholders).
    name : str
        The experiment.

    Returns
    -------
    str
        One shell-quoted command line.
    """
    base = list(command) if command else ["motorid", "batch", "ROOT", "--out", "OUT"]
    return shlex.join([*base, "--reports", "full", "--only", name])


def _value(x: Any, ci: Any, fmt: str = ".4g") -> str:
    if x is None:
        return "—"
    text = format(float(x), fmt)
    if ci:
        text += f" [{format(float(ci[0]), fmt)}, {format(float(ci[1]), fmt)}]"
    return text


def report_stub(name: str, status: str, row: Mapping[str, Any], command: str) -> str:
    """The page written in place of a lazy report.

    Parameters
    ----------
    name : str
        The experiment (a path below the batch folder, ``/``-separated).
    status : str
        ``ok`` or ``warning``.
    row : Mapping[str, Any]
        The worker's summary values (:attr:`ExperimentOutcome.row`).
    command : str
        The command that renders the full report (:func:`render_command`).

    Returns
    -------
    str
        A self-contained HTML page (no script, no figure).
    """
    esc = html.escape
    up = "../" * (name.count("/") + 1)
    unit = row.get("dc_gain_unit") or ""
    rows = [
        ("status", status),
        ("DC gain [95 %]", f"{_value(row.get('dc_gain'), row.get('dc_gain_ci95'))} {unit}".strip()),
        ("τ (s) [95 %]", _value(row.get("time_constant"), row.get("time_constant_ci95"))),
        ("order", "—" if row.get("order") is None else str(row["order"])),
        ("method", str(row.get("method") or "—")),
        ("fit %", _value(row.get("fit_percent"), None, ".1f")),
    ]
    table = "".join(f"<tr><th>{esc(k)}</th><td>{esc(v)}</td></tr>" for k, v in rows)
    warnings = "".join(f"<li>{esc(str(w))}</li>" for w in row.get("warnings") or ())
    return f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>motorid batch: {esc(name)} (report not rendered yet)</title>
<style>body{{font:16px/1.45 system-ui,sans-serif;max-width:50rem;margin:2rem auto;padding:0 1rem}}
th{{text-align:left;padding-right:1.5rem}}pre{{background:#f4f4f4;padding:.6rem;white-space:pre-wrap;
word-break:break-all}}.warn{{color:#8a5300}}</style></head>
<body>
<p><a href="{esc(up)}summary.html">← class summary</a></p>
<h1>motorid batch: {esc(name)}</h1>
<p id="lazy-report">The full report of this experiment (figures, fit, conditioning, sensitivity, advice) has not
been rendered: the batch ran with <code>--reports lazy</code>. To render it, run this in a terminal, then reload
this page:</p>
<pre id="render-command">{esc(command)}</pre>
<p>Only this experiment is computed again (a few seconds); the others are kept.</p>
<h2>Model</h2>
<table>{table}</table>
{f'<h2>Warnings</h2><ul class="warn">{warnings}</ul>' if warnings else ''}
</body></html>
"""

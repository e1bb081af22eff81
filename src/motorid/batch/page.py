"""``summary.html``: the class at a glance — table, distribution plots, outliers, failures.

One self-contained page (figures inlined as PNG): a row per experiment with gain and τ and
their 95 % intervals, order, fit and warnings, linked to its report; histograms of gain and τ
and their scatter with the outliers marked; the outliers (modified z-score, see
:mod:`motorid.batch.summary`) and the failed captures with their one-line reasons.  Nothing
on the page depends on when or where the batch ran (no dates, no timings).
"""

from __future__ import annotations

import html
import io
from urllib.parse import quote
from collections.abc import Sequence

import numpy as np
from matplotlib.figure import Figure

from motorid.batch.summary import OUTLIER_Z, SummaryRow
from motorid.report.figures import data_uri

__all__ = ["summary_html"]

_CSS = """body{font-family:system-ui,sans-serif;margin:2em;max-width:80em}
table{border-collapse:collapse;font-size:.9em}td,th{border:1px solid #ccc;padding:.25em .5em;text-align:right}
td.l,th.l{text-align:left}tr.failed td{background:#fde8e8}tr.warning td{background:#fff8e0}
tr.outlier td{font-weight:bold}.flag{color:#b00}img{max-width:100%}"""


def _png(fig: Figure) -> str:
    buf = io.BytesIO()
    # no bbox_inches="tight": tight_layout has placed the axes already, and "tight" draws the
    # whole figure once more (a third of the summary page's time)
    fig.savefig(buf, format="png", dpi=80, metadata={"Software": None})
    return f'<img alt="class distribution" src="{data_uri(buf.getvalue())}">'


def _distribution_figure(rows: Sequence[SummaryRow], unit: str) -> str | None:
    """Histograms of gain (in ``unit``) and τ and their scatter (with 95 % intervals); outliers in red."""
    ok = [r for r in rows if r.status != "failed" and r.dc_gain is not None and r.time_constant is not None
          and r.dc_gain_unit == unit]
    if not ok:
        return None
    gain = np.array([r.dc_gain for r in ok])
    tau = np.array([r.time_constant for r in ok])
    out_g = np.array(["gain" in r.outlier for r in ok])
    out_t = np.array(["tau" in r.outlier for r in ok])
    fig = Figure(figsize=(12, 3.6))
    ax_g, ax_t, ax_s = fig.subplots(1, 3)
    bins = max(5, min(30, int(np.ceil(np.sqrt(len(ok)))) * 2))
    for ax, x, flag, label in ((ax_g, gain, out_g, f"DC gain ({unit})"), (ax_t, tau, out_t, "τ (s)")):
        ax.hist([x[~flag], x[flag]], bins=bins, stacked=True, color=["#4878a8", "#c03030"],
                label=["", "outlier"])
        ax.set_xlabel(label)
        ax.set_ylabel("experiments")
    # ok rows have a gain and a time constant (the rows without are failed or skipped)
    lo_g = [float(r.dc_gain or 0.0) - r.dc_gain_ci[0] if r.dc_gain_ci else 0.0 for r in ok]
    hi_g = [r.dc_gain_ci[1] - float(r.dc_gain or 0.0) if r.dc_gain_ci else 0.0 for r in ok]
    lo_t = [float(r.time_constant or 0.0) - r.time_constant_ci[0] if r.time_constant_ci else 0.0 for r in ok]
    hi_t = [r.time_constant_ci[1] - float(r.time_constant or 0.0) if r.time_constant_ci else 0.0 for r in ok]
    either = out_g | out_t
    ax_s.errorbar(tau, gain, xerr=[lo_t, hi_t], yerr=[lo_g, hi_g], fmt="none", ecolor="#999", lw=0.8)
    ax_s.scatter(tau[~either], gain[~either], s=14, color="#4878a8")
    ax_s.scatter(tau[either], gain[either], s=24, color="#c03030", label=f"outlier (|z| > {OUTLIER_Z:g})")
    ax_s.set_xlabel("τ (s)")
    ax_s.set_ylabel(f"DC gain ({unit})")
    if either.any():
        ax_s.legend(fontsize="small")
    fig.tight_layout()
    return _png(fig)


def _relative_href(path: str) -> str:
    """A link to one of the batch's own files, relative and percent-encoded.

    ``./`` first and each segment encoded, so that a folder a student named ``javascript:…`` is a
    path, never a scheme.
    """
    return "./" + "/".join(quote(part, safe="") for part in path.split("/"))


def _num(x: float | None, fmt: str = ".4g") -> str:
    return "—" if x is None else format(x, fmt)


def _with_ci(x: float | None, ci: tuple[float, float] | None) -> str:
    if x is None:
        return "—"
    return _num(x) + ("" if ci is None else f" [{ci[0]:.4g}, {ci[1]:.4g}]")


def summary_html(rows: Sequence[SummaryRow], *, title: str = "motorid batch summary") -> str:
    """The summary page.

    Parameters
    ----------
    rows : sequence of SummaryRow
        From :func:`motorid.batch.summary.summary_rows`.
    title : str
        Page title.

    Returns
    -------
    str
        A self-contained HTML page; report links are relative to the batch folder.
    """
    esc = html.escape
    counts = {s: sum(r.status == s for r in rows) for s in ("ok", "warning", "failed")}
    head = ["experiment", "status", "DC gain [95 %]", "τ (s) [95 %]", "order", "method", "fit %",
            "z gain", "z τ", "warnings"]
    table = ["<table><tr>" + "".join(f'<th{" class=l" if i in (0, 9) else ""}>{esc(h)}</th>'
                                     for i, h in enumerate(head)) + "</tr>"]
    for r in rows:
        name = esc(r.experiment)
        link = f'<a href="{esc(_relative_href(r.report))}">{name}</a>' if r.report else name
        cls = r.status + (" outlier" if r.outlier else "")
        what = esc(r.error) if r.status == "failed" else "<br>".join(esc(w) for w in r.warnings)
        flag = f' <span class=flag>outlier: {esc(r.outlier)}</span>' if r.outlier else ""
        table.append(
            f'<tr class="{cls}"><td class=l>{link}{flag}</td><td>{esc(r.status)}</td>'
            f"<td>{_with_ci(r.dc_gain, r.dc_gain_ci)}{'' if r.dc_gain is None else ' ' + esc(r.dc_gain_unit)}</td>"
            f"<td>{_with_ci(r.time_constant, r.time_constant_ci)}</td>"
            f"<td>{'—' if r.order is None else r.order}</td><td>{esc(r.method)}</td>"
            f"<td>{_num(r.fit_percent, '.1f')}</td>"
            f"<td>{_num(r.gain_z, '.2f')}</td><td>{_num(r.tau_z, '.2f')}</td><td class=l>{what}</td></tr>"
        )
    table.append("</table>")
    ok = [r for r in rows if r.status != "failed"]
    units = sorted({r.dc_gain_unit for r in ok})
    stats = ""
    if ok:
        t = np.array([r.time_constant for r in ok])
        gains = []
        for unit in units:  # experiments in different units never share a median or a histogram
            g = np.array([r.dc_gain for r in ok if r.dc_gain_unit == unit])
            gains.append(f"DC gain {np.median(g):.4g} {esc(unit)} (range {g.min():.4g}–{g.max():.4g}, "
                         f"{g.size} experiment{'s' if g.size > 1 else ''})")
        stats = (f"<p>Class median {'; '.join(gains)}; "
                 f"median τ {np.median(t):.4g} s (range {t.min():.4g}–{t.max():.4g} s).</p>")
    figures = [f for unit in units if (f := _distribution_figure(rows, unit)) is not None]
    figure = "\n".join(figures) or "<p>No identified experiment to plot.</p>"
    outliers = [r for r in rows if r.outlier]
    out_html = ("<ul>" + "".join(
        f"<li>{esc(r.experiment)}: {esc(r.outlier)} (z gain {_num(r.gain_z, '.2f')}, z τ {_num(r.tau_z, '.2f')})</li>"
        for r in outliers) + "</ul>") if outliers else f"<p>None (|z| ≤ {OUTLIER_Z:g} for every experiment).</p>"
    failed = [r for r in rows if r.status == "failed"]
    fail_html = ("<ul>" + "".join(f"<li>{esc(r.experiment)}: {esc(r.error)}</li>" for r in failed) + "</ul>"
                 if failed else "<p>None.</p>")
    return "\n".join([
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">', f"<title>{esc(title)}</title>",
        f"<style>{_CSS}</style></head><body>", f"<h1>{esc(title)}</h1>",
        f"<p>{len(rows)} experiments: {counts['ok']} ok, {counts['warning']} with warnings, "
        f"{counts['failed']} failed.</p>", stats,
        "<h2>Distribution</h2>", figure,
        f"<h2>Outliers</h2><p>Modified z-score 0.6745·(x − median)/MAD, flagged above {OUTLIER_Z:g} "
        "(Iglewicz &amp; Hoaglin 1993).</p>", out_html,
        "<h2>Failed captures</h2>", fail_html,
        "<h2>Experiments</h2>", *table, "</body></html>", "",
    ])

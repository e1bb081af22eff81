"""Speed of one slider move on the local web page (a 100 ms budget of server CPU per update).

One update = design + closed-loop simulation (3 s at 1 ms) + the closed-loop figure (the tab's
``figures.ClosedLoopCanvas`` redrawn as SVG) + the mode-map marker, as the page's
``/tab/{tab}/design`` endpoint does it. The bench writes the demo's captures (``motorid demo``,
seed 0), uploads them to a fresh app through FastAPI's ``TestClient``, identifies, draws the
mode maps once, then moves the ωn slider over ``--positions`` values and reads each response's
``Server-Timing`` header: ``cpu`` (the update thread's CPU time) and ``update`` (its wall
time). The check on the plausible motors comes in a request of its own that the page fires once
a move is shown (the ``robust-line`` placeholder): the bench sends it too and prints its CPU time
on its own line (it is not part of the move the budget is about, but the page's total is the sum).
It prints the medians, the machine's load before and after, and whether the median CPU time meets
the budget.

Run: ``python3 bench/web_update_speed.py [--positions 12] [--budget-ms 100]``

A timing belongs here, not in the unit tests (the brief): the functional part of the same
sequence (every position draws its own response, Kp grows as ωn²) is
``tests/web/test_web_pages.py::test_slider_moves_change_the_design``.
"""

from __future__ import annotations

import argparse
import html
import json
import os
import re
import statistics
import tempfile
from pathlib import Path

import numpy as np
from fastapi.testclient import TestClient

from motorid.cli.demo import run_demo
from motorid.web import WebSettings, create_app

ROLES = {"c0": "position", "c1": "velocity", "c2": "current", "c3": "validation", "c4": "validation",
         "c5": "validation"}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--positions", type=int, default=12)
    ap.add_argument("--budget-ms", type=float, default=100.0)
    args = ap.parse_args()
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        demo = Path(tmp) / "D"
        run_demo(demo, seed=0)
        files = sorted(demo.glob("ALL000[0-5]/F000[0-5]CH[12].CSV"))
        root = Path(tmp) / "root"
        root.mkdir()
        with TestClient(create_app(WebSettings(temp_root=root)), base_url="http://127.0.0.1") as client:
            tab = re.search(r'data-tab="([0-9a-f]{32})"', client.get("/").text).group(1)
            res = client.post(f"/tab/{tab}/upload", files=[("files", (p.name, p.read_bytes(), "text/csv"))
                                                           for p in files])
            res.raise_for_status()
            form = {f"role_{k}": v for k, v in ROLES.items()} | {"method": "auto", "order": "auto", "delay": "auto"}
            client.post(f"/tab/{tab}/identify", data=form).raise_for_status()
            base = {"damping": "0.7", "saturation": "10", "level": "5", "duration": "3"}
            client.post(f"/tab/{tab}/design", data=base | {"wn": "4"}).raise_for_status()  # draws the maps once
            cpu, wall, robust = [], [], []
            for wn in np.linspace(3.0, 12.0, args.positions):
                res = client.post(f"/tab/{tab}/design", data=base | {"wn": f"{wn:.3f}"})
                res.raise_for_status()
                timing = dict(re.findall(r"(\w+);dur=([\d.]+)", res.headers["server-timing"]))
                cpu.append(float(timing["cpu"]))
                wall.append(float(timing["update"]))
                line = re.search(r'id="robust-line"[^>]*hx-post="([^"]+)"[^>]*hx-vals=\'([^\']+)\'', res.text)
                if line:  # the follow-up request the page fires once the move is shown
                    rres = client.post(line.group(1), data=json.loads(html.unescape(line.group(2))))
                    rres.raise_for_status()
                    robust.append(float(dict(re.findall(r"(\w+);dur=([\d.]+)", rres.headers["server-timing"]))["cpu"]))
    load_after = os.getloadavg()[0]
    print(f"slider updates on the demo's model: {args.positions} positions, load {load_before:.2f} -> {load_after:.2f}")
    print(f"{'':24}{'median':>10}{'min':>10}{'max':>10}")
    rows = [("CPU time per update", cpu), ("wall time per update", wall)]
    if robust:
        rows.append(("CPU, robust follow-up", robust))
    for name, xs in rows:
        print(f"{name:24}{statistics.median(xs):>8.1f}ms{min(xs):>8.1f}ms{max(xs):>8.1f}ms")
    ok = statistics.median(cpu) <= args.budget_ms
    print("per position (ωn from 3 to 12 rad/s), CPU ms:", " ".join(f"{x:.0f}" for x in cpu))
    print(f"budget {args.budget_ms:g} ms on the median CPU time: {'met' if ok else 'NOT met'}")


if __name__ == "__main__":
    main()

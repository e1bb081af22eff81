"""``validate``'s simulation against python-control's, side by side in one process.

Run: ``python3 bench/validate_speed.py [--samples 10000,100000,1000000] [--repeat 3]``.

For each record length, one third-order servo (a position integrator, a 5 rad/s mechanical and a
150 rad/s electrical pole) driven by a noisy sine at 1 kHz, simulated with the input linear
between samples, from rest and from each unit initial state (what ``validate`` needs to estimate
the initial state):

- ``python-control``: ``control.forced_response`` + three ``control.initial_response`` (a Python
  loop over the samples each; what ``validate`` ran before);
- ``motorid``: :func:`motorid.model.forced.linear_hold_response` (the same discretisation, block
  recursions).

CPU seconds (``time.process_time``, the best of ``--repeat`` runs), their ratio, and the largest
difference between the two relative to the response's peak.  The load average is printed before
and after (the machine may be shared).
"""

from __future__ import annotations

import argparse
import os
import time

import control
import numpy as np

from motorid.model.forced import linear_hold_response

A = np.array([[0.0, 1.0, 0.0], [0.0, -5.0, 30.0], [0.0, -2.0, -150.0]])
B = np.array([[0.0], [0.0], [40.0]])
C = np.array([[0.0, 1.0, 0.0]])
D = np.zeros((1, 1))
DT = 1e-3


def _best(fn, repeat: int) -> tuple[float, object]:
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.process_time()
        out = fn()
        best = min(best, time.process_time() - t0)
    return best, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", default="10000,100000,1000000")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"load average before: {os.getloadavg()[0]:.2f}")
    print("| samples | python-control CPU s | motorid CPU s | ratio | max difference / peak |")
    print("| ---: | ---: | ---: | ---: | ---: |")
    sys = control.ss(A, B, C, D)
    for n in (int(s) for s in args.samples.split(",")):
        t = np.arange(n) * DT
        u = np.sin(2 * np.pi * 3 * t) + 0.1 * np.random.default_rng(0).standard_normal(n)

        def peer(t: np.ndarray = t, u: np.ndarray = u) -> np.ndarray:
            cols = [np.ravel(control.forced_response(sys, t, u).outputs)]
            cols += [np.ravel(control.initial_response(sys, t, X0=x0).outputs) for x0 in np.eye(3)]
            return np.column_stack(cols)

        def ours(u: np.ndarray = u) -> np.ndarray:
            forced, free = linear_hold_response(A, B, C, D, DT, u, np.eye(3))
            return np.column_stack([forced, free])

        s_peer, y_peer = _best(peer, args.repeat)
        s_ours, y_ours = _best(ours, args.repeat)
        diff = float(np.max(np.abs(np.asarray(y_ours) - np.asarray(y_peer))) / np.max(np.abs(y_peer)))
        print(f"| {n} | {s_peer:.3f} | {s_ours:.4f} | {s_peer / s_ours:.1f}× | {diff:.1e} |")
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()

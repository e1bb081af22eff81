"""
Design and robustness
=====================

State feedback with ζ = 1 and ωn = 8 rad/s on the identified model, its stability margins,
the design on the plausible motors (when this version has it), and a closed-loop run.
"""

import tempfile
from pathlib import Path

import motorid as mi
from motorid.io import write_tds_capture
from motorid.trainer import run_experiment

exp = run_experiment("paper", step_volts=5.92, seed=0)
folder = Path(tempfile.mkdtemp())
paths = {role: write_tds_capture(folder, exp.captures[role], index=i)
         for i, role in enumerate(("position", "velocity", "current"))}
fit = mi.identify(mi.read_experiment(**paths))
des = mi.design(fit.model, damping=1, wn=8)
print(des.margins.text())
robust = getattr(des, "robust", None)
if robust is not None:
    print(robust.text())
sim = mi.simulate(fit.model, des, duration_s=3.0)
sim.plot()

"""
Identify a scope capture
========================

Record the paper's step experiment on the virtual trainer, write it as Tektronix TDS files,
read them back and identify the motor.
"""

import tempfile
from pathlib import Path

import motorid as mi
from motorid.io import write_tds_capture
from motorid.trainer import run_experiment

folder = Path(tempfile.mkdtemp())
exp = run_experiment("paper", step_volts=5.92, seed=0)
paths = {role: write_tds_capture(folder, exp.captures[role], index=i)
         for i, role in enumerate(("position", "velocity", "current"))}

experiment = mi.read_experiment(**paths)
fit = mi.identify(experiment)
print(fit.summary())
fit.plot()

"""
A batch of experiments
======================

Three students' experiments (three seeds of the trainer) identified one after the other, with
the table a teacher would compare. ``motorid batch FOLDER --out DIR`` does the same on folders.
"""

import tempfile
from pathlib import Path

import motorid as mi
from motorid.io import write_tds_capture
from motorid.trainer import run_experiment

root = Path(tempfile.mkdtemp())
for seed in (1, 2, 3):
    exp = run_experiment("paper", step_volts=5.92, seed=seed)
    velocity = write_tds_capture(root / f"student{seed}", exp.captures["velocity"], index=1)
    fit = mi.identify(mi.read_experiment(velocity=velocity))
    gain = fit.params["dc_gain"]
    print(f"seed {seed}: dc gain {gain.value:.4f} (95 % interval {gain.ci95})")

"""
Identify a rig log in rpm
=========================

A hobby rig (L298N driver, encoder logged in rpm by a microcontroller) written as the CSV its
logger makes; identified with the options a user would give ``motorid identify``.
"""

import tempfile
from pathlib import Path

import motorid as mi
from motorid.trainer.realsetups import write_real_setup

recording = write_real_setup("l298n-rpm", Path(tempfile.mkdtemp()))
print("motorid identify", " ".join(recording.cli_args))

experiment = mi.read_experiment(velocity=recording.cli_args[1])
fit = mi.identify(experiment)
print(fit.summary())
print(f"trainer truth: dc gain {recording.truth.dc_gain:.1f} {recording.truth.output_units}/V, "
      f"time constant {recording.truth.time_constant_s:.4f} s")
fit.plot()

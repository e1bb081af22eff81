"""
Several step levels
===================

Steps at five levels, twice each, on a trainer with a dead-zone and rails: one Hammerstein
model (dead-zone, gain, rails and the shared dynamics) from all of them.
"""

import tempfile
from pathlib import Path

import motorid as mi
from motorid.io import write_tds_capture
from motorid.trainer.multilevel import multilevel_experiment

exp = multilevel_experiment("deadzone-rails", levels=(2.0, 4.0, 6.0, 8.0, 10.0), repeats=2, seed=7)
folder = Path(tempfile.mkdtemp())
files = [write_tds_capture(folder, c.capture, index=i) for i, c in enumerate(exp.captures)]
result = mi.identify_levels(files)
static = result.static
print(f"gain {static.gain:.4f} V/V, dead-zone {static.dead_zone_v:.3f} V, rails at {static.saturation_output_v} V")
print(result.dynamics_note)
print(result.model.velocity_tf)

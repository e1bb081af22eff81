"""The trainer's signal generator, importable here as before.

The waveforms live in :mod:`motorid.simulation.signals` (the closed-loop reference uses them too).
"""

from motorid.simulation.signals import *  # noqa: F403
from motorid.simulation.signals import __all__  # noqa: F401

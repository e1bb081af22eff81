"""The trainer's signal generator, importable here as before.

The waveforms live in :mod:`motorid.simulate.signals` (the closed-loop reference uses them too).
"""

from motorid.simulate.signals import *  # noqa: F403
from motorid.simulate.signals import __all__  # noqa: F401

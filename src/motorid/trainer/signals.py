"""The trainer's signal generator: the waveforms live in :mod:`motorid.simulate.signals` (the
closed-loop reference uses them too); importable here as before."""

from motorid.simulate.signals import *  # noqa: F403
from motorid.simulate.signals import __all__  # noqa: F401

"""A closed-loop run's settings refuse what would silently show nothing."""

from __future__ import annotations

import math

import pytest

from motorid.errors import OptionError
from motorid.simulation.closed_loop import SimulationSettings


def test_a_load_that_starts_after_the_run_is_refused():
    """Before, ``--disturbance 1 --disturbance-start 100`` on a 5 s run printed the unloaded
    response as if the load had been applied."""
    with pytest.raises(OptionError, match=r"^--disturbance-start 100 s is at or after the end of the run "
                                          r"\(--duration 5 s\): the load would never act"):
        SimulationSettings(duration_s=5.0, disturbance_v=1.0, disturbance_start_s=100.0)
    SimulationSettings(duration_s=5.0, disturbance_v=1.0, disturbance_start_s=4.0)  # inside the run
    SimulationSettings(duration_s=5.0, disturbance_v=0.0, disturbance_start_s=100.0)  # no load: nothing to miss


@pytest.mark.parametrize(("name", "flag"), [("disturbance_v", "--disturbance"),
                                            ("disturbance_start_s", "--disturbance-start"), ("z0", "--z0")])
def test_a_value_that_is_not_finite_is_named_by_its_flag(name, flag):
    with pytest.raises(OptionError, match=f"^{flag} must be finite, got nan$"):
        SimulationSettings(**{name: math.nan})

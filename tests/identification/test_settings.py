"""Settings validate themselves on construction: a bad value fails at once with a
one-line OptionError naming the Python parameter, not deep inside the pipeline."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from motorid.conditioning.pipeline import ConditioningSettings
from motorid.errors import OptionError
from motorid.identification.pipeline import IdentifySettings


@pytest.mark.parametrize("changes, name", [
    ({"sample_interval_s": 0.0}, "sample_interval_s"), ({"sample_interval_s": math.nan}, "sample_interval_s"),
    ({"sample_interval_s": "fast"}, "sample_interval_s"), ({"ratio": 0}, "ratio"), ({"ratio": 2.5}, "ratio"),
    ({"reduction": "median"}, "reduction"), ({"record_length_s": -1.0}, "record_length_s"),
    ({"record_length_s": math.inf}, "record_length_s"), ({"sync": "nearest"}, "sync"),
    ({"step_tolerance": 0.0}, "step_tolerance"),
])
def test_conditioning_settings_refuse_bad_values(changes, name) -> None:
    with pytest.raises(OptionError, match=name) as info:
        ConditioningSettings(**changes)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize("changes, name", [
    ({"method": "magic"}, "method"), ({"order": 4}, "order"), ({"order": True}, "order"), ({"order": "2"}, "order"),
    ({"derivative": "spline"}, "derivative"), ({"structure": "half"}, "structure"),
    ({"markov_params": 2}, "markov_params"), ({"markov_window_s": 0.0}, "markov_window_s"),
    ({"delay": "yes"}, "delay"), ({"markov_basis": "fourier"}, "markov-basis"),
])
def test_identify_settings_refuse_bad_values(changes, name) -> None:
    with pytest.raises(OptionError, match=name):
        IdentifySettings(**changes)


def test_good_settings_and_replace_still_work() -> None:
    s = IdentifySettings(method="oe", order=2, delay=True, markov_params=11, markov_window_s=0.5,
                         conditioning=ConditioningSettings(sample_interval_s=0.1, record_length_s=2.4))
    assert replace(s, order="auto").order == "auto"
    with pytest.raises(OptionError, match="order"):
        replace(s, order=7)

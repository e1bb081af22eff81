"""Options that are valid numbers but impossible for the data: refused in one line naming them.

Before: ``mi.identify(exp, record_length_s=0.001)`` and ``--markov-window 1e-9`` ended in
``IndexError: index 1 is out of bounds`` (the command line checked the record length itself,
the front door did not); ``--markov-params 1000000`` with ``auto`` was dropped without a word (the
Markov stage failed, the fit started from the classic method, the printout did not say so).
"""

from __future__ import annotations

import pytest

import motorid as mi
from motorid.errors import IdentificationError, OptionError
from motorid.identification import pipeline
from motorid.trainer import run_experiment


@pytest.fixture(scope="module")
def velocity_capture(tmp_path_factory):
    from motorid.io import write_tds_capture

    exp = run_experiment("first-order", seed=0)
    return write_tds_capture(tmp_path_factory.mktemp("cap"), exp.captures["velocity"], index=1)


@pytest.mark.parametrize(("options", "words"), [
    ({"record_length_s": 0.001}, r"^.*ALL0001: record_length_s 0.001 s holds fewer than 20 samples"),
    ({"markov_window_s": 1e-9}, r"^markov_window_s 1e-09 s holds 1 sample\(s\) after the step .*at least 20"),
    ({"markov_window_s": 1e-9, "method": "markov"}, r"^markov_window_s 1e-09 s holds 1 sample"),
    ({"markov_params": 1_000_000}, r"^markov_params 1000000: at most \d+ for this record"),
])
def test_an_option_the_data_cannot_take_is_refused_naming_it(velocity_capture, options, words):
    exp = mi.read_experiment(velocity=velocity_capture)
    with pytest.raises(OptionError, match=words) as info:
        mi.identify(exp, **options)
    assert "\n" not in str(info.value)


def test_a_paper_method_that_fails_on_the_data_is_named_in_the_warnings(velocity_capture, monkeypatch):
    """``auto`` goes on from the other paper methods, and says which one did not run and why."""
    def broken(cond, settings):
        raise IdentificationError("no 63 % crossing in this record")

    monkeypatch.setitem(pipeline._RUNNERS, "classic", broken)
    fit = mi.identify(mi.read_experiment(velocity=velocity_capture))
    assert "the paper's classic method did not run: no 63 % crossing in this record" in fit.model.warnings
    assert all(st.get("method") != "classic" for st in fit.model.stages)

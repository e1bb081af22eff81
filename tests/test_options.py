"""The options declared once (motorid.options) are the front door's, the web page's, the batch's
and the command line's; a message names an option as its caller did."""

from __future__ import annotations

import inspect

import pytest

import motorid as mi
from motorid import options
from motorid.batch.task import IDENTIFY_OPTIONS
from motorid.web import options as web_options


@pytest.mark.parametrize("command", sorted(options.COMMANDS))
def test_the_front_door_signature_is_the_declared_options(command):
    params = inspect.signature(getattr(mi, command)).parameters
    # identify takes read_experiment's Experiment; the captures, the progress hook and the Python-only settings
    # objects are no options of the command line
    declared = {"identify": options.IDENTIFY, "read_experiment": options.READ}.get(command, options.COMMANDS[command])
    hooks = (*options.names(options.ROLES), "progress", *options.PYTHON_ONLY)
    keyword = {n: p for n, p in params.items() if p.kind is inspect.Parameter.KEYWORD_ONLY and n not in hooks}
    assert list(keyword) == list(options.names(declared))
    for spec in declared:
        assert keyword[spec.name].default == spec.default, spec.name


def test_the_web_page_and_the_batch_take_the_declared_options():
    assert options.names(options.IDENTIFY) == web_options.IDENTIFY_OPTIONS
    assert options.names(options.DESIGN) == web_options.DESIGN_OPTIONS
    assert options.names(options.SIMULATE) == web_options.SIMULATE_OPTIONS
    assert options.defaults(options.IDENTIFY) == IDENTIFY_OPTIONS


@pytest.mark.parametrize(("command", "specs"), [("identify", options.READ + options.IDENTIFY),
                                                ("design", options.DESIGN), ("simulate", options.SIMULATE),
                                                ("validate", options.VALIDATE)])
def test_every_declared_option_is_a_flag_of_its_command(command, specs):
    import typer.main

    from motorid.cli.app import app

    click_cmd = typer.main.get_command(app).commands[command]
    flags = {opt for p in click_cmd.params for opt in (*p.opts, *p.secondary_opts)}
    missing = [s.flag for s in specs if s.flag not in flags]
    assert not missing, missing


#: Command-line defaults that spell the declared default otherwise: no --sample-interval is "auto".
_SPELLED_OTHERWISE = {("identify", "--sample-interval"): (None, "auto")}


@pytest.mark.parametrize(("command", "specs"), [("identify", options.READ + options.IDENTIFY),
                                                ("design", options.DESIGN), ("simulate", options.SIMULATE),
                                                ("validate", options.VALIDATE), ("advise", options.ADVISE)])
def test_the_command_line_defaults_are_the_declared_ones(command, specs):
    # a default declared twice drifts (simulate's record length was 5 s on the command line and
    # 3 s from Python and the web API)
    import typer.main

    from motorid.cli.app import app

    click_cmd = typer.main.get_command(app).commands[command]
    by_flag = {opt: p for p in click_cmd.params for opt in (*p.opts, *p.secondary_opts)}
    drift = [(s.flag, by_flag[s.flag].default, s.default) for s in specs
             if (by_flag[s.flag].default, s.default) != _SPELLED_OTHERWISE.get((command, s.flag), (s.default,) * 2)]
    assert not drift, drift


def test_a_python_caller_reads_the_names_it_used(demo_run):
    m = mi.identify(mi.read_experiment(velocity=demo_run.folder / "ALL0001"), method="pinv").model
    with pytest.raises(mi.MotorIdError) as err:
        mi.design(m, settling_time=1.0, overshoot=120)
    assert str(err.value) == "overshoot must be a percentage in [0, 100), got 120"
    with pytest.raises(mi.MotorIdError, match=r"^settling_time and overshoot go together$"):
        mi.design(m, settling_time=1.0)
    with pytest.raises(mi.MotorIdError, match=r"^step_volts"):
        mi.read_experiment(velocity=demo_run.folder / "ALL0001", step_volts=0)


def test_the_command_line_reads_its_flags(demo_run, run_cli):
    res = run_cli("design", demo_run.folder / "model.json", "--settling-time", "1", "--overshoot", "120")
    assert res.code == 2
    assert "--overshoot must be a percentage in [0, 100), got 120" in res.err


def test_only_the_commands_own_flags_are_translated():
    said = options.in_callers_words("--overshoot must be < 100; see --t0 and --no-such-flag", "design")
    assert said == "overshoot must be < 100; see --t0 and --no-such-flag"
    assert options.in_callers_words("--t0 is outside the record", "identify") == "t0 is outside the record"

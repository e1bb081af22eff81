"""An optional part used without its extra says which extra to install (one line, exit 2),
never a traceback: the core install is numpy/scipy/python-control (checked by hand in a fresh
venv without extras; here the missing modules are simulated)."""

from __future__ import annotations

import importlib.util

import pytest


@pytest.mark.parametrize("missing", ["yaml", "pyvisa_sim", "pyvisa"])
def test_scope_simulation_without_the_visa_extra(run_cli, monkeypatch, missing):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == missing else real(name, *a))
    res = run_cli("scope", "list", "--simulate")
    assert res.code == 2, res.err
    assert res.err.count("\n") == 1 and "pip install 'motorid[visa]'" in res.err and missing in res.err

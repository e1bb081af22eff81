"""Every public function and method of the library documents its Parameters and Returns.

numpydoc's own validator (``numpydoc.validate``) checks each one: PR01 (a parameter not
documented), PR02 (a documented parameter that does not exist), RT01 (no Returns section) and
GL08 (no docstring).  Public = listed in the module's ``__all__`` (or, without one, not
starting with ``_``) and defined in that module; methods of public classes likewise.  The
command line (``motorid.cli``) is documented by its ``--help`` text instead.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

import pytest

import motorid

numpydoc_validate = pytest.importorskip("numpydoc.validate")

CHECKED = ("PR01", "PR02", "RT01", "GL08")


def _public_callables() -> list[str]:
    out: list[str] = []
    for info in pkgutil.walk_packages(motorid.__path__, "motorid."):
        parts = info.name.split(".")[1:]
        if parts[0] == "cli" or any(p.startswith("_") for p in parts):
            continue
        try:
            mod = importlib.import_module(info.name)
        except ImportError:  # an optional extra that is not installed
            continue
        names = getattr(mod, "__all__", None) or [n for n in vars(mod) if not n.startswith("_")]
        for name in names:
            obj = getattr(mod, name, None)
            if getattr(obj, "__module__", None) != info.name:
                continue  # re-exported: checked where it is defined
            if inspect.isfunction(obj):
                out.append(f"{info.name}.{name}")
            elif inspect.isclass(obj):
                out += [f"{info.name}.{name}.{attr}" for attr, value in vars(obj).items()
                        if not attr.startswith("_") and inspect.isfunction(value)]
    return out


PUBLIC = _public_callables()


def test_the_walk_finds_the_library():
    # the walk itself must see the stages, or the test below would pass on nothing
    assert len(PUBLIC) > 150
    for name in ("motorid.frontdoor.identify", "motorid.model.motor.MotorModel.reduce",
                 "motorid.conditioning.derivative.five_point_derivative"):
        assert name in PUBLIC


def test_public_functions_document_parameters_and_returns():
    missing = {}
    for name in PUBLIC:
        errors = [code for code, _ in numpydoc_validate.validate(name)["errors"] if code in CHECKED]
        if errors:
            missing[name] = errors
    assert not missing, f"{len(missing)} public functions lack numpydoc sections: " + ", ".join(
        f"{k} {v}" for k, v in sorted(missing.items()))

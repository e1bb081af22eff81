"""Identification methods of the paper, as pure functions on conditioned numpy arrays.

- :mod:`~motorid.identification.pinv`: pseudo-inverse state-space fit (Masoud 2019, §III).
- :mod:`~motorid.identification.markov`: Markov parameters, Hankel order test, companion
  realisation (Masoud 2019, §IV).
- :mod:`~motorid.identification.classic`: first-order gain and 63.2 % time constant (lab report
  §1.1, paper Fig. 1).

The names below load on first use (``import motorid.identification.result`` for the result types
must not pull scipy and python-control into a light import of the front door).
"""

from __future__ import annotations

import importlib
from typing import Any

#: Public names and the module each lives in.
_LAZY: dict[str, str] = {
    "ClassicResult": "classic", "classic_first_order": "classic",
    "MarkovParameters": "markov", "MarkovResult": "markov", "MarkovSettings": "markov",
    "companion_realisation": "markov", "detect_order": "markov", "hankel_matrix": "markov",
    "hankel_singular_values": "markov", "markov_identify": "markov", "markov_parameters": "markov",
    "PinvResult": "pinv", "PinvSettings": "pinv", "pinv_identify": "pinv",
    "IdentificationError": "result", "ParameterEstimate": "result",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return getattr(importlib.import_module(f"motorid.identification.{module}"), name)


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))

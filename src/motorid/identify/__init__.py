"""Identification methods of the paper, as pure functions on conditioned numpy arrays.

- :mod:`~motorid.identify.pinv`: pseudo-inverse state-space fit (Masoud 2019, §III).
- :mod:`~motorid.identify.markov`: Markov parameters, Hankel order test, companion
  realisation (Masoud 2019, §IV).
- :mod:`~motorid.identify.classic`: first-order gain and 63.2 % time constant (lab report
  §1.1, paper Fig. 1).
"""

from motorid.identify.classic import ClassicResult, classic_first_order
from motorid.identify.markov import (
    MarkovParameters,
    MarkovResult,
    MarkovSettings,
    companion_realisation,
    detect_order,
    hankel_matrix,
    hankel_singular_values,
    markov_identify,
    markov_parameters,
)
from motorid.identify.pinv import PinvResult, PinvSettings, pinv_identify
from motorid.identify.result import IdentificationError

__all__ = [
    "ClassicResult",
    "IdentificationError",
    "MarkovParameters",
    "MarkovResult",
    "MarkovSettings",
    "PinvResult",
    "PinvSettings",
    "classic_first_order",
    "companion_realisation",
    "detect_order",
    "hankel_matrix",
    "hankel_singular_values",
    "markov_identify",
    "markov_parameters",
    "pinv_identify",
]

"""The settings of the estimators inside a method, for Python callers: ``identify(method_options=…)``.

The command line and the web page expose what a student chooses (method, order, dead time,
Markov terms); an engineer scripting an identification may want the estimators' own knobs too —
the Laguerre basis pole, SRIVC's iterations, the output-error fit's evaluations and tolerances.
Each estimator's own settings class is passed as it is (:class:`~motorid.identification.laguerre.LaguerreSettings`,
:class:`~motorid.identification.srivc.SrivcSettings`); the output-error fit, whose structure the
order search sets, takes :class:`OutputErrorOptions`.  Fields a method sets itself from
``identify``'s own parameters (the Laguerre ``n_terms`` from ``markov_params``, the ``order``,
SRIVC's poles and zeros from the structure search) are taken from those; asking for two different
values is an error naming both.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from motorid.errors import OptionError

if TYPE_CHECKING:
    from motorid.identification.laguerre import LaguerreSettings
    from motorid.identification.srivc import SrivcSettings

__all__ = ["DEFAULT_OUTPUT_ERROR", "FIT_TOLERANCE", "MAX_NFEV", "SEARCH_NFEV",
           "SEARCH_TOLERANCE", "MethodOptions", "OutputErrorOptions", "positive_int", "tolerance"]

#: Most model evaluations of one output-error fit.
MAX_NFEV = 200
#: Stopping tolerance of the chosen structure's fit (``ftol`` and ``xtol``; scipy's default 1e-8).
FIT_TOLERANCE = 1e-8
#: Stopping tolerance of the order search's candidate structures (their BIC then moves by about
#: 1e-6 of the sample count, far under the differences it decides on), of the sanity gate's refit
#: and of auto's SRIVC second opinion.  Not looser: whether a candidate's extra pole is resolved
#: is read off its covariance where the fit stopped, and at 1e-5 three of twenty third-order
#: records lost their third pole that way (BIC 0.05 from the optimum, the pole's interval wider).
SEARCH_TOLERANCE = 1e-6
#: Evaluations of a candidate structure before the search checks how far it still is from the
#: best (most candidates on the trainer's presets converge in 3–36; over-parametrised ones
#: crawled on for up to 200 to gain a few BIC units).
SEARCH_NFEV = 40


def positive_int(name: str, value: Any) -> None:
    """Refuse ``value`` unless it is a whole number ≥ 1, naming ``method_options.<name>``.

    Parameters
    ----------
    name : str
        The field's path below ``method_options`` (``srivc.max_iter``).
    value : Any
        The value given.

    Raises
    ------
    OptionError
        Not a whole number ≥ 1.
    """
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise OptionError(f"method_options.{name} must be a whole number ≥ 1, got {value!r}")


def tolerance(name: str, value: Any) -> None:
    """Refuse ``value`` unless it is a number strictly between 0 and 1, naming ``method_options.<name>``.

    Parameters
    ----------
    name : str
        The field's path below ``method_options`` (``srivc.tol``).
    value : Any
        The value given.

    Raises
    ------
    OptionError
        Not a finite number in (0, 1).
    """
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0 < float(value) < 1) \
            or not math.isfinite(float(value)):
        raise OptionError(f"method_options.{name} must be a number between 0 and 1, got {value!r}")


@dataclass(frozen=True, slots=True)
class OutputErrorOptions:
    """The output-error fit's own settings (methods ``auto`` and ``oe``).

    Attributes
    ----------
    max_nfev : int
        Most model evaluations of each fit (a fit that reaches it says so in the warnings).
    tolerance : float
        Relative change of the cost and of the parameters that ends the chosen structure's fit.
    search_tolerance : float
        The same for the candidate structures of the order search and the sanity gate's refit.
    search_nfev : int
        Evaluations a candidate structure gets before the search looks at it: one still
        :data:`~motorid.identification.stages.FAR_BIC` or more above the best BIC so far is left
        there and said so (such candidates crawl along a valley of near-cancelling poles and
        zeros for hundreds of evaluations to gain a few BIC units), the others run on to
        ``max_nfev``.
    """

    max_nfev: int = MAX_NFEV
    tolerance: float = FIT_TOLERANCE
    search_tolerance: float = SEARCH_TOLERANCE
    search_nfev: int = SEARCH_NFEV

    def __post_init__(self) -> None:
        positive_int("output_error.max_nfev", self.max_nfev)
        positive_int("output_error.search_nfev", self.search_nfev)
        tolerance("output_error.tolerance", self.tolerance)
        tolerance("output_error.search_tolerance", self.search_tolerance)


@dataclass(frozen=True, slots=True)
class MethodOptions:
    """Settings of the estimators a method runs (``None``: the method's defaults).

    Attributes
    ----------
    laguerre : LaguerreSettings or None
        The Laguerre–Hankel (Markov) estimate: basis pole, terms, orders, noise floor, polish.
        Used by ``markov`` (Laguerre basis) and by ``auto``/``paper-auto``, which run it among
        the paper's methods.
    srivc : SrivcSettings or None
        SRIVC's iterations and tolerance (method ``srivc``, and ``auto``'s second opinion).
    output_error : OutputErrorOptions or None
        The output-error fit (methods ``auto`` and ``oe``).
    """

    laguerre: LaguerreSettings | None = None
    srivc: SrivcSettings | None = None
    output_error: OutputErrorOptions | None = None

    def __post_init__(self) -> None:
        from motorid.identification.laguerre import LaguerreSettings
        from motorid.identification.srivc import SrivcSettings

        for name, value, kind in (("laguerre", self.laguerre, LaguerreSettings), ("srivc", self.srivc, SrivcSettings),
                                  ("output_error", self.output_error, OutputErrorOptions)):
            if value is not None and not isinstance(value, kind):
                raise OptionError(f"method_options.{name} must be a {kind.__name__} or None, "
                                  f"got {type(value).__name__}")

    @property
    def oe(self) -> OutputErrorOptions:
        """The output-error settings in force (the defaults when none were given)."""
        return self.output_error if self.output_error is not None else DEFAULT_OUTPUT_ERROR


#: The output-error fit's default settings.
DEFAULT_OUTPUT_ERROR = OutputErrorOptions()

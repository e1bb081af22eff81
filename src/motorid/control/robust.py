"""Is the design good for every motor the data allow? A Monte-Carlo check over the fit's uncertainty.

An identified model is one motor out of many the captures cannot tell apart: the output-error
fit's covariance (the model JSON's ``uncertainty.joint``: DC gain, log time constants, zero time
constants, dead time, position scale and current numerator; for the Markov method's polish, the
velocity transfer function's coefficients and the dead time) describes them.  This module draws
plausible motors from that Gaussian, restricted to its 95 % region (Mahalanobis distance below
the χ² quantile), rebuilds each with the fit's own realisation
(:func:`motorid.model.motor.realise_tfs`), re-expresses it in the sensors' coordinates the
design's gains act on, and closes the loop with the *designed* controller (its observer keeps the
nominal model: it is code that does not know which motor it runs on).  For each motor: the
closed loop's stability (eigenvalues, the dead time as a Padé approximant), the reference step's
overshoot and 2 % settling time, and the loop's phase margin, gain margin and sensitivity peak
(loop broken at the motor's input, the dead time exact as ``e^{−jωτ}``).

Written here rather than with python-control's per-system functions: they cost 5–15 ms per
motor (``step_response``, ``stability_margins``), 10–30 s for 2000 motors; the same quantities
are computed for all motors at once — the step response exactly at the grid's instants by the
matrix exponential (scipy's stacked ``expm``), the margins from the loop's frequency response on
a grid, the way python-control's ``stability_margins(method="frd")`` reads them.  The tests
compare both with python-control on single motors.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from motorid.model.lti import zoh

if TYPE_CHECKING:
    from motorid.control.design import Design
    from motorid.model import MotorModel

__all__ = ["DEFAULT_SAMPLES", "RobustCheck", "RobustCheckUnavailable", "RobustSpec", "robust_check"]

#: Plausible motors drawn by default.
DEFAULT_SAMPLES = 2000
#: The joint region sampled: the parameters' 95 % confidence region.
REGION = 0.95
#: Points of each simulated reference step.
STEP_POINTS = 800
#: Order of the dead time's Padé approximant in the closed loop's eigenvalues and steps.
PADE_ORDER = 6
#: Instants of the step-response band kept in the design JSON.
BAND_POINTS = 150
#: Frequencies of the loop's response (log-spaced around the nominal loop's crossover).
MARGIN_POINTS = 240
#: A rebuilt nominal motor must match the model's velocity TF to this relative tolerance, or
#: the covariance belongs to another model (one simplified after the fit).
MATCH_RTOL = 1e-6


@dataclass(frozen=True, slots=True)
class RobustSpec:
    """What a plausible motor's loop must meet besides stability.

    Attributes
    ----------
    overshoot_pct : float or None
        Largest percent overshoot of the reference step.
    settling_time_s : float or None
        Longest 2 % settling time.
    """

    overshoot_pct: float | None = None
    settling_time_s: float | None = None

    @property
    def given(self) -> bool:
        """Whether anything beyond stability is asked for."""
        return self.overshoot_pct is not None or self.settling_time_s is not None

    def text(self) -> str:
        """The spec in words.

        Returns
        -------
        str
            ``overshoot ≤ 5 %, settling ≤ 1.2 s`` (empty without a spec).
        """
        from motorid.numfmt import sig

        parts = []
        if self.overshoot_pct is not None:
            parts.append(f"overshoot ≤ {sig(self.overshoot_pct)} %")
        if self.settling_time_s is not None:
            parts.append(f"settling ≤ {sig(self.settling_time_s)} s")
        return ", ".join(parts)


@dataclass(frozen=True, slots=True)
class RobustCheck:
    """The design on plausible motors.

    Attributes
    ----------
    samples : int
        Motors drawn from the joint 95 % region.
    stable_fraction : float
        Fraction with a stable closed loop.
    spec_fraction : float or None
        Fraction stable and meeting ``spec`` (None without a spec).
    spec : RobustSpec
    overshoot_pct, settling_time_s, phase_margin_deg, gain_margin_db, ms : tuple of float
        2.5 %, 50 % and 97.5 % points over the stable motors (NaN without any; an infinite
        margin counts as infinite).
    parameters : tuple of str
        The model parameters varied.
    seed : int
        The random generator's seed (the check is reproducible).
    note : str
        How the motors were drawn, in one sentence.
    band : tuple of four tuples of float
        The unit reference step over the stable motors: time (s), then the 2.5 %, 50 % and
        97.5 % points of the measured output at each instant (:data:`BAND_POINTS` instants).
    nominal_overshoot_pct, nominal_settling_time_s : float
        The same step on the model itself (its dead time included), by the same computation
        (NaN when unknown).  A design asked for by ``--settling-time`` and ``--overshoot`` places
        its dominant pair by the textbook rules, exact for a lone pair only: the loop's other
        poles, zeros and observer move its step, and this says where to before the ranges do.
    """

    samples: int
    stable_fraction: float
    spec_fraction: float | None
    spec: RobustSpec
    overshoot_pct: tuple[float, float, float]
    settling_time_s: tuple[float, float, float]
    phase_margin_deg: tuple[float, float, float]
    gain_margin_db: tuple[float, float, float]
    ms: tuple[float, float, float]
    parameters: tuple[str, ...]
    seed: int
    note: str
    band: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...]] = ((), (), (), ())
    nominal_overshoot_pct: float = math.nan
    nominal_settling_time_s: float = math.nan

    def nominal_misses(self) -> str:
        """What of the spec the nominal model's own loop misses, in words ('' when it meets it or is unknown).

        Returns
        -------
        str
            ``settling 1.083 s (asked ≤ 1 s)``; parts joined by ``and``.
        """
        from motorid.numfmt import sig

        parts = []
        for value, bound, name, unit in ((self.nominal_overshoot_pct, self.spec.overshoot_pct, "overshoot", " %"),
                                         (self.nominal_settling_time_s, self.spec.settling_time_s, "settling",
                                          " s")):
            if bound is not None and math.isfinite(value) and value > bound:
                parts.append(f"{name} {sig(value)}{unit} (asked ≤ {sig(bound)}{unit})")
        return " and ".join(parts)

    def text(self) -> str:
        """One sentence for a terminal.

        Returns
        -------
        str
            ``stable for 100 % of 2000 plausible motors; overshoot 4–9 %, settling 0.8–1.1 s,
            phase margin 55–62°`` (2.5–97.5 % ranges).
        """
        from motorid.numfmt import sig

        def pct(x: float) -> str:
            return f"{100 * x:.1f}".rstrip("0").rstrip(".")

        def span(r: tuple[float, float, float], unit: str) -> str | None:
            lo, _, hi = r
            if not (math.isfinite(lo) or math.isfinite(hi)):
                return None if math.isnan(lo) else f"∞{unit}"
            hi_txt = sig(hi) if math.isfinite(hi) else "∞"
            lo_txt = sig(lo) if math.isfinite(lo) else "∞"
            return f"{lo_txt}{unit}" if lo_txt == hi_txt else f"{lo_txt}–{hi_txt}{unit}"

        head = f"stable for {pct(self.stable_fraction)} % of {self.samples} plausible motors"
        if self.spec_fraction is not None:
            head += f", {pct(self.spec_fraction)} % meet {self.spec.text()}"
            missed = self.nominal_misses()
            if missed:
                head += f" (the model itself: {missed})"
        spans = [(name, span(r, unit)) for name, r, unit in (
            ("overshoot", self.overshoot_pct, " %"), ("settling", self.settling_time_s, " s"),
            ("phase margin", self.phase_margin_deg, "°"), ("gain margin", self.gain_margin_db, " dB"),
            ("Ms", self.ms, ""))]
        body = ", ".join(f"{name} {s}" for name, s in spans if s is not None)
        return head + (f"; {body}" if body and self.stable_fraction > 0 else "")

    def to_json(self) -> dict[str, Any]:
        """The design JSON's ``robust`` object.

        Returns
        -------
        dict
            ``samples``, ``stable_fraction``, ``spec_fraction``, ``spec``, the ranges as
            ``[p2.5, median, p97.5]`` (``null`` for an infinite or missing value), ``parameters``,
            ``seed``, ``method``.
        """
        def finite_or_none(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        def triple(r: tuple[float, float, float]) -> list[float | None]:
            return [finite_or_none(x) for x in r]

        return {"samples": self.samples, "stable_fraction": self.stable_fraction,
                "spec_fraction": self.spec_fraction,
                "spec": {"overshoot_pct": self.spec.overshoot_pct, "settling_time_s": self.spec.settling_time_s},
                "overshoot_pct": triple(self.overshoot_pct), "settling_time_s": triple(self.settling_time_s),
                "phase_margin_deg": triple(self.phase_margin_deg), "gain_margin_db": triple(self.gain_margin_db),
                "ms": triple(self.ms), "parameters": list(self.parameters), "seed": self.seed,
                "method": self.note} | ({"band": {"time_s": list(self.band[0]), "p2_5": list(self.band[1]),
                                                  "median": list(self.band[2]), "p97_5": list(self.band[3])}}
                                        if self.band[0] else {}) | {
            "nominal": {"overshoot_pct": finite_or_none(self.nominal_overshoot_pct),
                        "settling_time_s": finite_or_none(self.nominal_settling_time_s)}}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> RobustCheck:
        """Rebuild from :meth:`to_json` (a ``null`` margin back to infinite, other ``null`` to NaN).

        Parameters
        ----------
        data : Mapping
            The ``robust`` object.

        Returns
        -------
        RobustCheck

        Raises
        ------
        ValueError
            On a malformed entry (the message names it).
        """
        def fraction(key: str, optional: bool = False) -> float | None:
            v = data.get(key)
            if v is None and optional:
                return None
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not 0.0 <= float(v) <= 1.0:
                raise ValueError(f"robust.{key} must be a fraction in [0, 1]")
            return float(v)

        def triple(key: str, missing: float) -> tuple[float, float, float]:
            v = data.get(key)
            if not isinstance(v, list) or len(v) != 3 or not all(
                    x is None or (isinstance(x, (int, float)) and not isinstance(x, bool)) for x in v):
                raise ValueError(f"robust.{key} must be [low, median, high]")
            lo, mid, hi = (missing if x is None else float(x) for x in v)
            return (lo, mid, hi)

        band: tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], tuple[float, ...]] = ((), (), (), ())
        if data.get("band") is not None:
            b = data["band"]
            try:
                cols = [tuple(float(x) for x in b[k]) for k in ("time_s", "p2_5", "median", "p97_5")]
            except (KeyError, TypeError, ValueError):
                raise ValueError("robust.band must hold time_s, p2_5, median and p97_5 lists of numbers") from None
            if len({len(c) for c in cols}) != 1:
                raise ValueError("robust.band's lists must have one length")
            band = (cols[0], cols[1], cols[2], cols[3])
        spec = data.get("spec") or {}
        samples = data.get("samples")
        if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
            raise ValueError("robust.samples must be a positive integer")
        if not isinstance(spec, Mapping):
            raise ValueError("robust.spec must be an object")
        stable = fraction("stable_fraction")
        nominal = data.get("nominal") or {}
        if not isinstance(nominal, Mapping):
            raise ValueError("robust.nominal must be an object")

        def number(key: str) -> float:
            value = nominal.get(key)
            if value is None:
                return math.nan
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"robust.nominal.{key} must be a number or null")
            return float(value)

        return cls(samples, cast(float, stable), fraction("spec_fraction", True),
                   RobustSpec(spec.get("overshoot_pct"), spec.get("settling_time_s")),
                   triple("overshoot_pct", math.nan), triple("settling_time_s", math.nan),
                   triple("phase_margin_deg", math.inf), triple("gain_margin_db", math.inf), triple("ms", math.nan),
                   tuple(str(p) for p in data.get("parameters") or ()), int(data.get("seed") or 0),
                   str(data.get("method") or ""), band, number("overshoot_pct"), number("settling_time_s"))


@dataclass(frozen=True, slots=True)
class _Joint:
    """The model JSON's ``uncertainty.joint``: parameter names, values and covariance."""

    names: tuple[str, ...]
    values: np.ndarray
    cov: np.ndarray
    #: Directions held at the fit's value (said in the check's note), and the directions themselves.
    held: tuple[str, ...] = ()
    directions: tuple[np.ndarray, ...] = ()

    def held_at_edges(self, model: MotorModel) -> _Joint:
        """The joint with each pair of poles held at its double pole when the fit stopped there.

        A pair at its double pole sits at the edge of the output-error fit's real poles: the
        response changes with the square of the poles' split, so the delta method's variance of
        the split is unbounded (±2229 1/s on each pole of the HSLU rig's pair at −14.24) and a
        Gaussian draw along it is no motor the data allow (one pole at microseconds, the other at
        hours: 58 % of such draws made a well-damped design "unstable").  The split is held at
        the fit's value — the Gaussian conditioned on it — while the pair's natural frequency and
        everything else keep their spread.
        """
        u = model.uncertainty
        taus = [i for i, n in enumerate(self.names) if n.startswith("log_tau_")]
        if u is None or not taus or not u.pole_pairs:
            return self
        cov, held, directions = self.cov.copy(), list(self.held), list(self.directions)
        for pair in u.pole_pairs:
            if math.isfinite(pair.damping.stderr) or max(pair.poles) >= len(u.poles):
                continue
            # each pole's time constant among the joint's log time constants (the nearest one)
            cols = []
            for i in pair.poles:
                tau = -1.0 / float(np.real(u.poles[i].value))
                cols.append(min((j for j in taus if j not in cols),
                                key=lambda j: abs(math.log(tau) - float(self.values[j])) if tau > 0 else math.inf))
            d = np.zeros(self.values.size)
            d[cols[0]], d[cols[1]] = 1.0, -1.0
            spread = cov @ d
            v = float(d @ spread)
            if v > 0:
                cov = cov - np.outer(spread, spread) / v
                directions.append(d)
                held.append(f"poles {pair.poles[0] + 1} and {pair.poles[1] + 1} held at their double pole (the "
                            "edge of the fit's real poles: their split has no interval)")
        return replace(self, cov=0.5 * (cov + cov.T), held=tuple(held), directions=tuple(directions))

    @classmethod
    def of(cls, model: MotorModel) -> _Joint | None:
        joint = None if model.uncertainty is None else model.uncertainty.joint
        if joint is None:
            return None
        names, values, cov = joint.parameters, joint.values, joint.covariance
        if not (np.all(np.isfinite(values)) and np.all(np.isfinite(cov))):
            return None
        by_time_constants = "K" in names and any(n.startswith("log_tau_") for n in names)
        if not (by_time_constants or any(n.startswith("den_") for n in names)):
            return None
        return cls(names, values, 0.5 * (cov + cov.T))

    def column(self, theta: np.ndarray, prefix: str) -> np.ndarray:
        """The columns of ``theta`` (shape (S, k)) whose names start with ``prefix``, shape (S, m)."""
        cols = [i for i, n in enumerate(self.names) if n.startswith(prefix)]
        return theta[:, cols]

    # a draw from a wide interval can overflow (a time constant of e^800 s): its realisation is not
    # finite, and _plants drops it with the other draws that are not motors
    @np.errstate(over="ignore", invalid="ignore", divide="ignore")
    def plants(self, model: MotorModel, theta: np.ndarray) -> tuple[Any, np.ndarray]:
        """The motors the rows of ``theta`` describe, realised as the fit realises its model.

        Returns the stacked :class:`~motorid.model.motor.TfRealisation` and each motor's dead time.
        """
        from motorid.model.motor import realise_tfs_stacked

        s = theta.shape[0]
        idx = {n: i for i, n in enumerate(self.names)}
        delay = (np.maximum(theta[:, idx["delay"]], 0.0) if "delay" in idx
                 else np.full(s, float(model.delay_s)))
        if any(n.startswith("den_") for n in self.names):
            # the Markov polish's coefficients (lowest powers first): the monic denominator, the numerator
            d = self.column(theta, "den_")[:, ::-1]
            b = self.column(theta, "num_")[:, ::-1]
            den_c = np.concatenate([np.ones((s, 1)), d], axis=1)
            num_c = np.concatenate([np.zeros((s, den_c.shape[1] - b.shape[1])), b], axis=1)
            pos: Any = 1.0 if "position" in model.outputs else None
            return realise_tfs_stacked(num_c, den_c, current_num=None, position_scale=pos), delay
        taus = np.exp(self.column(theta, "log_tau_"))
        n = taus.shape[1]
        den = np.ones((s, 1))
        for i in range(n):  # Π(s + 1/τ_i): the fit's Π(τ_i s + 1) over its leading coefficient
            den = _convolve_rows(den, np.stack([np.ones(s), 1.0 / taus[:, i]], axis=1))
        lead = np.prod(taus, axis=1)
        num = (theta[:, idx["K"]] / lead)[:, None]
        for z in self.column(theta, "Tz_").T:
            num = _convolve_rows(num, np.stack([z, np.ones(s)], axis=1))
        num = np.concatenate([np.zeros((s, n + 1 - num.shape[1])), num], axis=1)
        cur = self.column(theta, "cur_")
        current = None
        if cur.shape[1] and "current" in model.outputs:
            current = np.concatenate([np.zeros((s, n + 1 - cur.shape[1])), cur / lead[:, None]], axis=1)
        scale: Any = theta[:, idx["c"]] if "c" in idx else (1.0 if "position" in model.outputs else None)
        return realise_tfs_stacked(num, den, current_num=current, position_scale=scale), delay


def _convolve_rows(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Row-wise polynomial products of two stacks of coefficient rows."""
    out = np.zeros((p.shape[0], p.shape[1] + q.shape[1] - 1))
    for j in range(q.shape[1]):
        out[:, j:j + p.shape[1]] += p * q[:, j:j + 1]
    return out


def _matches(model: MotorModel, a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray,
             outputs: tuple[str, ...], delay: float) -> bool:
    """Whether the motor rebuilt from the joint values is ``model`` (same velocity TF and dead time)."""
    import scipy.signal

    if tuple(outputs) != tuple(model.outputs) or a.shape != model.A.shape:
        return False
    i = list(outputs).index("velocity")
    n1, d1 = scipy.signal.ss2tf(model.A, model.B, model.C[i:i + 1], model.D[i:i + 1])
    n2, d2 = scipy.signal.ss2tf(a, b, c[i:i + 1], d[i:i + 1])
    scale = max(float(np.max(np.abs(n1))), 1e-300)
    return bool(np.allclose(d1, d2, rtol=MATCH_RTOL, atol=0.0)
                and np.allclose(n1, n2, rtol=MATCH_RTOL, atol=MATCH_RTOL * scale)
                and abs(model.delay_s - delay) <= MATCH_RTOL * max(model.delay_s, 1e-9))


def _draws(joint: _Joint, samples: int, rng: np.random.Generator) -> np.ndarray:
    """Parameter vectors from the joint Gaussian, inside its 95 % region."""
    import scipy.stats  # scipy.stats costs a command's start-up: only when motors are drawn

    k = joint.values.size
    w, v = np.linalg.eigh(joint.cov)
    root = v * np.sqrt(np.clip(w, 0.0, None))
    limit = scipy.stats.chi2.ppf(REGION, k - len(joint.held))  # a held direction has no spread
    out: list[np.ndarray] = []
    while sum(len(o) for o in out) < samples:
        z = rng.standard_normal((2 * samples, k))
        z = z[np.sum(z * z, axis=1) <= limit]
        out.append(joint.values + z @ root.T)
    theta = np.vstack(out)[:samples]
    for d in joint.directions:  # what rounding left along a held direction (1e-5 of a variance of 2e4)
        theta -= np.outer((theta - joint.values) @ d, d) / float(d @ d)
    return theta


@dataclass(frozen=True, slots=True)
class _Plants:
    """Stacked motors in their own coordinates, with the design's gain row on those coordinates."""

    a: np.ndarray  # (S, n, n)
    b: np.ndarray  # (S, n, 1)
    c: np.ndarray  # (S, 1, n): the measured output y
    k: np.ndarray  # (S, 1, n)
    delay: np.ndarray  # (S,)
    t: np.ndarray  # (S, n, n): the design's coordinates from each motor's own states


def _pade_unit() -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """State space of the Padé approximant of a 1 s dead time; ``τ`` s is ``(A/τ, B/τ, C, D)``."""
    import control

    p = control.ss(control.tf(*control.pade(1.0, PADE_ORDER)))
    return np.asarray(p.A, float), np.asarray(p.B, float), np.asarray(p.C, float), float(np.asarray(p.D)[0, 0])


def _loop_parts(pl: _Plants, nominal: tuple[np.ndarray, np.ndarray, np.ndarray], design: Design
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, float, np.ndarray]:
    """The designed controller around each motor, the loop open at the motor's input.

    Returns stacked ``A`` (motor and controller states, the motor driven by ``v``), ``B`` (``v``'s
    column), ``f`` (the command ``u = f·state + f_r·r``), ``f_r`` and ``R`` (where ``r`` enters
    the controller's states besides through ``u``).  States ``[x, controller…, z]``: the motor; the
    full observer's estimate ``x̂`` or the reduced observer's ``w`` (built on the nominal model,
    fed the command and what the sensors read); the integrator ``ż = y − r``.
    """
    m, n = pl.a.shape[0], pl.a.shape[1]
    a0, b0, c0 = nominal
    n0 = a0.shape[0]
    ki = design.ki
    red = design.reduced
    n_ctrl = red.F.shape[0] if red is not None else (n0 if design.L is not None else 0)
    size = n + n_ctrl + (1 if ki is not None else 0)
    ctrl = slice(n, n + n_ctrl)
    f = np.zeros((m, 1, size))
    big_a = np.zeros((m, size, size))
    big_a[:, :n, :n] = pl.a
    r_col = np.zeros((m, size, 1))
    f_ref = 0.0 if ki is not None else float(design.kr if design.kr is not None else 1.0)
    if ki is not None:
        f[:, 0, -1] = -float(ki)
        big_a[:, -1, :n] = pl.c[:, 0, :]
        r_col[:, -1, 0] = -1.0
    if red is not None:
        from motorid.control.reduced_observer import command_rows

        mi, _ = red.split(tuple(design.states))
        sel = pl.t[:, mi, :]  # what the sensors read, on each motor's own states
        kz, kw, _ = command_rows(design.K, ki, red, tuple(design.states))
        f[:, :, :n] = kz @ sel
        f[:, :, ctrl] = kw
        big_a[:, ctrl, :] += red.H @ f
        big_a[:, ctrl, :n] += red.G @ sel
        big_a[:, ctrl, ctrl] += red.F
        r_col[:, ctrl, 0] += red.H[:, 0] * f_ref
    elif design.L is not None:
        lcol = np.asarray(design.L, float).reshape(n0, 1)
        f[:, :, ctrl] = -design.K.reshape(1, n0)
        big_a[:, ctrl, :] += b0 @ f
        big_a[:, ctrl, ctrl] += a0 - lcol @ c0
        big_a[:, ctrl, :n] += lcol @ pl.c
        r_col[:, ctrl, 0] += b0[:, 0] * f_ref
    else:
        f[:, :, :n] = -pl.k
    big_b = np.zeros((m, size, 1))
    big_b[:, :n] = pl.b
    return big_a, big_b, f, f_ref, r_col


def _closed_loop(pl: _Plants, nominal: tuple[np.ndarray, np.ndarray, np.ndarray], design: Design,
                 fastest: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stacked ``(A, B, C)`` of reference → measured output with the designed controller on each motor.

    The loop of :func:`_loop_parts` closed, the dead time's Padé states between the command and
    the motor.
    """
    a_l, b_l, f, f_ref, r_col = _loop_parts(pl, nominal, design)
    m, size = a_l.shape[0], a_l.shape[1]
    use_pade = bool(np.any(pl.delay * fastest > 1e-6))
    if use_pade:
        p_a, p_b, p_c, p_d = _pade_unit()
        q = p_a.shape[0]
        tau = np.maximum(pl.delay, 1e-6 / fastest)[:, None, None]
        fq = np.concatenate([f, np.zeros((m, 1, q))], axis=2)
        big_a = np.zeros((m, size + q, size + q))
        big_a[:, :size, :size] = a_l
        # v = C_p w + D_p u drives the motor; ẇ = (A_p w + B_p u)/τ
        big_a[:, :size, :] += b_l @ (p_d * fq)
        big_a[:, :size, size:] += b_l @ p_c[None]
        big_a[:, size:, :] += (p_b[None] / tau) @ fq
        big_a[:, size:, size:] += p_a[None] / tau
        big_b = np.concatenate([r_col + b_l * (p_d * f_ref), p_b[None] / tau * f_ref], axis=1)
    else:
        big_a = a_l + b_l @ f
        big_b = r_col + b_l * f_ref
    big_c = np.zeros((m, 1, big_a.shape[1]))
    big_c[:, :, :pl.a.shape[1]] = pl.c
    return big_a, big_b, big_c


def _loop(pl: _Plants, nominal: tuple[np.ndarray, np.ndarray, np.ndarray], design: Design
          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Stacked ``(A, B, C)`` of the loop broken at the motor's input, without the dead time: ``L = −u/v``."""
    a_l, b_l, f, _, _ = _loop_parts(pl, nominal, design)
    return a_l, b_l, -f


def _percentiles(x: np.ndarray) -> tuple[float, float, float]:
    """2.5 %, 50 % and 97.5 % points (nearest rank: an infinite margin stays infinite)."""
    x = x[~np.isnan(x)]
    if x.size == 0:
        return (math.nan, math.nan, math.nan)
    lo, mid, hi = np.percentile(x, [2.5, 50.0, 97.5], method="nearest")
    return (float(lo), float(mid), float(hi))


def _steps(a: np.ndarray, b: np.ndarray, c: np.ndarray, horizon: float) -> tuple[np.ndarray, np.ndarray]:
    """Unit reference steps of stacked closed loops, exact at the grid's instants."""
    m, size = a.shape[0], a.shape[1]
    dt = horizon / (STEP_POINTS - 1)
    # a draw far out in a wide interval can give a loop whose exponential overflows: its response
    # is not finite, and it is NaN (unknown) rather than a number such as a 1e19 % overshoot
    with np.errstate(over="ignore", invalid="ignore"):
        # Φ and Γ of the zero-order hold (exact for a step), every loop of the stack in one call
        phi, gammas = zoh(a, b, dt)
        gamma = gammas[:, :, 0]
        x = np.zeros((m, size))
        y = np.zeros((m, STEP_POINTS))
        for i in range(1, STEP_POINTS):
            x = np.einsum("mij,mj->mi", phi, x) + gamma
            y[:, i] = np.einsum("mj,mj->m", c[:, 0, :], x)
    y[~np.all(np.isfinite(y), axis=1)] = np.nan
    return np.linspace(0.0, horizon, STEP_POINTS), y


def _step_metrics(t: np.ndarray, y: np.ndarray, final: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Percent overshoot and 2 % settling time of each row (against its own final value; NaN: not settled)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        sign = np.sign(final)[:, None]
        over = 100.0 * np.maximum((np.max(y * sign, axis=1) - np.abs(final)) / np.abs(final), 0.0)
        outside = np.abs(y - final[:, None]) > 0.02 * np.abs(final)[:, None]
    any_out = outside.any(axis=1)
    last = t.size - 1 - np.argmax(outside[:, ::-1], axis=1)
    settle = np.where(last >= t.size - 1, np.nan, t[np.minimum(last + 1, t.size - 1)])
    return over, np.where(any_out, settle, 0.0)


def _margins(a: np.ndarray, b: np.ndarray, c: np.ndarray, delays: np.ndarray, omega: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Phase margin (°), gain margin (dB) and sensitivity peak of stacked loops from ``L(jω)`` on a grid.

    As python-control's ``stability_margins(method="frd")`` reads them: of several crossings, the
    phase margin smallest in size and the gain margin closest to 0 dB, each interpolated between
    grid points.
    """
    m, size = a.shape[0], a.shape[1]
    resp = np.empty((m, omega.size), dtype=complex)
    eye = np.eye(size)
    # frequencies in blocks: one stacked solve per block, about 20 000 small systems each
    block = max(1, 20_000 // max(m, 1))
    with np.errstate(all="ignore"):
        for j0 in range(0, omega.size, block):
            w = omega[j0:j0 + block]
            mats = (1j * w)[None, :, None, None] * eye - a[:, None]
            x = np.linalg.solve(mats, np.broadcast_to(b[:, None], (m, w.size, size, 1)))
            resp[:, j0:j0 + w.size] = (c[:, None] @ x)[..., 0, 0]
        resp *= np.exp(-1j * omega[None, :] * delays[:, None])
        mag_db = 20 * np.log10(np.abs(resp))
        phase = np.unwrap(np.angle(resp), axis=1)
        # |S(j∞)| = 1 (the loop has no direct term): the peak is at least 1 beyond the grid's end
        ms = np.maximum(np.nanmax(1.0 / np.abs(1.0 + resp), axis=1), 1.0)
    # gain crossovers: grid intervals where |L| passes through 1; python-control's choice, the one
    # with the smallest |phase margin|
    cross = (mag_db[:, :-1] >= 0) != (mag_db[:, 1:] >= 0)
    with np.errstate(all="ignore"):
        frac = mag_db[:, :-1] / (mag_db[:, :-1] - mag_db[:, 1:])
        ph = phase[:, :-1] + frac * (phase[:, 1:] - phase[:, :-1])
        margin = np.degrees(ph) % 360.0 - 180.0
    margin = np.where(cross & np.isfinite(margin), margin, math.inf)
    pm = np.take_along_axis(margin, np.argmin(np.abs(margin), axis=1)[:, None], axis=1)[:, 0]
    # phase crossovers: where the phase passes −180° + k·360°; python-control's choice, the gain
    # margin closest to 0 dB
    turns = np.floor((phase + math.pi) / (2 * math.pi))
    hit = turns[:, :-1] != turns[:, 1:]
    target = np.maximum(turns[:, :-1], turns[:, 1:]) * 2 * math.pi - math.pi
    with np.errstate(all="ignore"):
        frac = (target - phase[:, :-1]) / (phase[:, 1:] - phase[:, :-1])
        g = -(mag_db[:, :-1] + frac * (mag_db[:, 1:] - mag_db[:, :-1]))
    g = np.where(hit & np.isfinite(g), g, math.inf)
    gm = np.take_along_axis(g, np.argmin(np.abs(g), axis=1)[:, None], axis=1)[:, 0]
    return pm, gm, ms


class RobustCheckUnavailable(Exception):  # noqa: N818 (a reason, not a failure)
    """Why a design cannot be checked over the model's uncertainty (one sentence)."""


def robust_check(model: MotorModel, design: Design, *, samples: int = DEFAULT_SAMPLES,
                 spec: RobustSpec = RobustSpec(), seed: int = 0) -> RobustCheck:
    """Check ``design`` on ``samples`` motors drawn from ``model``'s joint 95 % region.

    Parameters
    ----------
    model : MotorModel
        The model the design was made for; it must carry ``uncertainty.joint`` (an
        output-error fit's model: ``auto`` or ``oe``).
    design : Design
        Its controller.
    samples : int
        Motors to draw (at least 10).
    spec : RobustSpec
        Overshoot and settling time each motor's loop should meet (besides stability).
    seed : int
        Seed of the random generator.

    Returns
    -------
    RobustCheck

    Raises
    ------
    RobustCheckUnavailable
        When the model carries no joint covariance (a paper method's model), or one that is
        not its own (the model was changed after the fit), or the design's coordinates are not
        the sensors'.
    """
    joint = _Joint.of(model)
    if joint is None:
        raise RobustCheckUnavailable("the model carries no joint covariance of its parameters (a paper method's "
                                     f"model, here {model.method}, or one written by an older motorid); "
                                     "identify with method auto or oe")
    joint = joint.held_at_edges(model)
    built = _plants(model, design, joint, _draws(joint, max(int(samples), 10), np.random.default_rng(seed)))
    if built is None:
        raise RobustCheckUnavailable("the model's covariance is not its own (the model was changed after the fit) "
                                     "or the design's states are not its sensors")
    plants, nominal = built
    check = _summary(_per_motor(plants, nominal, design), spec, joint.names, seed, joint.held)
    own = _plants(model, design, joint, joint.values[None])
    if own is None or own[0].a.shape[0] != 1:
        return check
    itself = _per_motor(own[0], own[1], design)
    return replace(check, nominal_overshoot_pct=float(itself["overshoot_pct"][0]),
                   nominal_settling_time_s=float(itself["settling_time_s"][0]))


def _plants(model: MotorModel, design: Design, joint: _Joint, theta: np.ndarray
            ) -> tuple[_Plants, tuple[np.ndarray, np.ndarray, np.ndarray]] | None:
    """The motors of the rows of ``theta`` (the design's gains on their own states) and the nominal ``(A, B, C)``.

    The nominal model is in the design's coordinates; None when the covariance is not the
    model's own or the design's coordinates are not the sensors'.
    """
    from motorid.control.coordinates import sensor_transform
    from motorid.control.design import design_model, output_row

    nominal_r, nominal_delay = joint.plants(model, joint.values[None])
    if not _matches(model, nominal_r.A[0], nominal_r.B[0], nominal_r.C[0], nominal_r.D[0], nominal_r.outputs,
                    float(nominal_delay[0])):
        return None
    work = design_model(model, design)
    n0 = work.A.shape[0]
    nominal = (np.asarray(work.A, float), np.asarray(work.B, float).reshape(-1, 1),
               np.asarray(output_row(work, design.output)[1], float).reshape(1, -1))
    r, delays = joint.plants(model, theta)
    if design.output not in r.outputs or r.A.shape[1] != n0:
        return None
    own = design.transform is None and tuple(design.states) == tuple(model.states)
    t = (np.broadcast_to(np.eye(n0), (theta.shape[0], n0, n0)) if own
         else sensor_transform(r.A, r.C, r.outputs, tuple(design.states)))
    if t is None:
        return None
    k = design.K.reshape(1, 1, n0) @ t
    y = r.C[:, [list(r.outputs).index(design.output)], :]
    ok = np.all(np.isfinite(r.A), axis=(1, 2)) & np.all(np.isfinite(k), axis=(1, 2))
    return _Plants(r.A[ok], r.B[ok], y[ok], k[ok], delays[ok], t[ok]), nominal


def _per_motor(pl: _Plants, nominal: tuple[np.ndarray, np.ndarray, np.ndarray], design: Design
               ) -> dict[str, np.ndarray]:
    """Stability, step overshoot and settling time, margins and Ms of the designed loop on each motor."""
    count = pl.a.shape[0]
    n0 = nominal[0].shape[0]
    nominal_pl = _Plants(nominal[0][None], nominal[1][None], nominal[2][None], design.K.reshape(1, 1, -1),
                         np.zeros(1), np.eye(n0)[None])
    eig0 = np.linalg.eigvals(_closed_loop(nominal_pl, nominal, design, 1.0)[0][0])
    fastest = max(float(np.max(np.abs(eig0))), 1.0)
    slowest = float(np.min(np.abs(eig0.real)))
    horizon = 12.0 / max(slowest, 1e-3) + 4.0 * float(np.max(pl.delay, initial=0.0))
    a, b, c = _closed_loop(pl, nominal, design, fastest)
    with np.errstate(all="ignore"):
        eig = np.linalg.eigvals(a)
    stable = np.all(eig.real < 0, axis=1)
    over = np.full(count, np.nan)
    settle = np.full(count, np.nan)
    band = np.zeros((4, 0))
    if stable.any():
        t, y = _steps(a[stable], b[stable], c[stable], horizon)
        finals = -(c[stable] @ np.linalg.solve(a[stable], b[stable]))[:, 0, 0]
        o, st = _step_metrics(t, y, finals)
        known = np.all(np.isfinite(y), axis=1)  # (a response that overflowed has no overshoot or settling)
        over[stable], settle[stable] = np.where(known, o, np.nan), np.where(known, st, np.nan)
        pick = np.linspace(0, t.size - 1, BAND_POINTS).round().astype(int)
        if known.any():
            band = np.vstack([t[pick], np.percentile(y[known][:, pick], [2.5, 50.0, 97.5], axis=0)])
    la, lb, lc = _loop(pl, nominal, design)
    # the grid around the nominal loop's crossover (where every plausible motor's is): four and
    # a half decades; the nominal's fastest pole's seven decades without a crossover
    wc = float(getattr(design.margins, "crossover_rad_s", math.nan))
    centre = math.log10(wc) if math.isfinite(wc) and wc > 0 else math.log10(fastest) - 1.5
    span = 2.25 if math.isfinite(wc) and wc > 0 else 3.5
    omega = np.logspace(centre - span, centre + span, MARGIN_POINTS)
    pm, gm, ms = (np.where(stable, v, np.nan) for v in _margins(la, lb, lc, pl.delay, omega))
    return {"stable": stable, "overshoot_pct": over, "settling_time_s": settle, "phase_margin_deg": pm,
            "gain_margin_db": gm, "ms": ms, "band": band}


def _summary(per: dict[str, np.ndarray], spec: RobustSpec, names: tuple[str, ...], seed: int,
             held: tuple[str, ...] = ()) -> RobustCheck:
    """The fractions and ranges over the motors."""
    stable = per["stable"]
    band = per["band"]
    count = stable.size
    meets = stable.copy()
    if spec.overshoot_pct is not None:
        meets &= np.nan_to_num(per["overshoot_pct"], nan=np.inf) <= spec.overshoot_pct
    if spec.settling_time_s is not None:
        meets &= np.nan_to_num(per["settling_time_s"], nan=np.inf) <= spec.settling_time_s
    note = (f"{count} motors drawn from the fit's joint Gaussian inside its {REGION:.0%} region "
            f"(parameters {', '.join(names)}{''.join('; ' + h for h in held)}); the designed controller (its "
            "observer on the nominal model) "
            f"on each; the dead time as a Padé approximant of order {PADE_ORDER} in the eigenvalues and steps, "
            "exact in the margins")
    return RobustCheck(count, float(np.mean(stable)), float(np.mean(meets)) if spec.given else None, spec,
                       overshoot_pct=_percentiles(per["overshoot_pct"]),
                       settling_time_s=_percentiles(per["settling_time_s"]),
                       phase_margin_deg=_percentiles(per["phase_margin_deg"]),
                       gain_margin_db=_percentiles(per["gain_margin_db"]), ms=_percentiles(per["ms"]),
                       parameters=names, seed=seed, note=note,
                       band=(tuple(map(float, band[0])), tuple(map(float, band[1])), tuple(map(float, band[2])),
                             tuple(map(float, band[3]))))

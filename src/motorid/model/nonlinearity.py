"""The static input nonlinearity of a Hammerstein motor model: dead-zone and saturation.

A DC servo's steady speed is an affine function of the input above a threshold: static
friction and the amplifier's offset swallow the first ``u₀`` volts (a dead-zone referred to
the input; Coulomb friction acts the same way in steady state, ``T_c·R_a/(k·A)`` volts), and
the amplifier's rails cap the armature voltage.  The Hammerstein model puts that law in front
of the identified linear dynamics: ``y = G(s)·f(u)`` with ``f(u) = u − u₀`` above ``u₀``,
``u + u₀⁻`` below ``−u₀⁻``, 0 between, and ``f`` clipped at the saturation level.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from motorid.errors import ModelFormatError

__all__ = ["StaticNonlinearity"]


def _interval(value: Any, what: str) -> tuple[float, float] | None:
    if value is None:
        return None
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ModelFormatError(f"static_nonlinearity.{what}.ci95 must be two numbers") from None
    return lo, hi


@dataclass(frozen=True, slots=True)
class StaticNonlinearity:
    """Dead-zone and saturation in front of the linear model (volts at the model's input).

    Attributes
    ----------
    dead_zone_v : float
        Input below which the motor does not move, for positive inputs (``u₀``, ≥ 0).
    dead_zone_ci95 : tuple of float or None
        Its 95 % interval.
    dead_zone_negative_v : float or None
        ``u₀⁻`` for negative inputs when negative steps were measured; ``None``: the law is
        taken as symmetric (``u₀⁻ = u₀``).
    gain : float
        Slope of the static characteristic (output volts per input volt above the dead-zone);
        the linear model's DC gain.
    gain_ci95 : tuple of float or None
        Its 95 % interval.
    saturation_input_v : float or None
        Input level above which the output stops growing (rails seen in the data), or ``None``.
    saturation_output_v : float or None
        The output level reached there.
    levels : tuple of Mapping
        One entry per measured level: ``step_volts``, ``steady_state``, ``stderr``, ``status``
        (``moving``, ``still``, ``saturated``), ``source``.
    """

    dead_zone_v: float
    gain: float
    dead_zone_ci95: tuple[float, float] | None = None
    dead_zone_negative_v: float | None = None
    gain_ci95: tuple[float, float] | None = None
    saturation_input_v: float | None = None
    saturation_output_v: float | None = None
    levels: tuple[Mapping[str, Any], ...] = field(default=())

    def __post_init__(self) -> None:
        if not (math.isfinite(self.dead_zone_v) and self.dead_zone_v >= 0):
            raise ModelFormatError(f"static_nonlinearity: the dead-zone must be a number >= 0, got {self.dead_zone_v}")
        if not math.isfinite(self.gain):
            raise ModelFormatError("static_nonlinearity: the gain must be a finite number")
        if self.dead_zone_negative_v is not None and not self.dead_zone_negative_v >= 0:
            raise ModelFormatError("static_nonlinearity: the negative dead-zone must be >= 0")
        if self.saturation_input_v is not None and not self.saturation_input_v > self.dead_zone_v:
            raise ModelFormatError("static_nonlinearity: the saturation input must lie above the dead-zone")

    @property
    def negative_dead_zone_v(self) -> float:
        """``u₀⁻``: the measured negative threshold, or ``u₀`` for a symmetric law."""
        return self.dead_zone_v if self.dead_zone_negative_v is None else self.dead_zone_negative_v

    def effective_input(self, u: Any) -> np.ndarray:
        """The input the linear part sees: ``f(u)`` (dead-zone removed, clipped at saturation).

        Parameters
        ----------
        u : array_like or float
            Input volts.

        Returns
        -------
        ndarray
            ``f(u)``, same shape as ``u``.
        """
        u = np.asarray(u, dtype=float)
        out = np.where(u > self.dead_zone_v, u - self.dead_zone_v,
                       np.where(u < -self.negative_dead_zone_v, u + self.negative_dead_zone_v, 0.0))
        if self.saturation_input_v is not None:
            top = self.saturation_input_v - self.dead_zone_v
            out = np.clip(out, -top, top)
        return out

    def compensate(self, u: Any, *, threshold_v: float = 1e-3) -> np.ndarray:
        """Inverse dead-zone feed-forward: the command whose ``f`` is ``u``.

        ``u + u₀`` for ``u > threshold``, ``u − u₀⁻`` for ``u < −threshold``, 0 between (a
        command that is essentially zero is not kicked to the edge of the dead-zone, which
        would make the loop chatter around its set point).

        Parameters
        ----------
        u : array_like or float
            The command a linear controller asks for.
        threshold_v : float
            Commands smaller than this are left at 0.

        Returns
        -------
        ndarray
            The compensated command.
        """
        u = np.asarray(u, dtype=float)
        return np.where(u > threshold_v, u + self.dead_zone_v,
                        np.where(u < -threshold_v, u - self.negative_dead_zone_v, 0.0))

    def to_json(self) -> dict[str, Any]:
        """The model JSON's ``static_nonlinearity`` object.

        Returns
        -------
        dict
            ``dead_zone`` {``value``, ``ci95``, ``negative``}, ``gain`` {``value``, ``ci95``},
            ``saturation`` ({``input_v``, ``output_v``} or ``None``), ``levels``.
        """
        sat = None
        if self.saturation_input_v is not None:
            sat = {"input_v": self.saturation_input_v, "output_v": self.saturation_output_v}
        return {
            "dead_zone": {"value": self.dead_zone_v,
                          "ci95": None if self.dead_zone_ci95 is None else list(self.dead_zone_ci95),
                          "negative": self.dead_zone_negative_v},
            "gain": {"value": self.gain, "ci95": None if self.gain_ci95 is None else list(self.gain_ci95)},
            "saturation": sat,
            "levels": [dict(level) for level in self.levels],
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> StaticNonlinearity:
        """Rebuild from :meth:`to_json` output.

        Parameters
        ----------
        data : Mapping
            The ``static_nonlinearity`` object.

        Returns
        -------
        StaticNonlinearity

        Raises
        ------
        ModelFormatError
            On missing or malformed entries.
        """
        if not isinstance(data, Mapping):
            raise ModelFormatError("static_nonlinearity must be an object")
        try:
            dz = data["dead_zone"]
            gain = data["gain"]
            sat = data.get("saturation") or None
            return cls(
                dead_zone_v=float(dz["value"]),
                dead_zone_ci95=_interval(dz.get("ci95"), "dead_zone"),
                dead_zone_negative_v=None if dz.get("negative") is None else float(dz["negative"]),
                gain=float(gain["value"]),
                gain_ci95=_interval(gain.get("ci95"), "gain"),
                saturation_input_v=None if sat is None else float(sat["input_v"]),
                saturation_output_v=None if sat is None or sat.get("output_v") is None else float(sat["output_v"]),
                levels=tuple(dict(level) for level in data.get("levels") or ()),
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelFormatError(f"static_nonlinearity: bad or missing entry ({exc!s})") from None

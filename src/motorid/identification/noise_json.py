"""What the output-error fit assumed about each channel's noise, as the model carries it.

:class:`~motorid.identification.stages.NoiseModel` (the fit's own object, with its whitening
polynomials) writes the model JSON's ``extras.noise`` through :class:`ChannelNoise`, and every
reader (the printout, the report, the truth checks) reads it back through :func:`noise_of`: one
writer and one reader of that object.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

__all__ = ["SCALE_ONLY", "ChannelNoise", "noise_of"]

#: ``use`` of a channel fitted for its scale only (undithered 8-bit codes), not for the dynamics.
SCALE_ONLY = "scale only"


@dataclass(frozen=True, slots=True)
class ChannelNoise:
    """One channel's noise model.

    Attributes
    ----------
    sigma : float
        Innovation standard deviation of the whitened post-step residuals (the data's unit).
    ar_order : int
        Order of its AR whitening model (0: white).
    pre_step_sigma : float or None
        Standard deviation of the samples before the step (motor at rest).
    use : str
        ``dynamics``, or :data:`SCALE_ONLY` (its codes are not dithered by noise).
    """

    sigma: float
    ar_order: int
    pre_step_sigma: float | None
    use: str

    @property
    def scale_only(self) -> bool:
        """Whether the channel was fitted for its scale only."""
        return self.use == SCALE_ONLY

    def to_json(self) -> dict[str, Any]:
        """The ``extras.noise`` entry of this channel.

        Returns
        -------
        dict
        """
        return {"sigma": self.sigma, "ar_order": self.ar_order, "pre_step_sigma": self.pre_step_sigma,
                "use": self.use}

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> ChannelNoise:
        """Read an ``extras.noise`` entry (a missing number reads as NaN, a missing order as 0).

        Parameters
        ----------
        data : Mapping
            The JSON object.

        Returns
        -------
        ChannelNoise
        """
        sigma = data.get("sigma")
        pre = data.get("pre_step_sigma")
        return cls(float("nan") if sigma is None else float(sigma), int(data.get("ar_order") or 0),
                   None if pre is None else float(pre), str(data.get("use") or "dynamics"))


def noise_of(model: Any) -> dict[str, ChannelNoise]:
    """A model's noise model per channel (empty when its method has none).

    Parameters
    ----------
    model : MotorModel
        Any model; its ``extras["noise"]`` is read.

    Returns
    -------
    dict of str to ChannelNoise
    """
    raw = (getattr(model, "extras", None) or {}).get("noise")
    if not isinstance(raw, Mapping):
        return {}
    return {str(role): ChannelNoise.from_json(nm) for role, nm in raw.items() if isinstance(nm, Mapping)}

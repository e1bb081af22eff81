"""One stage of an identification, typed (the model JSON's ``stages`` entries).

It lives with the model because a :class:`~motorid.model.motor.MotorModel` carries the stages
that produced it.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from motorid.model.jsonview import JsonView

__all__ = ["Stage"]


#: Keys of a stage's JSON object that :class:`Stage` holds as typed fields, in JSON order.
_STAGE_FIELDS = (("method", "method"), ("order", "order"), ("dc_gain", "dc_gain"),
                 ("time_constant", "time_constant_s"), ("velocity_nrmse", "velocity_nrmse"),
                 ("failed", "failed"))


@dataclass(frozen=True, slots=True)
class Stage(JsonView):
    """What one stage of ``--method auto`` found (the model JSON's ``stages`` entries).

    Typed fields for what every stage may report, ``details`` for what one kind of stage
    adds (the output-error stage's structure table, the order cross-check's orders).  It is
    also a read-only mapping with the JSON keys (``stage["dc_gain"]``), so readers of the
    JSON and of the object use one vocabulary; :meth:`to_dict` gives the JSON object with
    the keys in the order they had before the type existed.

    Attributes
    ----------
    name : str
        ``paper method``, ``output-error``, ``order cross-check``, ``srivc``, ...
    method : str or None
    order : int or None
        States of the stage's model.
    dc_gain, time_constant_s, velocity_nrmse : float or None
        The stage model's first-order gain and time constant, and its fit.
    failed : str or None
        Why the stage gave no model.
    details : Mapping
        Other entries, in their JSON order.
    """

    name: str
    method: str | None = None
    order: int | None = None
    dc_gain: float | None = None
    time_constant_s: float | None = None
    velocity_nrmse: float | None = None
    failed: str | None = None
    details: Mapping[str, Any] = field(default_factory=dict)
    keys_order: tuple[str, ...] = ()

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Stage:
        """Build from a JSON stage object (keys it does not type go to ``details``).

        Parameters
        ----------
        data : Mapping
            ``{"stage": name, ...}``.

        Returns
        -------
        Stage
        """
        typed = {attr: data[key] for key, attr in _STAGE_FIELDS if key in data}
        details = {k: v for k, v in data.items() if k != "stage" and k not in dict(_STAGE_FIELDS)}
        return cls(name=str(data.get("stage", "")), details=details, keys_order=tuple(data), **typed)

    def to_dict(self) -> dict[str, Any]:
        """The JSON object, keys in their original order.

        Returns
        -------
        dict
        """
        values: dict[str, Any] = {"stage": self.name}
        for key, attr in _STAGE_FIELDS:
            v = getattr(self, attr)
            if v is not None or key in self.keys_order:
                values[key] = v
        values.update(self.details)
        order = [k for k in self.keys_order if k in values] + [k for k in values if k not in self.keys_order]
        return {k: values[k] for k in order}

"""A typed object that also reads as its JSON object (a read-only mapping with the JSON's keys)."""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from typing import Any

__all__ = ["JsonView"]


class JsonView(Mapping[str, Any]):
    """Base of the model's typed parts whose JSON object callers may still index by key.

    A subclass gives :meth:`to_dict`; ``obj[key]``, iteration and ``len`` read that dict, so
    readers of the JSON and of the object use one vocabulary.
    """

    __slots__ = ()

    def to_dict(self) -> dict[str, Any]:
        """The JSON object."""
        raise NotImplementedError

    def __getitem__(self, key: str) -> Any:
        return self.to_dict()[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self.to_dict())

    def __len__(self) -> int:
        return len(self.to_dict())

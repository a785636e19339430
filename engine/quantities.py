"""Units of parameter fields, as ``typing.Annotated`` aliases.

A parameter dataclass declares ``voxel: Metres = 0.02``; :mod:`engine.params` reads the unit
back (``typing.get_type_hints(cls, include_extras=True)``) to print and document the
defaults. Every value is in SI units: metres, square metres, radians, seconds.
"""
from __future__ import annotations

from typing import Annotated, Optional

__all__ = ["Metres", "SquareMetres", "Radians", "Count", "Ratio", "Percent", "Factor", "Flag", "OptionalMetres",
           "unit_of"]

Metres = Annotated[float, "m"]
SquareMetres = Annotated[float, "m²"]
Radians = Annotated[float, "rad"]
Count = Annotated[int, "count"]
Ratio = Annotated[float, "share 0–1"]
Percent = Annotated[float, "percent"]
Factor = Annotated[float, "factor"]
Flag = Annotated[bool, "on/off"]
OptionalMetres = Annotated[Optional[float], "m, or auto (from the data)"]


def unit_of(hint) -> str:
    """The unit text of an annotated type hint, "" when it has none."""
    meta = getattr(hint, "__metadata__", ())
    return str(meta[0]) if meta else ""

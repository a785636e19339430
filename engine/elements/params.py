"""Parameters of the building-elements stage (SI units: metres, radians)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..quantities import Flag, Metres, Radians, Ratio
from .openings import OpeningParams

__all__ = ["WallRunParams", "SlabParams", "ElementsParams"]


@dataclass(frozen=True)
class WallRunParams:
    """How wall runs are found between the spaces' footprints."""

    max_thickness: Metres = 0.7
    """Two room faces facing each other at most this far apart have a wall between them
    (a party wall of 0.6 m is a wall), metres."""
    max_solid_thickness: Metres = 1.2
    """With a scan: room faces farther apart than ``max_thickness`` but at most this far have
    a wall between them (a party wall, a shaft) when the scan holds no points inside the gap
    away from its faces (it is solid, not a space left out), metres."""
    solid_margin: Metres = 0.15
    """The strip this close to either room face is left out of that test (the wall's faces
    lie in it when the rooms stop short of them), metres."""
    solid_share: Ratio = 0.35
    """A gap is solid when at most this share of its 10 cm plan cells (away from the faces)
    hold points (a doorway through a thick wall holds some)."""
    min_thickness: Metres = 0.03
    """Facing room faces closer than this meet without a wall (an open plan), metres."""
    exterior_thickness: Metres = 0.3
    """Thickness of an exterior wall whose outer face is not measured, metres."""
    min_length: Metres = 0.1
    """Wall pieces shorter than this along their axis are dropped, metres."""
    parallel_angle: Radians = math.radians(5.0)
    """Room faces within this angle of antiparallel face each other, radians."""
    run_angle: Radians = math.radians(1.5)
    """Wall pieces within this angle of parallel (and on one line) can be one run, radians."""
    line_tolerance: Metres = 0.06
    """Collinear pieces whose centre lines are this close (across) are one run, metres."""
    thickness_tolerance: Metres = 0.06
    """Collinear pieces whose thicknesses differ by at most this can be one run, metres."""
    doorway_bridge: Metres = 3.0
    """Collinear pieces of a wall between the same two rooms this far apart are one run: the
    rooms' footprints meet in a doorway (the wall goes on through it), metres."""
    simplify: Metres = 0.01
    """Footprints are simplified by this much before their edges are read, metres."""
    min_join_angle: Radians = math.radians(20.0)
    """Two runs join at an end only if their axes cross at least at this angle, radians."""


@dataclass(frozen=True)
class SlabParams:
    """Floor and ceiling/roof slabs per storey."""

    thickness: Metres = 0.25
    """Slab thickness where two scanned storeys do not give it (the gap between a ceiling
    and the floor above), metres."""
    max_gap: Metres = 1.2
    """A gap between a storey's ceiling and the next floor above up to this is one slab,
    metres."""
    level_tolerance: Metres = 0.05
    """Rooms whose ceilings are this close share one ceiling slab, metres."""


@dataclass(frozen=True)
class ElementsParams:
    """Parameters of the building-elements stage (:mod:`engine.elements.build`)."""

    walls: WallRunParams = field(default_factory=WallRunParams)
    slabs: SlabParams = field(default_factory=SlabParams)
    openings: OpeningParams = field(default_factory=OpeningParams)
    detect_openings: Flag = True
    """Find doors and windows in the walls when a scan is given."""

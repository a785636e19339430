"""Parameters of the building-elements stage (SI units: metres, radians)."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..quantities import Count, Factor, Flag, Metres, Radians, Ratio, SquareMetres

__all__ = ["OpeningParams", "ViewpointParams", "WallRunParams", "SlabParams", "SkylightParams",
           "ElementsParams"]


@dataclass(frozen=True)
class OpeningParams:
    """Thresholds of :func:`detect_openings` (SI units: metres, shares 0–1)."""

    cell: Metres = 0.05
    """Raster cell along the wall and in height, metres."""
    reach: Metres = 1.0
    """Points up to this far in front of / beyond a face are gathered for a wall; furniture
    up to this far in front of a face shadows it, metres."""
    grid: Metres = 0.5
    """Cell of the 2-D grid that assigns points to walls, metres."""
    face_search: Metres = 0.08
    """A face is looked for this far around its nominal place (axis ± thickness/2), metres."""
    face_sigmas: Factor = 2.5
    """Face tolerance in units of the measured range noise σ."""
    face_tolerance: tuple = (0.015, 0.06)
    """Lower and upper bound of the face tolerance, metres."""
    face_proud: Metres = 0.04
    """Where a hole's edges are measured, points up to this in front of a face (room side)
    are the face too: a door's casing stands 1-3 cm proud of the plaster, and a casing left
    out of the face widens the door by its width on each side (gaps are still found on the
    plaster's plane), metres."""
    edge_band: Metres = 0.08
    """Rows this close to the floor or ceiling are left out of the face rasters, metres."""
    kernel_points: Factor = 6.0
    """The presence kernel grows (15 → 55 cm) until it expects this many face points."""
    presence_share: Ratio = 0.25
    """A face cell is present when its kernel holds at least one point and this share of
    the kernel's usual count around it (the local face density)."""
    density_window: Metres = 1.0
    """Side of the window of the local face density, metres."""
    unobserved_run: Metres = 4.0
    """A face without points (and no rays through it) over a longer stretch is unobserved
    there, metres."""
    rect_share: Ratio = 0.55
    """Rows / columns of a gap's bounding box less empty than this are cut off."""
    merge_gap: Metres = 0.2
    """Gaps this close along the wall, overlapping in height, are one gap, metres."""
    abut: Metres = 0.05
    """Two openings overlapping by at most this much across one edge are neighbours (two
    windows measured from the mullion or transom between them), not one found twice; they
    are trimmed to meet halfway, metres ..."""
    abut_share: Ratio = 0.1
    """... or by at most this share of the narrower one's width (the lower one's height):
    each is measured into the mullion or pier between them, which may be wider (the Duplex's
    stair-hall panes, 10 cm from a 2.8 m window: 6 cm of overlap)."""
    min_door_width: Metres = 0.6
    """Narrower gaps reaching the floor are not doors, metres."""
    max_door_width: Metres = 2.0
    """Wider gaps reaching the floor are doorless openings, metres."""
    min_door_height: Metres = 1.7
    """Lower gaps reaching the floor are not doors, metres."""
    max_opening_width: Metres = 8.0
    """Wider gaps are not openings, metres."""
    min_window_width: Metres = 0.3
    """Narrower gaps above the floor are not windows, metres."""
    min_window_height: Metres = 0.3
    """Lower gaps above the floor are not windows, metres."""
    floor_tolerance: Metres = 0.2
    """A gap starting this close to the floor reaches the floor, metres."""
    min_sill: Metres = 0.05
    """A floor-reaching gap whose bottom inside the thickness (the material under the hole:
    the floor through a doorway, a sill's top under a window) lies this far above the floor
    or more is a window with that sill, not a door, metres."""
    min_sill_columns: Count = 3
    """A floor-reaching gap lower than a door is a window when its sill's top is seen in
    this many columns (a taller gap needs half its columns, or ``level_sill_columns``),
    cells."""
    level_sill_columns: Count = 2
    """A floor-reaching gap as tall as a door is a window when its sill's top is seen at one
    level in this many of its inner columns (its jambs' columns left out) and the floor in
    at most a tenth of those showing either (:func:`engine.elements.sills.level_sill`),
    cells."""
    unseen_bottom: Metres = 0.5
    """A gap whose bottom edge is unseen (no points across the hole around it) within this of
    the floor reaches the floor when the floor shows inside the wall's thickness under it and
    no sill does (a door whose lower part the scan missed), metres."""
    sill_level: Metres = 0.03
    """The sill's top seen in a few columns of a tall gap is one level: within this of its
    median, metres."""
    ceiling_tolerance: Metres = 0.15
    """A gap ending this close to the ceiling reaches the ceiling, metres."""
    min_head: Metres = 0.05
    """A gap above the floor that reaches the ceiling is a window when its head's soffit (a
    plane inside the thickness) lies this far under the ceiling or more, metres."""
    min_seen_through: Ratio = 0.15
    """Share of a gap's cells crossed by scanner rays that makes it seen through."""
    max_occluded: Ratio = 0.4
    """Share of a gap's cells shadowed by points in front (and not seen through) that makes
    it an occlusion."""
    max_front_cover: Ratio = 0.3
    """Without scanner positions: share of a gap covered by points in front of the face
    that makes it an occlusion."""
    min_scan_points: Count = 30
    """A scanner sees a face (and takes part in its ray test) when it measured this many
    points on it (fewer, down to 5, for a scanner with fewer than 200 × as many points). A
    real scanner with fewer that sees the face through its holes (this many of its rays pass
    through it: glazing) adds those rays, not its few points' shadows."""
    edge_search: Metres = 0.35
    """A gap's edges are looked for this far beyond its empty cells, metres."""
    cue_share: Ratio = 0.3
    """Share of a door's width with floor points inside the thickness for the full cue."""
    reveal_share: Ratio = 0.5
    """Share of a gap's edges (jambs, head, sill) with reveal points for the full cue."""
    framed_share: Ratio = 0.75
    """A window in an exterior wall with reveals at this share of its edges (sill, head,
    jambs), not shadowed and with no back inside the thickness (a niche), is kept however
    little is seen beyond it: an upper storey's window looks at the sky, which returns no
    point."""
    band_flank: Metres = 1.0
    """Without scanner positions, a gap's rows are compared with the face this far beside it,
    metres ..."""
    band_share: Ratio = 0.3
    """... and lines of sight through it prove nothing when those rows hold less than this
    share of the face's density there over its height (a band between a scanner's lines)."""
    hole_points: Factor = 20.0
    """A hole whose face would hold this many more points, by the face's density in the same
    rows beside it (:func:`engine.elements.gaps.hole_deficit`), gets the full cue of a
    missing face."""
    min_confidence: Ratio = 0.3
    """Gaps with less confidence are dropped."""
    junction_depth: Metres = 0.1
    """A wall standing against a face from the face out to this far in front of it hides the
    face there: no gap in those columns (:mod:`engine.elements.junctions`), metres."""
    leaf_depth: tuple = (0.02, 0.10)
    """A closed door leaf stands this far behind a face (inside the thickness), metres."""
    leaf_share: Ratio = 0.5
    """Share of a closed door's cells that must hold leaf points (near them), of the share the
    face reaches beside it (:func:`engine.elements.gaps.leaf_needed`)."""
    leaf_flank: Metres = 0.5
    """The face beside a closed leaf's hole, each side, that sets what the leaf must cover, metres."""
    leaf_floor: Ratio = 0.4
    """The face's cover beside the hole is taken as at least this (a leaf needs at least
    ``leaf_share`` × this of its cells: a few stray points in a sparsely seen hole are no leaf)."""
    flush_depth: Metres = 0.006
    """A closed leaf within the face tolerance (:mod:`engine.elements.leaves`): the face
    points over a door-sized rectangle reaching the floor stand at least this much deeper than
    the face beside and above it, metres ..."""
    flush_t: Factor = 8.0
    """... and that many standard errors of the face's noise (over the rectangle's points)."""
    flush_body: tuple = (0.3, 1.6)
    """Heights over the floor where a flush leaf's recess is looked for along the wall, metres
    (clear of skirting boards and of a door's head)."""
    flush_flank: Metres = 0.3
    """The face this wide beside a flush leaf is its reference depth, metres."""
    egress_depth: Metres = 1.2
    """An open exterior door leads onto ground, a terrace or a balcony: scan points at about
    its floor's level (``egress_band``) within this distance beyond the wall, metres."""
    egress_gap: Metres = 0.3
    """... counted from this far beyond the wall's outer face (not the sill of a low window in
    a wall thicker than the first pass assumed), metres."""
    egress_band: tuple = (-0.45, 0.25)
    """Levels (metres, from the storey's floor) that count as walkable beyond a door: a few
    steps down to a step up."""
    elevated_drop: Metres = 1.0
    """An open exterior "door" with nothing walkable beyond it, through which the scan sees
    points this far below its floor or more (the ground under an upper storey), is a
    window down to the floor (a French window without a balcony), metres."""
    min_elevated_points: Count = 5
    """Points that far below (within 2 m of the opening along the wall) needed to call an
    opening elevated (a narrow one seen through at a glance shows a few)."""


@dataclass(frozen=True)
class ViewpointParams:
    """Stand-in scanners in the rooms when the scan has no scanner positions
    (:mod:`engine.elements.viewpoints`)."""

    spacing: Metres = 4.0
    """One viewpoint per grid point of this spacing over a room's footprint (at least one per
    room), metres."""
    clearance: Metres = 0.5
    """Viewpoints keep this far inside the room's outline, metres."""
    height: Metres = 1.5
    """Over the storey's floor (at most 60 % of its height): a scanner's height, metres."""
    voxel: Metres = 0.1
    """Occupancy voxel that blocks a line of sight, metres."""
    source_voxel: Metres = 0.2
    """Points are tested per voxel of this size (their mean position), metres."""
    neighbours: Count = 4
    """Each point is tested against this many nearest viewpoints (at least 2 per storey)."""
    max_range: Metres = 15.0
    """Viewpoints farther than this from a point do not see it, metres."""
    plane_tolerance: Metres = 0.15
    """Occupied voxels this close to a point's tangent plane are its own surface (a floor seen
    at a glancing angle), not an obstacle, metres."""
    max_flatness: Ratio = 0.3
    """A source voxel's points lie on a plane when their least spread is at most this share of
    the next one."""
    chunk: Count = 200000
    """Lines marched at once (memory)."""


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
    face_search: Metres = 0.3
    """With a scan: where two spaces touch (their split cut through a wall), the wall's faces
    are looked for this far either side of the line they share, metres."""
    face_coverage: Ratio = 0.4
    """A face plane there holds mid-height points along at least this share of the line."""
    min_seen_thickness: Metres = 0.07
    """The two faces of such a wall are at least this far apart (a stud partition with its
    boards; closer planes are a panel, a leaf or a rail), metres."""
    min_thickness: Metres = 0.03
    """Facing room faces closer than this meet without a wall (an open plan), metres."""
    void_wall_thickness: Metres = 0.12
    """With a scan: room faces farther apart than ``max_thickness`` but at most
    ``max_solid_thickness`` across a gap that is not solid (a closet, a shaft or a strip
    behind furniture the rooms leave out) each get an interior wall this thick (at most a
    third of the gap), not an exterior one, metres."""
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
class SkylightParams:
    """Roof windows (:mod:`engine.elements.skylights`): holes in a roof slab seen from below."""

    cell: Metres = 0.1
    """Raster cell over a room's footprint, metres."""
    band: Metres = 0.08
    """Points this close to a room's ceiling are on it, metres."""
    min_depth: Metres = 0.2
    """Points at least this far above the ceiling are inside a hole through it (a recessed
    light stands less), metres."""
    max_depth: Metres = 1.5
    """... and at most this far (a roof's thickness and the skylight's kerb), metres."""
    min_area: SquareMetres = 0.15
    """A hole's least area, m²."""
    max_area: SquareMetres = 4.0
    """A hole's largest area (more: a void or a higher part of the room), m²."""
    min_side: Metres = 0.3
    """A hole's shorter side at least, metres."""
    min_fill: Ratio = 0.6
    """A hole's share of its bounding rectangle at least."""
    ring: Metres = 0.2
    """The ring around a hole that must be ceiling, metres."""
    min_ring: Ratio = 0.7
    """Share of the ring's cells with ceiling points at least, on three sides of the hole of
    four (a hole, not the ceiling's edge nor a part nobody saw; the fourth may be a wall)."""
    max_beyond: Ratio = 0.2
    """Share of the cells 0.3 m to ``ring`` + 0.2 m from a hole with points above the ceiling,
    at most: a shaft's walls hide what is beyond them (over a missing ceiling tile the plenum
    is seen far past the hole)."""
    wall_margin: Metres = 0.2
    """Cells this close to the room's walls are left out (the walls' tops), metres."""
    frame: Metres = 0.15
    """Depth of the window's box under the hole's top, metres."""


@dataclass(frozen=True)
class ElementsParams:
    """Parameters of the building-elements stage (:mod:`engine.elements.build`)."""

    walls: WallRunParams = field(default_factory=WallRunParams)
    slabs: SlabParams = field(default_factory=SlabParams)
    openings: OpeningParams = field(default_factory=OpeningParams)
    detect_openings: Flag = True
    """Find doors and windows in the walls when a scan is given."""
    viewpoints: ViewpointParams = field(default_factory=ViewpointParams)
    """Stand-in scanners for a scan without scanner positions."""
    skylights: SkylightParams = field(default_factory=SkylightParams)
    """Roof windows seen from the rooms under a roof slab (with a scan)."""

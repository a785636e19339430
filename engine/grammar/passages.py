"""Cuboids between rooms after the classification (docs/method.md §2): doorways whose top
only the ceiling's noise made look seen (:func:`doorway_tops`), wide passages under a beam or
a lintel that join two parts of an open plan (:func:`wide_passages`), narrow pockets of a
room whose ceiling fell between a far scan's lines (:func:`enclosed_pockets`), slices of a
room before its wall cut off by a wall line elsewhere (:func:`room_slices`), and strips of a
room behind tall furniture against a wall (:func:`furniture_strips`). They change
``shapes`` / ``types`` of :func:`.manhattan.place_storey` in place."""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..model import ShapeType
from .ipof import grid_face_index, local_radii
from .params import ManhattanParams

__all__ = ["doorway_tops", "wide_passages", "enclosed_pockets", "room_slices", "furniture_strips"]

_BEAM_SHARE = 0.25
"""A wide passage's faces hold a surface near the ceiling along at least this share of it: a
beam or a lintel over it (:func:`wide_passages`)."""
_SIDES = ((2, 0, -1), (3, 1, 0), (4, 0, 1), (5, -1, 0))
"""Side faces of a cuboid: (face index, di, dj) of the neighbour across it."""


def doorway_tops(shapes: dict, types: np.ndarray, uv: np.ndarray, X: np.ndarray, Y: np.ndarray,
                  params: ManhattanParams, spacing: float, margin: float) -> None:
    """Doorways whose top only the ceiling's noise made look seen, in place (issue 16).

    A thin interior cuboid on the floor in the middle of a wall run (a wall part of that run
    at one end along it, a part or a junction at the other: a sliver between two close cuts
    ends at junctions; or a thin exterior cuboid with both long faces unseen and a wall after
    it: a doorway cut in two by a cross wall's plane), both its long faces unseen (a gap
    through the wall), is a doorway under a lintel unless the ceiling runs on over it; a cuboid
    thin both ways (a junction's size) is taken along whichever line its neighbours make
    (two_storey_office mobile 3: a door cut at 10.1 m, its 22 cm piece typed interior from the
    ceiling's noise, joined a room and the corridor). A ceiling's points
    near a wall, pushed along their shallow rays by the range noise (about twice the surface
    noise measured across a surface), fall into the wall's footprint at the ceiling's height
    from both sides and covered the doorway's top between the margins (Duplex, 1M mobile
    points: top 0.48, a bedroom and its hallway one room). Its top is measured again with a
    margin of ``3 margin`` (up to a third of its width, :func:`.ipof.grid_face_index`), σ
    discs and sparse (``ceiling_reach``) alike: under τ both, it is exterior (the wall's
    door is found in it). ``uv`` : (n, 2) the lowest ceiling's points, metres."""
    tau, reach = params.tau, params.ceiling_reach * spacing

    def unseen(q, ax):  # both long faces of cuboid q across axis ax unseen
        return all(shapes[q].support.get(f"ipof_f{f}", 1.0) < tau for f in ((3, 5) if ax == 0 else (2, 4)))

    def wall_end(q, step, ax):  # the wall ending the run there (after a doorway's cuboid), or None
        if q not in shapes or shapes[q].attributes["thin_axis"] not in (ax, 2):
            return None
        if types[q] == ShapeType.WALL:
            return q
        nxt = (q[0] + step[0], q[1] + step[1], q[2])
        if types[q] == ShapeType.EXTERIOR and unseen(q, ax) and nxt in shapes and \
                types[nxt] == ShapeType.WALL and shapes[nxt].attributes["thin_axis"] in (ax, 2):
            return nxt
        return None

    for (i, j, k), s in list(shapes.items()):
        thin = s.attributes["thin_axis"]
        if k != 0 or s.type != ShapeType.INTERIOR or thin not in (0, 1, 2) or \
                ((i, j, 1) in shapes and types[i, j, 1] == ShapeType.INTERIOR):
            continue
        # a junction-sized cuboid (thin both ways) lies in whichever line its neighbours make
        for ax in ((thin,) if thin != 2 else (0, 1)):
            steps = [(0, -1), (0, 1)] if ax == 0 else [(-1, 0), (1, 0)]
            ends = [wall_end((i + di, j + dj, k), (di, dj), ax) for di, dj in steps]
            if all(ends) and unseen((i, j, k), ax) and \
                    any(shapes[q].attributes["thin_axis"] == ax for q in ends):
                break
        else:
            continue
        lo, hi = np.array([X[i], Y[j]]) - 2 * reach, np.array([X[i + 1], Y[j + 1]]) + 2 * reach
        near = uv[(uv >= lo).all(axis=1) & (uv <= hi).all(axis=1)]
        kw = dict(thin=params.max_wall_thickness, thin_margin=3.0 * margin)
        top = float(grid_face_index(near, X[i:i + 2], Y[j:j + 2], spacing, margin, **kw)[0, 0])
        sparse = top
        if reach > spacing and len(near):
            r = local_radii(near, spacing, reach)
            sparse = float(grid_face_index(near, X[i:i + 2], Y[j:j + 2], spacing, margin, radii=r, **kw)[0, 0])
        if max(top, sparse) >= tau:
            continue
        types[i, j, k] = ShapeType.EXTERIOR
        shapes[(i, j, k)] = s.logged(
            f"classify: in a wall run, both long faces unseen (a gap through it), its top seen only near "
            f"the wall's faces (IPoF {top:.2f}, sparse {sparse:.2f} at a {3.0 * margin:.3f} m margin) "
            "-> exterior (a doorway under a lintel)", type=ShapeType.EXTERIOR, terminal=True)


def wide_passages(shapes: dict, types: np.ndarray, params: ManhattanParams, upper=None) -> None:
    """Wide openings between two interiors (issue 19: open plans), in place.

    Thin exterior cuboids on the floor, in a row along their long axis at least
    ``min_passage_width`` long together, each between two interior cuboids across its thin
    axis, with the floor seen under it (IPoF(bottom) ≥ τ: no wall stands there) and neither
    face to those rooms seen (IPoF < τ), are a passage between two parts of an open plan.

    * Something over it near the ceiling — its faces' plane holds a surface in at least
      :data:`_BEAM_SHARE` of the bins along the row between 80 % and 95 % of the storey's
      height (``upper``, :class:`.ends.UpperBand`: a beam's or a lintel's side) — or ``upper``
      None: its top is a beam or a lintel, not a ceiling. Each cuboid becomes interior and
      joins the narrower side (a hall, a corridor); its face toward the wider side is an open
      boundary (``attributes["open_face"]``): the spaces split there ("split it at a beam") and
      are connected without a wall (an IfcVirtualElement).
    * Nothing: the strip of one room whose ceiling fell between a far scan's lines (the
      Duplex's foyer beside its stair, seen from the far end: one ceiling point in 0.12 m²
      where six were due); interior, with no boundary.

    Doors (narrower) keep their rooms apart. A shorter row qualifies when it spans a corridor
    from side wall to side wall: the wall cuboid at each of its ends runs on across it (wall
    on both sides along its thin axis), where a doorway's ends are pieces of the wall it
    pierces, with the rooms beside them; its floor or its ceiling is then seen somewhere along
    it (IPoF above ``min_room_evidence``: a wall's body shows neither), however thinly (the
    Duplex's 1.96 m hallways, cut by a 13 cm band whose ceiling and floor a far scan barely
    saw: bedroom doors led into the split-off ends)."""
    if params.min_passage_width <= 0:
        return
    tau = params.tau
    cand = {}
    for (i, j, k), s in shapes.items():
        ax = s.attributes["thin_axis"]
        if k != 0 or s.type != ShapeType.EXTERIOR or ax not in (0, 1):
            continue
        faces = (5, 3) if ax == 0 else (2, 4)
        nb = [(i - 1, j, k), (i + 1, j, k)] if ax == 0 else [(i, j - 1, k), (i, j + 1, k)]
        if any(s.support.get(f"ipof_f{q}", 1.0) >= tau for q in faces) or \
                not all(q in shapes and types[q] == ShapeType.INTERIOR for q in nb):
            continue
        cand[i, j] = (ax, faces, nb)
    done = set()
    for (i, j) in sorted(cand):
        if (i, j) in done:
            continue
        ax = cand[i, j][0]
        step = (0, 1) if ax == 0 else (1, 0)
        row = [(i, j)]
        while (nxt := (row[-1][0] + step[0], row[-1][1] + step[1])) in cand and cand[nxt][0] == ax:
            row.append(nxt)
        done.update(row)
        lo = shapes[row[0] + (0,)].geometry.bounds[0]
        hi = shapes[row[-1] + (0,)].geometry.bounds[1]
        long_ax = 1 - ax
        floor = [shapes[q + (0,)].support.get("ipof_bottom", 0.0) for q in row]
        seen = max(floor + [shapes[q + (0,)].support.get("ipof_top", 0.0) for q in row])
        if not (hi[long_ax] - lo[long_ax] >= params.min_passage_width and min(floor) >= tau
                or seen > params.min_room_evidence and _between_walls(types, row, step, ax)):
            continue
        beam = 1.0 if upper is None else max(upper.share(ax, float(w), float(lo[long_ax]), float(hi[long_ax]))
                                             for w in (lo[ax], hi[ax]))
        for q in row:
            s, (_, faces, nb) = shapes[q + (0,)], cand[q]
            types[q + (0,)] = ShapeType.INTERIOR
            if beam < _BEAM_SHARE:
                shapes[q + (0,)] = s.logged(
                    f"classify: {hi[long_ax] - lo[long_ax]:.2f} m long strip between two interiors, "
                    f"floor (IPoF(bottom)={s.support.get('ipof_bottom', 0.0):.2f}), no wall, nothing over it "
                    "near the ceiling "
                    f"({beam:.2f} of its length) -> interior (one room; its ceiling fell between scan lines)",
                    type=ShapeType.INTERIOR, terminal=False)
                continue
            # it joins the narrower side (a hall, a corridor); the open boundary is toward the wider
            wide = int(np.argmax([float(np.ptp(shapes[n].geometry.bounds[:, ax])) for n in nb]))
            shapes[q + (0,)] = s.logged(
                f"classify: {hi[long_ax] - lo[long_ax]:.2f} m wide passage between two interiors, floor seen "
                f"(IPoF(bottom)={s.support.get('ipof_bottom', 0.0):.2f}), no wall, a beam or lintel over it "
                f"({beam:.2f} of its length near the ceiling) -> interior, open to {shapes[nb[wide]].id}",
                type=ShapeType.INTERIOR, terminal=False,
                attributes={**s.attributes, "open_face": faces[wide]})


def _between_walls(types: np.ndarray, row: list, step: tuple, ax: int) -> bool:
    """Whether the cuboids just beyond both ends of ``row`` (grid (i, j), along ``step``) are
    walls that run on across it: no room on either side of each along the thin axis ``ax``
    (a wall, or a piece of it no scan saw), where a doorway's jambs have the rooms it joins.
    Past the grid's edge lies the outermost wall plane: the outer wall."""
    nx, ny = types.shape[:2]
    across = (1, 0) if ax == 0 else (0, 1)

    def is_(q, kinds):
        return not (0 <= q[0] < nx and 0 <= q[1] < ny) or types[q[0], q[1], 0] in kinds

    for (i, j), sgn in ((row[0], -1), (row[-1], 1)):
        e = (i + sgn * step[0], j + sgn * step[1])
        sides = [(e[0] + d * across[0], e[1] + d * across[1]) for d in (-1, 1)]
        if not is_(e, (ShapeType.WALL,)) or \
                not all(is_(q, (ShapeType.WALL, ShapeType.EXTERIOR)) for q in sides):
            return False
    return True


def enclosed_pockets(shapes: dict, types: np.ndarray, params: ManhattanParams,
                     seen_through: Optional[dict] = None) -> None:
    """Narrow parts of a room whose ceiling no scan line crossed, in place (issue 19).

    An exterior cuboid on the floor, wider than a wall but at most ``pocket_width`` across,
    with some floor seen (IPoF(bottom) > ``min_room_evidence``; a stair's void may take the
    rest) and nothing interior above it, is interior when it is closed all round — on every
    side a wall is seen in part (IPoF > ``min_room_evidence``: a far wall beside a void is
    seen sparsely too) or an interior, a wall or another such cuboid touches it, or the grid's
    edge where the outer wall is seen beside it along the edge, or a gap in a
    wall line (an exterior cuboid no thicker than a wall) that is closed so itself — and open
    to a room (an unseen face, IPoF < τ, toward an interior cuboid, or toward a sliver no thicker
    than 2 ``shape_buffer`` — two cuts of one surface — with the room beyond it; the sliver
    joins the pocket). Other gaps stay as they are. Far from a terrestrial scanner a
    ceiling is seen as lines tens of centimetres apart (0.6 m over the Duplex's hallways
    beside the stair voids, seen from the other end): a 0.6 m strip between two lines has no
    ceiling point, and the strip between the hallway and the bedroom's wall was exterior —
    a 0.7 m "wall" with the bedroom's door in it leading outside. The outside is not closed
    by walls and rooms; a courtyard or a light well is wider; a shaft is not open to a room.
    A wider cuboid is a candidate too when it is in ``seen_through`` ({(i, j): faces}: its far
    walls seen through it from inside the building, the rays entering by those faces,
    :func:`.visibility.seen_through`); it is open only to a room across one of those faces.
    Those parts get ``attributes["ceiling_seen"] = False`` (lower confidence)."""
    if params.pocket_width <= 0:
        return
    seen_through = seen_through or {}
    nx, ny, nz = types.shape
    tau, t_max = params.tau, params.max_wall_thickness
    cand, gaps = set(), set()
    for i in range(nx):
        for j in range(ny):
            s = shapes[(i, j, 0)]
            if types[i, j, 0] != ShapeType.EXTERIOR or \
                    any(types[i, j, k] == ShapeType.INTERIOR for k in range(1, nz)):
                continue
            size = np.ptp(s.geometry.bounds[:, :2], axis=0)
            if size.min() <= t_max:
                gaps.add((i, j))  # a gap in a wall line: closed only if what lies beyond it is
            elif size.min() <= params.pocket_width and \
                    s.support.get("ipof_bottom", 0.0) > params.min_room_evidence or (i, j) in seen_through:
                cand.add((i, j))
    closed = (ShapeType.INTERIOR, ShapeType.WALL)

    def seen(q, f):  # a wall seen in part on face f of cuboid q
        return q in shapes and shapes[q].support.get(f"ipof_f{f}", 0.0) > params.min_room_evidence

    def outer_wall_runs_on(c, f, di):
        """Past the grid's edge lies the outermost wall plane. Where the first cuboids wider
        than a wall either side of ``c`` along the edge see it (face ``f``, IPoF ≥ τ), that
        wall runs on past ``c`` however little of it shows there (the Duplex's east hallway,
        TLS: its end's outer wall hidden behind the stair, 0.04 seen, 0.45-0.50 beside it):
        closed. Unseen beside it too, the edge may be only where the scan stopped: open."""
        step = (0, 1) if di else (1, 0)
        along = 1 if di else 0
        found = False
        for sgn in (-1, 1):
            a, b = c[0] + sgn * step[0], c[1] + sgn * step[1]
            while 0 <= a < nx and 0 <= b < ny and \
                    float(np.ptp(shapes[(a, b, 0)].geometry.bounds[:, along])) <= t_max:
                a, b = a + sgn * step[0], b + sgn * step[1]
            if not (0 <= a < nx and 0 <= b < ny):
                continue
            if shapes[(a, b, 0)].support.get(f"ipof_f{f}", 0.0) < tau:
                return False
            found = True
        return found

    inside = cand | gaps
    changed = True
    while changed:  # a cuboid with a side open to the outside drops out, until none does
        changed = False
        for (i, j) in sorted(inside):
            size = np.ptp(shapes[(i, j, 0)].geometry.bounds[:, :2], axis=0)
            for f, di, dj in _SIDES:
                q = (i + di, j + dj)
                if seen((i, j, 0), f) or q in inside or (0 <= q[0] < nx and 0 <= q[1] < ny and
                                                         types[q[0], q[1], 0] in closed):
                    continue
                if not (0 <= q[0] < nx and 0 <= q[1] < ny) and outer_wall_runs_on((i, j), f, di):
                    continue
                # a gap's end too short to measure (a sliver between two close cuts): the wall
                # seen on that side of the cuboids across it runs on through it
                across = [(i, j - 1, 0), (i, j + 1, 0)] if di else [(i - 1, j, 0), (i + 1, j, 0)]
                if (i, j) in gaps and size[1 if di else 0] <= t_max and any(seen(a, f) for a in across):
                    continue
                # a gap in a wall line between two wall parts, toward a cuboid whose floor was
                # never seen: no scan looked through it, so it is the wall's unseen stretch (the
                # Duplex's hallway by its stair, TLS: beside a closet no scanner entered)
                line = [(i, j - 1, 0), (i, j + 1, 0)] if di else [(i - 1, j, 0), (i + 1, j, 0)]
                if (i, j) in gaps and size[0 if di else 1] <= t_max and \
                        all(a in shapes and types[a] == ShapeType.WALL for a in line) and \
                        0 <= q[0] < nx and 0 <= q[1] < ny and \
                        shapes[q + (0,)].support.get("ipof_bottom", 0.0) <= params.min_room_evidence:
                    continue
                inside.discard((i, j))
                changed = True
                break
    cand, gaps = cand & inside, gaps & inside
    sliver = 2.0 * float(params.shape_buffer or 0.0)  # two cuts of one surface: thinner than any wall
    for (i, j) in sorted(cand):
        s = shapes[(i, j, 0)]
        via, room = [], None
        # wider than a pocket: open only to the room its far walls were seen from, directly
        wide = seen_through.get((i, j)) if np.ptp(s.geometry.bounds[:, :2], axis=0).min() > \
            params.pocket_width else None
        for f, di, dj in _SIDES:  # a room across an unseen face, or across a sliver beyond it
            q, path = (i + di, j + dj), []
            if s.support.get(f"ipof_f{f}", 0.0) >= tau or (wide is not None and f not in wide):
                continue
            if wide is None and q in gaps and \
                    float(np.ptp(shapes[q + (0,)].geometry.bounds[:, 0 if di else 1])) <= sliver \
                    and shapes[q + (0,)].support.get(f"ipof_f{f}", 0.0) < tau:
                path, q = [q], (q[0] + di, q[1] + dj)
            if 0 <= q[0] < nx and 0 <= q[1] < ny and types[q[0], q[1], 0] == ShapeType.INTERIOR:
                via, room = path, f
                break
        if room is None:
            continue
        for q in [(i, j)] + via:
            c = shapes[q + (0,)]
            types[q[0], q[1], 0] = ShapeType.INTERIOR
            shapes[q + (0,)] = c.logged(
                f"classify: {float(np.ptp(s.geometry.bounds[:, :2], axis=0).min()):.2f} m wide pocket "
                f"{s.id}, floor seen (IPoF(bottom)={s.support.get('ipof_bottom', 0.0):.2f}), closed by walls "
                f"and rooms, open to a room (face {room}), ceiling unseen -> interior (lower confidence)",
                type=ShapeType.INTERIOR, terminal=False, attributes={**c.attributes, "ceiling_seen": False})


def room_slices(shapes: dict, types: np.ndarray, params: ManhattanParams) -> None:
    """Slices of a room before its wall, in place (issue 19). A wall line elsewhere on the
    storey (the other face of a party wall, a lining 10 cm proud) cuts the grid a few
    centimetres before a room's wall: the cuboid between the two is thinner than a wall, its
    ceiling too narrow to be seen near the wall, and its one seen face made it a wall — the
    room lost the slice (Duplex: 10 cm of each bedroom along the party wall, and the end of a
    window at the corner). A wall cuboid thin along one axis whose face on one side is seen
    (IPoF ≥ τ) and on the other barely (< τ/2; its points count for the nearest cut only),
    with an interior cuboid across the unseen face and none across the seen one, is that
    room's slice: the surface was seen from the room, through it."""
    tau = params.tau
    for (i, j, k), s in list(shapes.items()):
        ax = s.attributes.get("thin_axis")
        if types[i, j, k] != ShapeType.WALL or ax not in (0, 1):
            continue
        lo_f, hi_f = (5, 3) if ax == 0 else (2, 4)
        di, dj = (1, 0) if ax == 0 else (0, 1)
        lo_q, hi_q = (i - di, j - dj, k), (i + di, j + dj, k)
        f = {q: float(s.support.get(f"ipof_f{q}", 0.0)) for q in (lo_f, hi_f)}
        for seen, free, seen_q, free_q in ((lo_f, hi_f, lo_q, hi_q), (hi_f, lo_f, hi_q, lo_q)):
            if f[seen] >= tau and f[free] < tau / 2 and free_q in shapes and seen_q in shapes \
                    and types[free_q] == ShapeType.INTERIOR and types[seen_q] != ShapeType.INTERIOR:
                types[i, j, k] = ShapeType.INTERIOR
                shapes[(i, j, k)] = s.logged(
                    f"classify: a slice before a wall seen from the room beside it (IPoF {f[seen]:.2f} on "
                    f"one side, {f[free]:.2f} on the room's) -> interior",
                    type=ShapeType.INTERIOR, terminal=False)
                break


def furniture_strips(shapes: dict, types: np.ndarray, uv: np.ndarray, X: np.ndarray, Y: np.ndarray,
                     params: ManhattanParams, margin: float) -> None:
    """Strips of a room behind tall furniture against a wall, in place (issue 19).

    A cabinet 0.4 m deep and 2 m high against a wall puts a plane at its front: the cuboids
    between it and the wall are each thinner than a wall, their floor hidden and their
    ceiling's index low (narrow cuboids on a sparse scan: 0.05–0.24 where the room beside
    them reaches 0.8, two_storey_office mobile), so they came out exterior — the room ended at
    the cabinet's front, with a 0.7 m "wall" holding a false door. A run across them, from an
    interior cuboid wider than a wall both ways (a room part, not a doorway's band; the face
    between them may be seen: the furniture's front, on another wall's plane) over exterior
    cuboids on the floor (and thin interior ones the classification made rooms of, the first
    one too: a wall line elsewhere on the storey cuts a strip off the room; all of them too:
    a sparse ceiling counted by its height, :mod:`.levels`) to a wall cuboid, each at most
    ``max_wall_thickness`` across and longer than that along the wall (a strip, not a piece of
    a wall line: a run along a wall line from a doorway merged a corridor with a room), all
    at most ``pocket_width`` across, closed at its ends (walls, rooms, such runs or the grid's
    edge, the outermost wall plane; a thin interior cuboid's ends by walls), is part of the
    room when its ceiling is seen at least
    ``strip_density`` of the room's density beside it: points of the lowest ceiling level
    ``uv`` per m² inside the run (``margin`` — the range noise — in from its long sides)
    against those in the room's band ``strip_band`` (or the run's width) wide along it (a
    ceiling's density falls off away from a scanner's path). Its faces across the run are
    furniture (``joined_faces``): one space with the room. A wall's body has no ceiling over
    it, a doorway's is hidden by its lintel, and beyond a glazed wall lies the outside, not
    a wall."""
    if params.pocket_width <= 0 or params.strip_density <= 0 or len(uv) == 0:
        return
    nx, ny, nz = types.shape
    t_max = params.max_wall_thickness
    uv = uv[np.argsort(uv[:, 0])]  # slices of it are counted: any order of ties

    def density(x0, x1, y0, y1):
        if x1 <= x0 or y1 <= y0:
            return 0.0
        a, b = np.searchsorted(uv[:, 0], x0), np.searchsorted(uv[:, 0], x1, side="right")
        n = int(np.count_nonzero((uv[a:b, 1] >= y0) & (uv[a:b, 1] <= y1)))
        return n / ((x1 - x0) * (y1 - y0))

    def inside(q):
        return 0 <= q[0] < nx and 0 <= q[1] < ny

    def free(q):  # an exterior cuboid on the floor with nothing interior above it
        return inside(q) and types[q[0], q[1], 0] == ShapeType.EXTERIOR and \
            not any(types[q[0], q[1], k] == ShapeType.INTERIOR for k in range(1, nz))

    def across(q):  # the cuboid's extent along x and y
        return np.ptp(shapes[q + (0,)].geometry.bounds[:, :2], axis=0)

    runs = []
    for (i, j), t in np.ndenumerate(types[:, :, 0]):
        if t != ShapeType.INTERIOR or across((i, j)).min() <= t_max:
            continue  # a room part, not a band of a wall line (a doorway)
        for f, di, dj in _SIDES:
            back = {2: 4, 3: 5, 4: 2, 5: 3}[f]
            run, q = [], (i + di, j + dj)
            edges = X if di else Y
            while (free(q) or (inside(q) and types[q[0], q[1], 0] == ShapeType.INTERIOR)) \
                    and edges[q[0 if di else 1] + 1] - edges[q[0 if di else 1]] <= t_max:
                run.append(q)  # ... or a thin part the classification made a room of (first too:
                # a wall line elsewhere on the storey cuts one off the room; all of them: a sparse
                # ceiling seen by its height, :mod:`.levels`)
                q = (q[0] + di, q[1] + dj)
            if not run or not inside(q) or types[q[0], q[1], 0] != ShapeType.WALL or \
                    any(across(c)[1 if di else 0] <= t_max for c in run):
                continue  # ... and strips along the wall, not pieces of a wall line
            lo = np.min([shapes[c + (0,)].geometry.bounds[0, :2] for c in run], axis=0)
            hi = np.max([shapes[c + (0,)].geometry.bounds[1, :2] for c in run], axis=0)
            if float((hi - lo)[0 if di else 1]) > params.pocket_width:
                continue
            # the room's ceiling beside the run, as wide (a ceiling's density falls off away
            # from the scanner's path: the room's middle is no measure for its edge)
            rb = shapes[(i, j, 0)].geometry.bounds.copy()
            k = 0 if di else 1
            band = max(float(hi[k] - lo[k]), params.strip_band)
            if di + dj > 0:
                rb[0, k] = max(rb[0, k], rb[1, k] - band)
            else:
                rb[1, k] = min(rb[1, k], rb[0, k] + band)
            ref = density(rb[0, 0] + margin, rb[1, 0] - margin, rb[0, 1] + margin, rb[1, 1] - margin)
            lo[k], hi[k] = lo[k] + margin, hi[k] - margin
            if ref > 0 and density(lo[0], hi[0], lo[1], hi[1]) >= params.strip_density * ref:
                runs.append(((i, j), f, back, run, ref))
    cells = {c for *_, run, _ in runs for c in run}
    changed = True
    while changed:  # a run whose end opens to the outside (or a thin room part's, to a room) drops out
        changed = False
        for r in list(runs):
            di = r[1] in (3, 5)
            ends = [(c, (c[0], c[1] + s) if di else (c[0] + s, c[1])) for c in r[3] for s in (-1, 1)]
            # the grid's edge is the outermost wall plane: it closes a run as it closes a room
            if any(inside(e) and e not in cells and (
                   types[e[0], e[1], 0] != ShapeType.WALL if types[c[0], c[1], 0] == ShapeType.INTERIOR
                   else types[e[0], e[1], 0] not in (ShapeType.INTERIOR, ShapeType.WALL))
                   for c, e in ends):
                runs.remove(r)
                cells = {c for *_, run, _ in runs for c in run}
                changed = True
    for (i, j), f, back, run, ref in runs:
        for n, c in enumerate(run):
            s = shapes[c + (0,)]
            types[c[0], c[1], 0] = ShapeType.INTERIOR
            # the faces across the run are furniture, not the last one's toward the wall
            joined = tuple(sorted(set(s.attributes.get("joined_faces", ())) | {back}
                                  | ({f} if n < len(run) - 1 else set())))
            shapes[c + (0,)] = s.logged(
                f"classify: strip between room part {shapes[(i, j, 0)].id} and a wall behind furniture, "
                f"ceiling seen at the room's density (≥ {params.strip_density:g} of {ref:.0f} points/m²) "
                "-> interior", type=ShapeType.INTERIOR, terminal=False,
                attributes={**s.attributes, "joined_faces": joined})

"""Wall runs from the spaces' footprints (docs/method.md §7.1).

The spaces of a storey are footprints in plan; a wall is what lies between them. Per storey:

1. every space's footprint (the union of its leaves' footprints) is read as directed edges,
   the space on each edge's left, its outward normal on the right;
2. two edges of different spaces that face each other (antiparallel within
   ``parallel_angle``, ``min_thickness`` to ``max_thickness`` apart, overlapping along
   their length) bound an interior wall piece over the overlap: its axis is the mid-line,
   its thickness the measured gap. Faces closer than ``min_thickness`` meet without a wall
   (an open plan). Two edges of one space facing each other across a wall's thickness are a
   partition standing free in it: a wall piece with that space on both sides;
3. what is left of an edge, facing no space within ``max_thickness``, is an exterior wall
   piece of ``exterior_thickness`` outside the face;
4. collinear pieces of about the same thickness and kind that overlap or are separated by
   no more than a junction (``max_thickness``) are one run; an interior run lying within a
   longer one between the same two rooms (a room's footprint reaching into its wall along a
   doorway) is dropped;
5. run ends meet: where the axes of two runs cross near an end, the runs join (an L corner
   ``ATSTART``/``ATEND`` to ``ATSTART``/``ATEND``, a T junction to ``ATPATH``); at a corner
   one run goes through to the other's far face and the other stops at its near face (a
   butt joint, no overlap), at a T the ending run stops at the through run's face.

Cost: edges are found with one STRtree query per edge (n log n in edges); nothing depends
on the extent.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np
from shapely import STRtree
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.polygon import orient
from shapely.ops import unary_union

from ..geometry.boxes import box_sides
from ..geometry.polygon import polygon_parts
from ..model import BuildingModel, Shape
from .params import WallRunParams

__all__ = ["WallRun", "space_footprint", "wall_runs"]


@dataclass
class _Piece:
    a: np.ndarray          # axis start (2,)
    b: np.ndarray          # axis end (2,)
    thickness: float
    external: bool
    left: Optional[str]    # space on the left of a→b
    right: Optional[str]
    measured: bool
    seen: bool = False     # a wall seen in the scan where two spaces touch


@dataclass
class WallRun:
    """A straight wall between two ends (aligned frame, metres).

    ``a``/``b`` the axis ends, ``thickness``, ``external``, ``spans`` (u0, u1, left, right)
    with u measured from ``a`` along the axis, ``joins`` (other run index, at, other_at).
    """

    storey: int
    a: np.ndarray
    b: np.ndarray
    thickness: float
    external: bool
    measured: bool
    spans: list = field(default_factory=list)
    joins: list = field(default_factory=list)

    @property
    def direction(self) -> np.ndarray:
        d = self.b - self.a
        return d / max(float(np.linalg.norm(d)), 1e-12)

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self.b - self.a))

    def footprint(self) -> np.ndarray:
        """(4, 2) float64 counter-clockwise rectangle around the axis."""
        d = self.direction
        n = np.array([-d[1], d[0]]) * self.thickness / 2
        return np.array([self.a - n, self.b - n, self.b + n, self.a + n])

    def sides(self) -> tuple:
        """(left, right) space ids over the longest span."""
        if not self.spans:
            return (None, None)
        s = max(self.spans, key=lambda x: x[1] - x[0])
        return (s[2], s[3])


def space_footprint(model: BuildingModel, space: Shape):
    """The plan footprint of a space: the union of its leaves' footprints (shapely)."""
    polys = []
    for leaf in model.leaves(space.id):
        fp = leaf.geometry.footprint()
        if fp is None:
            v = leaf.geometry.vertices
            poly = Polygon(v[:, :2]).convex_hull if len(v) >= 3 else None
        else:
            poly = Polygon(fp)
        if poly is not None and poly.area > 0:
            polys.append(poly.buffer(0))
    if not polys:
        return None
    u = unary_union(polys)
    # close hairline seams between parts
    return u.buffer(1e-3, join_style="mitre").buffer(-1e-3, join_style="mitre")


def _edges(footprints: dict, tol: float):
    """Directed edges (p, q, space id): the space on the left."""
    P, Q, owner = [], [], []
    for sid, g in footprints.items():
        for poly in polygon_parts(g):
            poly = orient(poly.simplify(tol, preserve_topology=True), 1.0)
            for ring in [poly.exterior, *poly.interiors]:
                c = np.asarray(ring.coords)[:, :2]
                for i in range(len(c) - 1):
                    if np.linalg.norm(c[i + 1] - c[i]) > 1e-6:
                        P.append(c[i])
                        Q.append(c[i + 1])
                        owner.append(sid)
    return np.array(P).reshape(-1, 2), np.array(Q).reshape(-1, 2), owner


def _subtract(intervals, lo, hi):
    """[lo, hi] minus the union of ``intervals``."""
    out, cur = [], lo
    for a, b in sorted(intervals):
        if b <= cur:
            continue
        if a > cur:
            out.append((cur, min(a, hi)))
        cur = max(cur, b)
        if cur >= hi:
            break
    if cur < hi:
        out.append((cur, hi))
    return [(a, b) for a, b in out if b > a]


def _rect(pc: _Piece) -> np.ndarray:
    """(4, 2) footprint of a piece: its axis widened to its thickness."""
    d = (pc.b - pc.a) / max(float(np.linalg.norm(pc.b - pc.a)), 1e-12)
    n = np.array([-d[1], d[0]]) * pc.thickness / 2
    return np.array([pc.a - n, pc.b - n, pc.b + n, pc.a + n])


def _split_at_breaks(piece: _Piece, breaks, prm: WallRunParams) -> list:
    """The parts of an interior piece outside the break regions (plan polygons)."""
    line = LineString([piece.a, piece.b])
    length = line.length
    cut = []
    for region in breaks:
        if not region.intersects(line):
            continue
        part = line.intersection(region)
        if part.is_empty:
            continue
        ts = [line.project(Point(xy)) for g in getattr(part, "geoms", [part]) for xy in np.asarray(g.coords)]
        cut.append((min(ts), max(ts)))
    if not cut:
        return [piece]
    d = (piece.b - piece.a) / max(length, 1e-12)
    return [_Piece(piece.a + d * u0, piece.a + d * u1, piece.thickness, piece.external, piece.left, piece.right,
                   piece.measured, piece.seen) for u0, u1 in _subtract(cut, 0.0, length) if u1 - u0 >= prm.min_length]


def _pieces(footprints: dict, prm: WallRunParams, measured=None, breaks=(), solid=None, faces=None):
    """Interior and exterior wall pieces and the open-plan pairs of one storey; ``measured``
    [(region, thickness)]: exterior pieces whose default axis lies in a region get its thickness;
    ``breaks`` [region]: interior pieces stop there and their two spaces meet without a wall;
    ``solid(region) -> bool``: whether a gap wider than ``max_thickness`` (up to
    ``max_solid_thickness``) is solid in the scan, so a thick wall, else a void inside the
    building with a wall along each face (docs/method.md §7.1); ``faces(p, q, n)``: the
    wall the scan shows along the stretch p–q where two spaces touch, as (offset of its axis
    along n, thickness), or None (they meet without a wall)."""
    P, Q, owner = _edges(footprints, prm.simplify)
    m = len(P)
    if m == 0:
        return [], set()
    D = Q - P
    L = np.linalg.norm(D, axis=1)
    D = D / L[:, None]
    N = np.stack([D[:, 1], -D[:, 0]], axis=1)  # outward (right of the edge)
    lines = [LineString([P[i], Q[i]]) for i in range(m)]
    tree = STRtree(lines)
    cos_par = math.cos(prm.parallel_angle)
    covered = [[] for _ in range(m)]
    pieces, open_pairs = [], set()
    # every edge against the edges within max_thickness of it
    reach = max(prm.max_thickness, prm.max_solid_thickness) if solid is not None else prm.max_thickness
    qi, qj = tree.query(lines, predicate="dwithin", distance=reach)
    thick = []  # (gap, i, j): facing edges farther apart than max_thickness, tested below
    voids = []  # (region, i, u0, u1, gap): such gaps that are not solid
    for i, j in zip(qi.tolist(), qj.tolist()):
        if i >= j:
            continue
        if float(D[i] @ D[j]) > -cos_par:
            continue
        s = float(N[i] @ (0.5 * (P[j] + Q[j]) - P[i]))  # gap from edge i outward to edge j
        if s > reach or s < -prm.min_thickness:
            continue
        # two edges of one space facing each other across a wall's thickness: a partition
        # standing free in it (the Duplex's stub between the living room and the foyer, one
        # open plan past its end) — a wall with that space on both sides
        if owner[i] == owner[j] and not prm.min_thickness <= s <= prm.max_thickness:
            continue
        u_a, u_b = float(D[i] @ (P[j] - P[i])), float(D[i] @ (Q[j] - P[i]))
        u0, u1 = max(0.0, min(u_a, u_b)), min(L[i], max(u_a, u_b))
        if u1 - u0 < prm.min_length:
            continue
        if s > prm.max_thickness:
            thick.append((s, i, j, u0, u1))
            continue
        # the same interval on edge j
        v_a, v_b = float(D[j] @ (P[i] + D[i] * u0 - P[j])), float(D[j] @ (P[i] + D[i] * u1 - P[j]))
        covered[i].append((u0, u1))
        covered[j].append((min(v_a, v_b), max(v_a, v_b)))
        seen = None
        if s < prm.min_thickness:
            seen = faces(P[i] + D[i] * u0, P[i] + D[i] * u1, N[i]) if faces is not None else None
            if seen is None:
                open_pairs.add(tuple(sorted((owner[i], owner[j]))))
                continue
            c, s = seen  # the spaces meet on a wall the scan shows: its faces give it
            off = N[i] * c
        else:
            off = N[i] * (s / 2)
        a, b = P[i] + D[i] * u0 + off, P[i] + D[i] * u1 + off
        piece = _Piece(a, b, s, False, owner[i], owner[j], True, seen=seen is not None)
        parts = _split_at_breaks(piece, breaks, prm) if breaks else [piece]
        if len(parts) != 1 or parts[0] is not piece:
            open_pairs.add(tuple(sorted((owner[i], owner[j]))))
        pieces.extend(parts)
    # a wall seen where two spaces touch that lies along another wall piece is that wall
    if any(pc.seen for pc in pieces):
        plain = [Polygon(_rect(pc)).buffer(0.05, join_style="mitre") for pc in pieces if not pc.seen]
        keep = []
        for pc in pieces:
            if pc.seen and plain:
                own = Polygon(_rect(pc))
                if sum(own.intersection(q).area for q in plain) >= 0.5 * own.area:
                    continue
            keep.append(pc)
        pieces = keep
    # thicker gaps, nearest first, where the edges are not yet paired: a wall when solid
    for s, i, j, u0, u1 in sorted(thick):
        free = _subtract(covered[i], u0, u1)
        if not free:
            continue
        u0, u1 = max(free, key=lambda x: x[1] - x[0])
        if u1 - u0 < prm.min_length:
            continue
        mg = prm.solid_margin
        core = Polygon([P[i] + D[i] * u0 + N[i] * mg, P[i] + D[i] * u1 + N[i] * mg,
                        P[i] + D[i] * u1 + N[i] * (s - mg), P[i] + D[i] * u0 + N[i] * (s - mg)])
        v_a, v_b = float(D[j] @ (P[i] + D[i] * u0 - P[j])), float(D[j] @ (P[i] + D[i] * u1 - P[j]))
        covered[i].append((u0, u1))
        covered[j].append((min(v_a, v_b), max(v_a, v_b)))
        if not solid(core):
            # neither a wall nor a room: a closet, a shaft or a strip behind furniture that
            # the rooms leave out, inside the building — a wall along each room's face, the
            # room across the void on its other side (a door in it leads there)
            voids.append((Polygon([P[i] + D[i] * u0, P[i] + D[i] * u1, P[i] + D[i] * u1 + N[i] * s,
                                   P[i] + D[i] * u0 + N[i] * s]), i, u0, u1, s))
            tv = min(prm.void_wall_thickness, s / 3)
            for e, f, w0, w1 in ((i, j, u0, u1), (j, i, min(v_a, v_b), max(v_a, v_b))):
                off = N[e] * (tv / 2)
                pieces.append(_Piece(P[e] + D[e] * w0 + off, P[e] + D[e] * w1 + off, tv, False, owner[e],
                                     owner[f], False))
            continue
        off = N[i] * (s / 2)
        pieces.append(_Piece(P[i] + D[i] * u0 + off, P[i] + D[i] * u1 + off, s, False, owner[i], owner[j], True))
    t = prm.exterior_thickness
    # the building closed over its walls: a face whose outside lies in it is at a junction
    # or a niche, not on the exterior; so is one facing a void (a wall along it), and the
    # building takes in its voids, its interior walls and the narrow holes they enclose
    r = prm.max_thickness / 2
    void = unary_union([v[0] for v in voids]) if voids else Polygon()
    closed = unary_union(list(footprints.values()) + [Polygon(_rect(pc)) for pc in pieces] + [void])
    closed = closed.buffer(r, join_style="mitre").buffer(-r, join_style="mitre")
    filled = _fill_holes(closed, prm.max_solid_thickness)
    void = unary_union([void, filled.difference(closed)])  # an enclosed shaft is a void too
    closed = filled
    probe = r + 0.05
    for i in range(m):
        for u0, u1 in _subtract(covered[i], 0.0, float(L[i])):
            if u1 - u0 < prm.min_length:
                continue
            at = P[i] + D[i] * (0.5 * (u0 + u1))
            if not void.is_empty and any(void.contains(Point(at + N[i] * d)) for d in (0.15, probe)):
                off = N[i] * (prm.void_wall_thickness / 2)
                pieces.append(_Piece(P[i] + D[i] * u0 + off, P[i] + D[i] * u1 + off, prm.void_wall_thickness,
                                     False, owner[i], None, False))
                continue
            if closed.contains(Point(at + N[i] * probe)):
                continue
            te, known = _exterior_thickness(at + N[i] * (t / 2), t, measured)
            off = N[i] * (te / 2)
            pieces.append(_Piece(P[i] + D[i] * u0 + off, P[i] + D[i] * u1 + off, te, True, owner[i], None, known))
    # a void's end open to the outside: the envelope goes on across it
    for _, i, u0, u1, s in voids:
        for u, out in ((u0, -D[i]), (u1, D[i])):
            a = P[i] + D[i] * u
            b = a + N[i] * s
            if closed.contains(Point(0.5 * (a + b) + out * probe)):
                continue
            te, known = _exterior_thickness(0.5 * (a + b) + out * (t / 2), t, measured)
            pieces.append(_Piece(a + out * (te / 2), b + out * (te / 2), te, True, None, None, known))
    return pieces, open_pairs


def _exterior_thickness(at: np.ndarray, default: float, measured) -> tuple:
    """(thickness, measured?) of an exterior wall whose axis passes ``at``: that of the
    measured region holding it, else ``default``."""
    for region, tm in measured or ():
        if region.contains(Point(at)):
            return tm, True
    return default, False


def _fill_holes(geom, width: float):
    """``geom`` with its holes no wider than ``width`` filled (the shorter side of a hole's
    minimum-area box): enclosed shafts and closets, not courtyards."""
    out = []
    for g in polygon_parts(geom):
        keep = [h for h in g.interiors if box_sides(Polygon(h))[0] > width]
        out.append(Polygon(g.exterior, keep))
    return unary_union(out) if out else geom


def _bridges_break(d, n, c: float, u0: float, u1: float, breaks) -> bool:
    """Whether the stretch u0..u1 of the line ``n·x = c`` (direction ``d``) crosses a break."""
    if not breaks or u1 <= u0:
        return False
    seg = LineString([d * u0 + n * c, d * u1 + n * c])
    return any(region.intersects(seg) for region in breaks)


def _runs_of(pieces: list, storey: int, prm: WallRunParams, breaks=()) -> list:
    """Collinear pieces of one kind and thickness → runs (never across a break)."""
    if not pieces:
        return []
    recs = []
    for k, pc in enumerate(pieces):
        d = pc.b - pc.a
        th = math.atan2(d[1], d[0]) % math.pi
        recs.append((th, k))
    recs.sort()
    # cluster directions (wrap at π)
    groups, cur = [], [recs[0]]
    for r in recs[1:]:
        if r[0] - cur[-1][0] <= prm.run_angle:
            cur.append(r)
        else:
            groups.append(cur)
            cur = [r]
    groups.append(cur)
    if len(groups) > 1 and groups[0][0][0] + math.pi - groups[-1][-1][0] <= prm.run_angle:
        groups[0] = groups[-1] + groups[0]
        groups.pop()
    runs = []
    for g in groups:
        ths = np.array([r[0] for r in g])
        ref = ths[0]
        ths = ref + ((ths - ref + math.pi / 2) % math.pi - math.pi / 2)
        lengths = np.array([np.linalg.norm(pieces[k].b - pieces[k].a) for _, k in g])
        theta = float(np.average(ths, weights=lengths))
        d = np.array([math.cos(theta), math.sin(theta)])
        n = np.array([-d[1], d[0]])
        items = []
        for _, k in g:
            pc = pieces[k]
            ua, ub = float(d @ pc.a), float(d @ pc.b)
            left, right = (pc.left, pc.right) if ua <= ub else (pc.right, pc.left)
            c = float(n @ (0.5 * (pc.a + pc.b)))
            items.append((c, min(ua, ub), max(ua, ub), pc, left, right))
        items.sort(key=lambda x: x[0])
        # cluster across the line, then by kind and thickness, then along it
        lines, cur = [], [items[0]]
        for it in items[1:]:
            if it[0] - cur[-1][0] <= prm.line_tolerance:
                cur.append(it)
            else:
                lines.append(cur)
                cur = [it]
        lines.append(cur)
        for line in lines:
            line.sort(key=lambda x: x[1])
            chains = []
            for it in line:
                for ch in chains:
                    last = ch[-1]
                    end = max(x[2] for x in ch)
                    same_rooms = not it[3].external and {it[4], it[5]} == {last[4], last[5]}
                    # a junction, or a doorway between the same two rooms where their
                    # footprints reach into the wall (the wall goes on through it)
                    reach = prm.doorway_bridge if same_rooms else prm.max_thickness
                    if (it[3].external == last[3].external
                            and abs(it[3].thickness - _thick(ch)) <= prm.thickness_tolerance
                            and it[1] <= end + reach
                            and not _bridges_break(d, n, 0.5 * (it[0] + last[0]), end + 1e-3, it[1] - 1e-3,
                                                   breaks)):
                        ch.append(it)
                        break
                else:
                    chains.append([it])
            for ch in chains:
                runs.append(_make_run(ch, d, n, storey))
    return runs


def _without_doorway_reaches(runs: list, prm: WallRunParams) -> list:
    """The runs less the interior ones between two rooms that lie within another run between
    the same rooms (parallel within ``parallel_angle``, axis inside its thickness over at least
    half its length): where the rooms' footprints reach into their wall along a doorway, the
    piece there is thinner (or turned) beyond what one run takes, and made a second run over
    the same stretch (hexagon_hall: two runs for one slanted wall, its door found twice)."""
    cos_par = math.cos(prm.parallel_angle)
    rooms = [{frozenset(s[2:]) for s in r.spans} for r in runs]  # once per run, not per pair
    t = np.linspace(0.0, 1.0, 21)[:, None]  # points along a run's axis
    kept = []
    for k in sorted(range(len(runs)), key=lambda k: -runs[k].length):
        r = runs[k]
        inside = False
        if not r.external and len(rooms[k]) == 1:
            for q in kept:
                o = runs[q]
                if o.external or rooms[q] != rooms[k] or abs(float(o.direction @ r.direction)) < cos_par:
                    continue
                d, n = o.direction, np.array([-o.direction[1], o.direction[0]])
                pts = r.a[None] + (r.b - r.a)[None] * t - o.a[None]
                u, v = pts @ d, pts @ n
                if np.mean((u >= 0) & (u <= o.length) & (np.abs(v) <= o.thickness / 2)) >= 0.5:
                    inside = True
                    break
        if not inside:
            kept.append(k)
    return [runs[k] for k in sorted(kept)]


def _thick(chain) -> float:
    w = np.array([x[2] - x[1] for x in chain])
    t = np.array([x[3].thickness for x in chain])
    return float(np.average(t, weights=np.maximum(w, 1e-9)))


def _make_run(chain, d, n, storey) -> WallRun:
    w = np.array([x[2] - x[1] for x in chain])
    c = float(np.average([x[0] for x in chain], weights=np.maximum(w, 1e-9)))
    u0, u1 = min(x[1] for x in chain), max(x[2] for x in chain)
    a, b = d * u0 + n * c, d * u1 + n * c
    spans = [(x[1] - u0, x[2] - u0, x[4], x[5]) for x in chain]
    return WallRun(storey, a, b, _thick(chain), bool(chain[0][3].external),
                   all(x[3].measured for x in chain), spans)


def _cross(a, b) -> float:
    return float(a[0] * b[1] - a[1] * b[0])


def _join(runs: list, prm: WallRunParams) -> None:
    """Meet run ends at the crossing of their axes; record the joins (in place)."""
    sin_min = math.sin(prm.min_join_angle)
    reach = prm.max_thickness
    ends = {}  # (run, end) -> new point
    joins = {}  # (run, end) -> (other run, where on it, axes' crossing)
    if not runs:
        return
    tree = STRtree([LineString([r.a, r.b]) for r in runs])
    for i, r in enumerate(runs):
        for e in (0, 1):
            E = r.a if e == 0 else r.b
            out = -r.direction if e == 0 else r.direction
            best = None
            near = tree.query(Point(E), predicate="dwithin", distance=2 * reach)
            for j in sorted(int(x) for x in near):
                s = runs[j]
                if j == i:
                    continue
                dj = s.direction
                den = _cross(out, dj)
                if abs(den) < sin_min:
                    continue
                # E + out * t = s.a + dj * v
                w = s.a - E
                t = _cross(w, dj) / den
                v = _cross(w, out) / den
                if abs(t) > reach or v < -reach or v > s.length + reach:
                    continue
                if best is None or abs(t) < abs(best[1]):
                    best = (j, t, v)
            if best is None:
                continue
            j, t, v = best
            s = runs[j]
            at_j = "ATSTART" if v <= reach and v < s.length / 2 else (
                "ATEND" if v >= s.length - reach else "ATPATH")
            joins[(i, e)] = (j, at_j, E + out * t)
    # a corner when both ends pick each other (the lower index goes through), else the end
    # stops at the other run's face (a T, or an end meeting a run that continues)
    at_name = ("ATSTART", "ATEND")
    for (i, e), (j, at_j, X) in sorted(joins.items()):
        r, s = runs[i], runs[j]
        out = -r.direction if e == 0 else r.direction
        ej = {"ATSTART": 0, "ATEND": 1}.get(at_j)
        mutual = ej is not None and joins.get((j, ej), (None,))[0] == i
        if not mutual:
            ends[(i, e)] = X - out * s.thickness / 2
            r.joins.append((j, at_name[e], at_j))
            continue
        if i > j:
            continue  # done from the other end
        out_j = -s.direction if ej == 0 else s.direction
        ends[(i, e)] = X + out * s.thickness / 2
        ends[(j, ej)] = X - out_j * r.thickness / 2
        r.joins.append((j, at_name[e], at_j))
    for (i, e), X in ends.items():
        r = runs[i]
        old_a = r.a.copy()
        if e == 0:
            r.a = X
        else:
            r.b = X
        if e == 0:  # spans are measured from a
            shift = float(r.direction @ (old_a - r.a))
            r.spans = [(u0 + shift, u1 + shift, lft, rgt) for u0, u1, lft, rgt in r.spans]


def wall_runs(footprints: dict, storey: int, prm: WallRunParams = WallRunParams(), measured=None, breaks=(),
              solid=None, faces=None):
    """Wall runs of one storey from its spaces' footprints (``{space id: shapely geometry}``);
    ``measured``: [(shapely region, thickness m)] of exterior walls measured in the scan;
    ``breaks``: [shapely region] where an interior wall is interrupted (a gap from floor to
    ceiling seen in the scan): the wall stops there and the two spaces meet without one;
    ``solid(region) -> bool``: whether the scan holds (almost) no points in a plan region,
    so that rooms up to ``max_solid_thickness`` apart have a thick wall between them (else a
    wall along each of their faces, the gap a void inside the building);
    ``faces(p, q, n) -> (offset, thickness) | None``: a wall seen in the scan where two spaces
    touch along p–q (their split cut through a wall: it stays a wall).

    Returns ``(runs, open_pairs)``: the runs (joined, ends met) and the pairs of spaces that
    meet without a wall.
    """
    pieces, open_pairs = _pieces(footprints, prm, measured, breaks, solid, faces)
    runs = [r for r in _runs_of(pieces, storey, prm, breaks) if r.length >= prm.min_length]
    runs = _without_doorway_reaches(runs, prm)
    _join(runs, prm)
    # meeting ends can shorten a run below the minimum: drop it, and the joins to it
    keep = [i for i, r in enumerate(runs) if r.length >= prm.min_length]
    new_index = {old: new for new, old in enumerate(keep)}
    out = [runs[i] for i in keep]
    for r in out:
        r.joins = [(new_index[j], at, other) for j, at, other in r.joins if j in new_index]
    return out, open_pairs

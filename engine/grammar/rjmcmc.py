"""Reversible-jump MCMC search for the interior spaces (docs/method.md §3.3, thesis Ch. 4.4).

The model M is a set of interior spaces, each a union of cells of a :class:`~.coverage.CellSet`.
The search maximises ``P(M | D) ∝ P(M) · P_L · P_G`` by Metropolis–Hastings with the four
reversible jumps of the thesis:

* **add** — an untyped cell adjacent to no interior space becomes a space;
* **remove** — an interior space adjacent to no other interior space loses its type;
* **add–merge** — an untyped cell becomes interior and merges with *all* its adjacent spaces;
* **split–remove** — the inverse: a cell of a space loses its type, the rest of the space
  splits into its connected parts.

Since add–merge joins every adjacent space, two spaces never share a face: the adjacency and
merge rules are applied as part of each move (that is the "topology rules fire after every
accepted move" of docs/method.md §3.3; the wall/door relations are derived once after the search).

Score (log domain)::

    log P(M|D) = log P(M) + Σ_i log(Cov(M_i.top) / |M_i.top|)
                 + log(k1·ΣCov(top)/Cov(h) + k2·ΣCov(vert)/Cov(v) + k3·(1 − ΣCov(in)/(Cov(h)+Cov(v))))

with ``P(M) = 0`` when a space is not wider than the maximum wall thickness (or smaller than
``RjmcmcParams.min_space_area``). Every term is a
sum over spaces of sums over their cells and faces, all measured once
(:func:`~.coverage.measure_coverage`); a move changes one to a few spaces, so a proposal is
scored in O(cells it touches) — the speed-up over the thesis's full re-score, which
:func:`naive_log_posterior` reproduces for the benchmark and the tests.

Kernel (MDL): ``C(M) = log2 n`` (1 for n ≤ 1), ``J(M'|M) = μ·C(M)/C(M')``; acceptance
``α = min(1, P(M')J(M'|M) / (P(M)J(M|M')))``, accepted when ``α > U``, ``U ~ U[β, 1]``.
The best model seen is kept.

Departures from the thesis (docs/method.md §3.3):

* The prior has a second condition (``RjmcmcParams.connected_cover``): the cells of a
  space that lie under the ceiling (coverage ratio ≥ ``cover_ratio``) must be connected
  through shared faces at least ``link_length`` long that are not seen walls, i.e. a space
  is one region under one ceiling, and it needs at least one such cell. Without it the
  product of per-space coverage ratios in ``P_L`` (each a little below 1 on real data)
  rewards gluing neighbouring rooms together through the small uncovered cells where walls
  meet (or through a wall cell), which the scope width alone (one oriented box per space)
  cannot see. Uncovered cells may still join a space at its edge; the likelihood decides.
* The moves see a cell as adjacent to a space only through faces that are no seen wall
  (``RjmcmcParams.walls_part``): two spaces may meet across a seen wall. A sparse scan may
  see the wall between two rooms from one side only, one line with no wall cell between
  them; a room beyond it could then neither start (*add*) nor join the first.
* ``P_vert`` credits a boundary face to a space only where the space's cell on that face
  is covered: a wall is seen from under the room's ceiling. Otherwise taking in the wall
  cell between two rooms lets one room claim the other room's wall surface.
* ``P_L`` weights each space's log coverage ratio by its share of the covered ceiling
  area (``RjmcmcParams.area_weighted_local``). The plain product charges every room the
  same factor (its ratio, a little below 1 on real scans) while the global gain of a room
  shrinks with the building's size, so in a large building the product leaves rooms out.
  Weighted, a badly covered space still costs a lot, a good room costs little. The
  weight's denominator is a constant of the data, so the score stays a sum of per-space
  terms (incremental).
* After the search, untyped covered cells next to exactly one space join it
  (``RjmcmcParams.absorb_covered``): ``P_L`` multiplies coverage *ratios*, so a partly
  occluded cell at a room's edge lowers the score although it lies under the room's
  ceiling; the returned ``log_posterior`` is that of the final model. A cell walled in by
  seen walls except towards one space joins it with less ceiling coverage
  (``walled_in_ratio``): at the far end of a corridor the ceiling is sampled sparsely and
  its alpha shape covers only part of a corner cell, yet the cell cannot be exterior —
  nothing but the room reaches it.
* The chain starts from a greedy best-improvement ascent from the empty model
  (``RjmcmcParams.greedy_start``), and after the chain, a greedy *polish* applies the best
  strictly improving move until none improves (``RjmcmcParams.polish``). The posterior is
  flat enough (a missing room costs little) that the plain chain often ends one cell or
  one small room short of its optimum; the polish makes the result independent of the
  seed. Set ``polish=False`` for the thesis's procedure.
"""
from __future__ import annotations

import logging
import math
import time
from dataclasses import asdict, dataclass
from typing import NamedTuple, Optional, Sequence

import numpy as np

from ..errors import InputError
from ..model import Scope
from ..progress import Progress
from .params import CoverageParams, RjmcmcParams
from .coverage import (CellCoverage, CellSet, _face_band, adaptive_alpha, alpha_area, alpha_geometry,
                       cell_heights, thin_points)

__all__ = ["RjmcmcParams", "SearchResult", "SpaceSearch", "search_spaces", "naive_log_posterior",
           "MOVES", "mdl_cost"]

log = logging.getLogger(__name__)

MOVES = ("add", "remove", "add_merge", "split_remove")
"""The four transition types, in the order of the trace's counters."""


class SpaceTerms(NamedTuple):
    """A space's contributions to the posterior: ceiling coverage of its cells (m²), seen wall
    faces around it, coverage inside it, its local log ratio, and whether the prior holds."""

    top: float
    vert: float
    inside: float
    log_ratio: float
    prior_ok: bool


def mdl_cost(n: int) -> float:
    """C(M) = log2 n for n > 1 spaces, else 1."""
    return math.log2(n) if n > 1 else 1.0


@dataclass(frozen=True)
class SearchResult:
    """Outcome of :func:`search_spaces`.

    Attributes
    ----------
    spaces : tuple of tuple of int — cells of every interior space of the best model.
    log_posterior : float — its log P(M | D) (up to the constant).
    iterations : int
    acceptance_rate : float — accepted / valid proposals.
    trace : dict — ``iteration``, ``score``, ``spaces`` lists, per-move ``proposed``,
        ``accepted``, the best score's iteration, seconds spent.
    """

    spaces: tuple
    log_posterior: float
    iterations: int
    acceptance_rate: float
    trace: dict


class SpaceSearch:
    """The search state with incremental scoring.

    Parameters
    ----------
    cells : CellSet
    coverage : CellCoverage
    params : RjmcmcParams
    """

    def __init__(self, cells: CellSet, coverage: CellCoverage, params: RjmcmcParams = RjmcmcParams()):
        self.cells, self.cov, self.params = cells, coverage, params
        n = len(cells)
        self.n = n
        self.nbrs = [[o for o, _ in lst] for lst in cells.neighbours()]
        self.cfaces = cells.cell_faces()
        self.face_ab = np.array([(f.a, f.b) for f in cells.faces], dtype=np.int64).reshape(-1, 2)
        self.verts = [np.asarray(p.exterior.coords)[:-1, :2] for p in cells.polygons]
        self.H = max(coverage.total_horizontal, 1e-12)
        self.V = max(coverage.total_vertical, 1e-12)
        self._width_cache: dict = {}
        self._terms_cache: dict = {}
        self.covered = coverage.top >= params.cover_ratio * np.maximum(coverage.area, 1e-12)
        # covered cells link through faces longer than a wall is thick: a scrap of a wall
        # cell (short faces, too few wall points to block the ceiling's alpha shape) must
        # not join two rooms
        # nor link through a face seen as a wall: where two walls cross, the cell of their
        # crossing is as long as the wall is thick and half under the ceiling of the room
        # whose wall face there is too short to be seen
        seen = coverage.seen if coverage.seen is not None else np.zeros(len(cells.faces), bool)
        self.long_nbrs = [[o for o, fi in lst if cells.faces[fi].length >= params.link_length
                           and not seen[fi]] for lst in cells.neighbours()]
        # the neighbours the moves join: through faces that are no seen wall (walls_part)
        self.open_nbrs = [[o for o, fi in lst if not (params.walls_part and seen[fi])]
                          for lst in cells.neighbours()]
        # a covered cell with no such face (a scrap where wall lines cross, walled off) can
        # link nothing, so it glues nothing: the connectivity test passes over it
        self.linkable = self.covered & np.array([bool(x) for x in self.long_nbrs], dtype=bool)
        self.space_of = np.full(n, -1, dtype=np.int64)
        self.spaces: dict[int, frozenset] = {}
        self.stats: dict[int, SpaceTerms] = {}
        self._next = 0
        self.sum_top = self.sum_vert = self.sum_in = self.sum_log = 0.0
        self.n_bad = 0

    # ------------------------------------------------------------------ terms
    def space_terms(self, S: frozenset) -> SpaceTerms:
        """The terms of a space made of the cells ``S`` (cached per cell set)."""
        hit = self._terms_cache.get(S)
        if hit is not None:
            return hit
        out = self._space_terms(S)
        if len(self._terms_cache) < 500_000:
            self._terms_cache[S] = out
        return out

    def _space_terms(self, S: frozenset) -> SpaceTerms:
        cov = self.cov
        idx = np.fromiter(S, dtype=np.int64, count=len(S))
        top = float(cov.top[idx].sum())
        area = float(cov.area[idx].sum())
        vert = 0.0
        inside = float(cov.inside[idx].sum())
        for c in S:
            for fi in self.cfaces[c]:
                a, b = self.face_ab[fi]
                other = b if a == c else a
                if other >= 0 and other in S:
                    if c < other:  # internal face, once
                        inside += cov.face[fi]
                elif self.covered[c]:  # a wall seen from under this space's ceiling
                    vert += cov.face[fi]
        ratio = max(top / area if area > 0 else 0.0, self.params.min_ratio)
        ok = area >= self.params.min_space_area and self._wide(S) and \
            (not self.params.connected_cover or self._cover_connected(S))
        lg = math.log(ratio)
        if self.params.area_weighted_local:
            lg *= area / self.H
        return SpaceTerms(top, vert, inside, lg, bool(ok))

    def _cover_connected(self, S: frozenset) -> bool:
        cov = [c for c in S if self.linkable[c]]
        if len(cov) <= 1:
            return bool(cov) or any(self.covered[c] for c in S)
        left = set(cov)
        stack = [left.pop()]
        while stack:
            c = stack.pop()
            for o in self.long_nbrs[c]:
                if o in left:
                    left.discard(o)
                    stack.append(o)
        return not left

    def _wide(self, S: frozenset) -> bool:
        w = self._width_cache.get(S)
        if w is None:
            v = np.vstack([self.verts[c] for c in S])
            w = Scope.of_points(np.column_stack([v, np.zeros(len(v))])).width
            if len(self._width_cache) < 200_000:
                self._width_cache[S] = w
        return w > self.params.max_wall_thickness

    def score_of(self, sum_top, sum_vert, sum_in, sum_log, n_bad) -> float:
        """log P(M|D) from the model's sums (−inf when the prior is 0)."""
        if n_bad:
            return -math.inf
        p = self.params
        pg = (p.k1 * sum_top / self.H + p.k2 * sum_vert / self.V
              + p.k3 * (1.0 - sum_in / (self.H + self.V)))
        return sum_log + math.log(max(pg, p.min_ratio))

    @property
    def score(self) -> float:
        """log P(M | D) of the current model (up to the constant; −inf when the prior is 0)."""
        return self.score_of(self.sum_top, self.sum_vert, self.sum_in, self.sum_log, self.n_bad)

    # ------------------------------------------------------------------ moves
    def evaluate(self, remove: Sequence[int], add: Sequence[frozenset]):
        """Score of the model with spaces ``remove`` dropped and cell sets ``add`` added.

        Returns (log score, new space count, terms of the added sets)."""
        st, sv, si, sl, nb = self.sum_top, self.sum_vert, self.sum_in, self.sum_log, self.n_bad
        for sid in remove:
            t, v, i, lg, ok = self.stats[sid]
            st, sv, si, sl, nb = st - t, sv - v, si - i, sl - lg, nb - (not ok)
        terms = []
        for S in add:
            tt = self.space_terms(S)
            terms.append(tt)
            t, v, i, lg, ok = tt
            st, sv, si, sl, nb = st + t, sv + v, si + i, sl + lg, nb + (not ok)
        return self.score_of(st, sv, si, sl, nb), len(self.spaces) - len(remove) + len(add), terms

    def apply(self, remove: Sequence[int], add: Sequence[frozenset], terms=None) -> None:
        """Make the move: drop spaces ``remove``, add cell sets ``add``."""
        for sid in remove:
            t, v, i, lg, ok = self.stats.pop(sid)
            self.sum_top -= t
            self.sum_vert -= v
            self.sum_in -= i
            self.sum_log -= lg
            self.n_bad -= (not ok)
            for c in self.spaces.pop(sid):
                self.space_of[c] = -1
        for k, S in enumerate(add):
            tt = terms[k] if terms is not None else self.space_terms(S)
            sid = self._next
            self._next += 1
            self.spaces[sid] = S
            self.stats[sid] = tt
            t, v, i, lg, ok = tt
            self.sum_top += t
            self.sum_vert += v
            self.sum_in += i
            self.sum_log += lg
            self.n_bad += (not ok)
            for c in S:
                self.space_of[c] = sid
        # floating-point drift of the running sums is negligible (sums of tens of terms)

    def adjacent_spaces(self, c: int) -> set:
        """Ids of the spaces holding a cell that shares a face with cell ``c`` (with
        ``walls_part``, a face that is no seen wall)."""
        return {int(self.space_of[o]) for o in self.open_nbrs[c] if self.space_of[o] >= 0}

    def components(self, S: set) -> list[frozenset]:
        """Connected parts of a cell set (through shared faces)."""
        left, out = set(S), []
        while left:
            seed = left.pop()
            comp, stack = {seed}, [seed]
            while stack:
                c = stack.pop()
                for o in self.nbrs[c]:
                    if o in left:
                        left.discard(o)
                        comp.add(o)
                        stack.append(o)
            out.append(frozenset(comp))
        return out

    def move_add(self, c: int):
        """*add* untyped cell ``c`` adjacent to no space: ``(remove, add)`` for :meth:`evaluate`, or None."""
        if self.space_of[c] >= 0 or self.adjacent_spaces(c):
            return None
        return [], [frozenset((c,))]

    def move_add_merge(self, c: int):
        """*add–merge*: untyped cell ``c`` and all its adjacent spaces become one space, or None."""
        if self.space_of[c] >= 0:
            return None
        adj = self.adjacent_spaces(c)
        if not adj:
            return None
        S = {c}
        for sid in adj:
            S |= self.spaces[sid]
        return sorted(adj), [frozenset(S)]

    def move_remove(self, sid: int):
        """*remove* space ``sid`` when no other space is adjacent to it, or None."""
        # spaces never share a face that is no seen wall (add-merge joins them), so every
        # space qualifies; checked anyway for models set from outside
        S = self.spaces[sid]
        for c in S:
            for o in self.open_nbrs[c]:
                if self.space_of[o] >= 0 and self.space_of[o] != sid:
                    return None
        return [sid], []

    def move_split_remove(self, sid: int, c: int):
        """*split–remove*: cell ``c`` leaves space ``sid``, the rest splits into its connected
        parts; None for a one-cell space or a cell outside it."""
        S = self.spaces[sid]
        if len(S) < 2 or c not in S:
            return None
        return [sid], self.components(set(S) - {c})

    def set_model(self, spaces: Sequence[Sequence[int]]) -> None:
        """Replace the state by the given spaces (cell index lists)."""
        self.apply(list(self.spaces), [])
        self.apply([], [frozenset(int(c) for c in s) for s in spaces if len(s)])

    def model(self) -> tuple:
        """The current spaces as a sorted tuple of sorted cell tuples."""
        return tuple(sorted(tuple(sorted(int(c) for c in S)) for S in self.spaces.values()))

    def kernel_log_ratio(self, n_old: int, n_new: int) -> float:
        """log [J(M'|M) / J(M|M')] of the MDL kernel."""
        p = self.params

        def mu(a, b):
            return p.mu_same if a == b else (p.mu_fewer_to_more if a < b else p.mu_more_to_fewer)

        return (math.log(mu(n_old, n_new)) - math.log(mu(n_new, n_old))
                + 2.0 * (math.log(mdl_cost(n_old)) - math.log(mdl_cost(n_new))))

    def hill_climb(self, should_check=None) -> int:
        """Apply the best strictly improving move until none improves; returns the count."""
        cur, moves = self.score, 0
        while True:
            if should_check is not None:
                should_check()
            top = None
            for remove, add in self.all_moves():
                s, _, terms = self.evaluate(remove, add)
                if s > cur + 1e-9 and (top is None or s > top[0]):
                    top = (s, remove, add, terms)
            if top is None:
                return moves
            self.apply(top[1], top[2], top[3])
            cur = top[0]
            moves += 1

    def walled_in(self, c: int, sid: int) -> bool:
        """Whether cell ``c`` is walled in except towards space ``sid`` — each of its other
        faces a seen wall or shared with a wall cell (untyped, within the maximum wall
        thickness of a face it shares with a space — the wall rule of docs/method.md §3.4: a wall
        seen at a grazing angle leaves too few points on a short face) — and enough of it
        lies under the ceiling (``RjmcmcParams.walled_in_ratio``). No covered cell may lie
        beyond it: a wall cell between the space and a room the search left out (a shelf
        strip against an outer wall has only walls behind it). And the space must reach it:
        through a face that is no seen wall, or under the same ceiling — its ceiling layer
        within ``walled_in_level`` of that over a cell of the space it touches (a strip behind
        a shelf's front). The strip inside an outer wall between its inner face and a window's
        glazing is neither: the wall's face stands between, and its "ceiling" is the window's
        head, 0.8 m under the room's (syn_house at 1M points took it in, and the wall's face,
        then 15 cm too far out, showed no window). A corner cell under a cupboard's top is
        reached through no wall (hexagon_hall mobile at 300k points)."""
        seen = self.cov.seen
        if seen is None or self.cov.top[c] < self.params.walled_in_ratio * max(self.cov.area[c], 1e-12):
            return False
        cz = self.cov.ceiling_z
        reached = False
        for fi in self.cfaces[c]:
            a, b = self.face_ab[fi]
            other = b if a == c else a
            if other >= 0 and self.space_of[other] == sid:
                # NaN levels compare False
                reached |= not seen[fi] or bool(abs(cz[c] - cz[other]) <= self.params.walled_in_level)
                continue
            if other >= 0 and self.covered[other]:
                return False
            if seen[fi]:
                continue
            if other < 0 or self.space_of[other] >= 0 or not self._wall_cell(other):
                return False
        return reached

    def _wall_cell(self, o: int) -> bool:
        """Whether untyped cell ``o`` is thin against a face it shares with a space."""
        d = self.cells.wall_thickness(o, self.cfaces[o], self.space_of >= 0)
        return d <= self.params.max_wall_thickness

    def _open_between(self, c: int) -> bool:
        """Whether covered untyped cell ``c`` separates its adjacent spaces by nothing: the
        ceiling is seen over it and none of its faces towards a space is a seen wall."""
        seen = self.cov.seen
        if seen is None or not self.covered[c]:
            return False
        for fi in self.cfaces[c]:
            a, b = self.face_ab[fi]
            other = b if a == c else a
            if other >= 0 and self.space_of[other] >= 0 and seen[fi]:
                return False
        return True

    def _contact(self, c: int) -> dict:
        """Space id -> the length of the faces cell ``c`` shares with that space's cells, metres."""
        length: dict = {}
        for fi in self.cfaces[c]:
            a, b = self.face_ab[fi]
            other = b if a == c else a
            if other >= 0 and self.space_of[other] >= 0:
                sid = int(self.space_of[other])
                length[sid] = length.get(sid, 0.0) + self.cells.faces[fi].length
        return length

    def _touching(self, c: int) -> set:
        """The spaces cell ``c`` shares faces with, leaving out those it touches over less than
        ``link_length`` in all (a corner's few centimetres: syn_house mobile at 1M points, a
        covered strip along a cabinet's front touched a second room over 3 cm and joined
        neither), unless it touches none longer."""
        length = self._contact(c)
        long = {sid for sid, v in length.items() if v >= self.params.link_length}
        return long or set(length)

    def _doorway(self, c: int, spaces) -> bool:
        """Whether cell ``c`` between spaces is a gap in a wall line rather than where rooms
        meet without a wall: no thicker than a wall against the spaces, and open towards one
        of them over less than ``join_open_width`` (syn_house mobile at 100k points: the
        last 30 cm of a partition before a T-junction, both its faces unseen and the
        ceiling's edges spilling over it, joined the two rooms beside it)."""
        if self.cells.wall_thickness(c, self.cfaces[c], self.space_of >= 0) > self.params.max_wall_thickness:
            return False
        contact = self._contact(c)
        return min((contact[sid] for sid in spaces), default=0.0) < self.params.join_open_width

    def _open_to(self, c: int) -> set:
        """The one space a covered untyped cell ``c`` opens to when every face it shares with
        its other adjacent spaces is a seen wall (empty otherwise): a sparse scan sees a wall
        between two rooms from one side only, as one line (no wall cell between them), and a
        strip of a room's floor cut off by that wall's line running on through the room
        touches both rooms (hexagon_hall mobile at 100k points: two 8-10 m² strips of the
        hall, its ceiling seen over 97-99 % of them, stayed outside)."""
        seen = self.cov.seen
        if seen is None or not self.covered[c]:
            return set()
        open_, walled = set(), set()
        for fi in self.cfaces[c]:
            a, b = self.face_ab[fi]
            other = b if a == c else a
            if other < 0 or self.space_of[other] < 0:
                continue
            (walled if seen[fi] else open_).add(int(self.space_of[other]))
        return open_ if len(open_) == 1 and not (open_ & walled) else set()

    def absorb_covered(self) -> int:
        """Add every untyped cell adjacent to exactly one space to it when it is covered or
        walled in and the grown space still satisfies the prior (a covered cell beyond a
        seen wall face stays out); join the spaces on both sides of a covered cell with no
        seen wall towards any of them (rooms meeting without a wall are one space: the
        posterior can tie on a strip split off by a wall line running on through a room)
        — repeatedly. Returns the number of cells added."""
        added, changed = 0, True
        while changed:
            changed = False
            for c in range(self.n):
                if self.space_of[c] >= 0:
                    continue
                adj = self._touching(c)
                if len(adj) > 1 and self.params.join_open and self._open_between(c):
                    if self._doorway(c, adj):
                        continue
                    remove = sorted(adj)
                    add = [frozenset({c}.union(*(self.spaces[sid] for sid in remove)))]
                    if self.space_terms(add[0]).prior_ok:
                        self.apply(remove, add)
                        added += 1
                        changed = True
                    continue
                if len(adj) > 1:
                    adj = self._open_to(c)  # one space it is open to, seen walls to the others
                if len(adj) != 1:
                    continue
                sid = adj.pop()
                if not (self.covered[c] or self.walled_in(c, sid)):
                    continue
                grown = self.spaces[sid] | {c}
                if self.stats[sid].prior_ok and not self.space_terms(grown).prior_ok:
                    continue
                self.apply([sid], [grown])
                added += 1
                changed = True
        return added

    def fill_corners(self) -> int:
        """Complete each space into the corners behind its furniture (``corner_area``,
        :func:`.corners.fill_corners`); returns the number of cells added."""
        from .corners import fill_corners

        return fill_corners(self)

    def all_moves(self):
        """Every applicable move of the current state (for the greedy polish)."""
        for c in range(self.n):
            if self.space_of[c] < 0:
                m = self.move_add(c) or self.move_add_merge(c)
                if m:
                    yield m
        for sid in list(self.spaces):
            m = self.move_remove(sid)
            if m:
                yield m
            if len(self.spaces[sid]) > 1:
                for c in self.spaces[sid]:
                    yield self.move_split_remove(sid, c)


def search_spaces(cells: CellSet, coverage: CellCoverage, params: RjmcmcParams = RjmcmcParams(), *,
                  rng=None, initial: Optional[Sequence[Sequence[int]]] = None,
                  progress=None, should_stop=None) -> SearchResult:
    """Run the rjMCMC search on one cell complex.

    Parameters
    ----------
    cells : CellSet — the cells of one storey.
    coverage : CellCoverage — from :func:`~.coverage.measure_coverage` on the same cells.
    params : RjmcmcParams
    rng : numpy Generator, int or None — same seed, same result.
    initial : optional starting spaces (cell index lists); default: the empty model.
    progress, should_stop : see :class:`engine.progress.Progress`.

    Returns
    -------
    SearchResult — the best model seen (after the polish when enabled).

    Raises
    ------
    InputError
        ``coverage`` does not belong to ``cells``.
    """
    rng = np.random.default_rng(rng)
    p = Progress.wrap(progress, should_stop)
    if len(coverage.area) != len(cells) or len(coverage.face) != len(cells.faces):
        raise InputError("the coverage figures do not match the cell complex (cells or faces differ)")
    t0 = time.perf_counter()
    st = SpaceSearch(cells, coverage, params)
    if initial:
        st.set_model(initial)
    greedy_moves = 0
    if params.greedy_start:
        p(0.0, "rjMCMC greedy start")
        greedy_moves = st.hill_climb(p.check)
    n_iter = params.iterations or max(params.min_iterations, params.iterations_per_cell * len(cells))
    score = st.score
    best, best_score, best_it = st.model(), score, 0
    proposed = dict.fromkeys(MOVES, 0)
    accepted = dict.fromkeys(MOVES, 0)
    tr_it, tr_score, tr_n = [], [], []
    n = len(cells)
    for it in range(n_iter):
        if it % 512 == 0:
            p(0.9 * it / n_iter, "rjMCMC search")
            p.check()
        kind = MOVES[int(rng.integers(4))]
        move = None
        if n:
            if kind in ("add", "add_merge"):
                c = int(rng.integers(n))
                move = st.move_add(c) if kind == "add" else st.move_add_merge(c)
            elif st.spaces:
                keys = list(st.spaces)
                sid = keys[int(rng.integers(len(keys)))]
                if kind == "remove":
                    move = st.move_remove(sid)
                else:
                    S = sorted(st.spaces[sid])
                    move = st.move_split_remove(sid, S[int(rng.integers(len(S)))])
        u = rng.uniform(params.beta, 1.0)
        if move is not None:
            proposed[kind] += 1
            remove, add = move
            new_score, n_new, terms = st.evaluate(remove, add)
            if math.isfinite(new_score):
                log_a = new_score - score + st.kernel_log_ratio(len(st.spaces), n_new) \
                    if math.isfinite(score) else math.inf
                alpha = 1.0 if log_a >= 0 else math.exp(log_a)
                if alpha > u or (alpha >= 1.0 and u >= 1.0):
                    st.apply(remove, add, terms)
                    score = new_score
                    accepted[kind] += 1
                    if score > best_score + 1e-12:
                        best, best_score, best_it = st.model(), score, it
        if params.trace_every and it % params.trace_every == 0:
            tr_it.append(it)
            tr_score.append(score)
            tr_n.append(len(st.spaces))
    polish_moves = 0
    if params.polish:
        p(0.9, "rjMCMC polish")
        st.set_model(best)
        polish_moves = st.hill_climb(p.check)
        cur = st.score
        if cur > best_score + 1e-12:
            best, best_score = st.model(), cur
    absorbed = 0
    if params.absorb_covered and best:
        st.set_model(best)
        absorbed = st.absorb_covered()
        absorbed += st.fill_corners()
        if absorbed:
            best, best_score = st.model(), st.score
    n_prop = sum(proposed.values())
    n_acc = sum(accepted.values())
    rate = n_acc / n_prop if n_prop else 0.0
    seconds = time.perf_counter() - t0
    trace = {"iteration": tr_it, "score": tr_score, "spaces": tr_n, "proposed": proposed,
             "accepted": accepted, "best_iteration": best_it, "polish_moves": polish_moves,
             "greedy_moves": greedy_moves, "absorbed_cells": absorbed,
             "seconds": seconds, "cells": n, "parameters": asdict(params)}
    log.info("rjMCMC: %d cells, %d iterations, acceptance %.2f, %d spaces, log P = %.4f (%.2f s)",
             n, n_iter, rate, len(best), best_score, seconds)
    p(1.0, "rjMCMC done")
    return SearchResult(spaces=best, log_posterior=float(best_score), iterations=n_iter,
                        acceptance_rate=float(rate), trace=trace)


def naive_log_posterior(spaces: Sequence[Sequence[int]], cells: CellSet, xyz_wall: np.ndarray,
                        xyz_horizontal: np.ndarray, params: RjmcmcParams = RjmcmcParams(),
                        coverage: CoverageParams = CoverageParams()) -> float:
    """The thesis's full re-score of a model from the points (reference for tests/benchmark).

    Every call thins the points, builds the alpha shapes of all ceiling points and of every
    space's ceiling and side faces, and counts the points inside every space — what one
    rjMCMC iteration costs without the cached, incremental terms of :class:`SpaceSearch`.

    Parameters
    ----------
    spaces : cell index lists of the interior spaces.
    cells : CellSet
    xyz_wall, xyz_horizontal : (n, 3) / (m, 3) float64 — wall and floor/ceiling points, metres.
    params : RjmcmcParams
    coverage : CoverageParams, as for :func:`~.coverage.measure_coverage`.

    Returns
    -------
    float — log P(M | D), −inf when the prior is 0.
    """
    import shapely

    shape_buffer, r_alpha, thin = coverage.shape_buffer, coverage.r_alpha, coverage.coverage_grid
    min_wall_coverage, wall_band = coverage.min_wall_coverage, coverage.wall_band
    alpha_spacing_factor, r_alpha_max = coverage.alpha_spacing_factor, coverage.r_alpha_max
    hw = thin_points(np.asarray(xyz_horizontal, float).reshape(-1, 3), thin)
    vw = thin_points(np.asarray(xyz_wall, float).reshape(-1, 3), thin)
    r_alpha = adaptive_alpha(hw[:, :2], r_alpha, alpha_spacing_factor)
    zr = cells.z_range
    _, upper, ceiling_z, _ = cell_heights(cells, hw)
    ceil = hw[upper]
    # all faces' wall coverage, one by one from the points
    fcov, bands = [], []
    for f in cells.faces:
        z0, z1 = _face_band(f, zr, ceiling_z, wall_band)
        bands.append(z1 - z0)
        fcov.append(sum(_face_cov(vw, a, b, z0, z1, shape_buffer, r_alpha) for a, b in f.segments))
    V = float(sum(fcov))
    blockers = [s for fi, f in enumerate(cells.faces) if fcov[fi] >= min_wall_coverage * f.length * bands[fi]
                for s in f.segments]
    geom_h = alpha_geometry(ceil[:, :2], r_alpha, blockers=blockers, snap=shape_buffer,
                            local_factor=alpha_spacing_factor, r_max=r_alpha_max)
    H = geom_h.area
    polys = np.array(cells.polygons, dtype=object)
    cell_top = shapely.area(shapely.intersection(geom_h, polys)) if not geom_h.is_empty else np.zeros(len(polys))
    covered = cell_top >= params.cover_ratio * shapely.area(polys)
    H, V = max(H, 1e-12), max(V, 1e-12)
    s_top = s_vert = s_in = s_log = 0.0
    for sp in spaces:
        poly = cells.union(sp)
        z0, z1 = zr[list(sp)][:, 0].min(), zr[list(sp)][:, 1].max()
        v = np.asarray(poly.exterior.coords)[:-1] if poly.geom_type == "Polygon" else \
            np.vstack([np.asarray(g.exterior.coords)[:-1] for g in poly.geoms])
        if Scope.of_points(np.column_stack([v, np.zeros(len(v))])).width <= params.max_wall_thickness \
                or poly.area < params.min_space_area:
            return -math.inf
        top = float(shapely.intersection(geom_h, poly).area) if not geom_h.is_empty else 0.0
        s_top += top
        lg = math.log(max(top / poly.area, params.min_ratio))
        s_log += lg * poly.area / H if params.area_weighted_local else lg
        spc = set(sp)
        for fi, f in enumerate(cells.faces):  # the space's boundary faces, from the points
            mine = f.a if f.a in spc else f.b
            if (f.a in spc) != (f.b in spc) and covered[mine]:
                bz0, bz1 = _face_band(f, zr, ceiling_z, wall_band)
                s_vert += sum(_face_cov(vw, a, b, bz0, bz1, shape_buffer, r_alpha) for a, b in f.segments)
        inner = poly.buffer(-shape_buffer, join_style="mitre")
        allp = np.vstack([vw, hw])
        mm = shapely.contains_xy(inner, allp[:, 0], allp[:, 1]) & (allp[:, 2] > z0 + shape_buffer) \
            & (allp[:, 2] < z1 - shape_buffer)
        s_in += len(np.unique(np.floor(allp[mm] / thin).astype(np.int64), axis=0)) * thin * thin
    pg = params.k1 * s_top / H + params.k2 * s_vert / V + params.k3 * (1 - s_in / (H + V))
    return s_log + math.log(max(pg, params.min_ratio))


def _face_cov(vw, a, b, z0, z1, delta, r_alpha) -> float:
    a, b = np.asarray(a, float)[:2], np.asarray(b, float)[:2]
    d = b - a
    L = float(np.linalg.norm(d))
    if L <= 0 or len(vw) == 0:
        return 0.0
    u = d / L
    rel = vw[:, :2] - a
    t = rel @ u
    dist = np.abs(rel @ np.array([-u[1], u[0]]))
    sel = (dist <= delta) & (t >= 0) & (t <= L) & (vw[:, 2] >= z0) & (vw[:, 2] <= z1)
    if sel.sum() < 3:
        return 0.0
    return alpha_area(np.column_stack([t[sel], vw[sel, 2]]), r_alpha, clip=((0.0, z0), (L, z1)))

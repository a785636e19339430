"""Corners behind furniture join their room after the rjMCMC search (docs/method.md §3.3).

A helper of :class:`engine.grammar.rjmcmc.SpaceSearch` (``fill_corners``): the search's cells,
coverage, spaces and moves (``st``) are read and changed in place through its methods."""
from __future__ import annotations

import numpy as np

__all__ = ["fill_corners"]


def _wall_lines(st, sid: int) -> np.ndarray:
    """(k, 3) lines ``(nx, ny, ρ)`` of the seen wall faces bounding space ``sid``, the normal
    pointing out of the space (the side of the face's cell in it: ``n · x < ρ``)."""
    seen, S, rows = st.cov.seen, st.spaces[sid], []
    for c in S:
        inner = st.verts[c].mean(axis=0)  # cells are convex: inside
        for fi in st.cfaces[c]:
            a, b = st.face_ab[fi]
            if seen[fi] and not (a in S and b in S):
                for p, q in st.cells.faces[fi].segments:
                    d = q - p
                    L = float(np.hypot(*d))
                    if L > 0.02:  # not a corner's degenerate piece: its direction is noise
                        n = np.array([-d[1], d[0]]) / L
                        n = n if n @ inner < n @ p else -n
                        rows.append((n[0], n[1], float(n @ p)))
    return np.array(rows, dtype=np.float64).reshape(-1, 3)


def _room_lines(st, sid: int, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_wall_lines` of space ``sid`` and (k,) bool which of them have the whole space
    on their side (within ``tol`` m): its walls, not a cupboard's front beside it."""
    lines = _wall_lines(st, sid)
    v = np.vstack([st.verts[c] for c in st.spaces[sid]])
    return lines, np.all(v @ lines[:, :2].T <= lines[:, 2] + tol, axis=0)


def _on(st, fi: int, lines: np.ndarray, tol: float = 0.02) -> np.ndarray:
    """(k,) bool: which of ``lines`` every (non-degenerate) segment of face ``fi`` lies on
    (within ``tol`` m)."""
    out = None
    for p, q in st.cells.faces[fi].segments:
        if float(np.hypot(*(q - p))) <= tol:
            continue
        on = (np.abs(lines[:, :2] @ p - lines[:, 2]) <= tol) & (np.abs(lines[:, :2] @ q - lines[:, 2]) <= tol)
        out = on if out is None else out & on
    return np.zeros(len(lines), bool) if out is None else out


def fill_corners(st, tol: float = 0.05) -> int:
    """Complete each space into the corners behind its furniture (``corner_area``); returns
    the number of cells added.

    A tall cupboard in a room's corner hides the ceiling and the two walls there; the lines of
    other walls (a hexagonal hall's, running on through a side room) then cut the corner off,
    and the room's outline ran along them (hexagon_hall mobile: a chamfer across a 0.4 m
    corner, a false window in it). A group of untyped, uncovered cells reached from a space
    through faces that are no seen wall and closed off by the lines of the space's own seen
    walls alone — no covered cell, no other space, not the storey's edge; each of those lines
    with the space and the group on one side of it (``tol`` m), as a room's walls are — and
    at most ``corner_area`` in all joins the space. A room's notch (an L's) is reached through
    a seen wall; beyond a room's wall, the group lies on the line's other side."""
    limit = st.params.corner_area
    if limit <= 0 or st.cov.seen is None:
        return 0
    seen, added = st.cov.seen, 0
    for sid in sorted(st.spaces):
        lines, walls = _room_lines(st, sid, tol)
        done = set()
        if not len(lines):
            continue
        for c0 in sorted({o for c in st.spaces[sid] for o in st.nbrs[c]}):
            if c0 in done or st.space_of[c0] >= 0 or st.covered[c0]:
                continue
            group, todo, area, ok, used = {c0}, [c0], 0.0, True, set()
            while todo and ok:
                c = todo.pop()
                area += float(st.cov.area[c])
                x = st.verts[c].mean(axis=0)
                for fi in st.cfaces[c]:
                    a, b = st.face_ab[fi]
                    o = b if a == c else a
                    if o in group:
                        continue
                    on = _on(st, fi, lines)
                    inner = lines[:, :2] @ x < lines[:, 2]
                    if o >= 0 and st.space_of[o] == sid:
                        # a seen wall towards the room (an L's notch), or beyond one of its walls
                        ok &= not seen[fi] and not np.any(on & walls & ~inner)
                        continue
                    if np.any(on & inner):  # closed off by the line of one of the room's walls
                        used.update(np.flatnonzero(on & inner).tolist())
                        continue
                    if o < 0 or st.space_of[o] >= 0 or st.covered[o]:
                        ok = False
                    else:
                        group.add(o)
                        todo.append(o)
                ok &= area <= limit
            done |= group
            if not ok or not used:
                continue
            grown = st.spaces[sid] | group
            v = np.vstack([st.verts[c] for c in grown])
            L = lines[sorted(used)]
            if np.any(v @ L[:, :2].T > L[:, 2] + tol):
                continue  # a line the room or the group crosses: no wall of the room's
            if st.stats[sid].prior_ok and not st.space_terms(grown).prior_ok:
                continue
            st.apply([sid], [grown])
            added += len(group)
            sid = int(st.space_of[c0])
            lines, walls = _room_lines(st, sid, tol)
    return added

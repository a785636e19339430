"""The generic pipeline and its rjMCMC search: time, scaling and the incremental speed-up.

Three measurements:

1. **End to end** — :func:`engine.grammar.generic.reconstruct_generic` on the ``syn_house``
   synthetic terrestrial scan at 1M points (200k with ``--quick``): wall-clock per step
   (targets: ≤ 30 s in all, of which the rjMCMC ≤ 10 s), rooms found, completeness /
   correctness / accuracy at b = 10 cm against the true model.
2. **Incremental vs full re-score** — on the same cells: seconds per proposal scored by
   :class:`engine.grammar.rjmcmc.SpaceSearch` (cached cell/face coverage, only the spaces a
   move touches) against :func:`engine.grammar.rjmcmc.naive_log_posterior` (the thesis's
   re-computation from the points), and the speed-up.
3. **Scaling with the number of cells** — a rotated (non-Manhattan) grid of rooms with
   walls, cut by its wall lines into about 50, 100, 200 and 400 cells: coverage and search
   seconds, iterations, rooms found.
"""
from __future__ import annotations

import logging
import math
import time

import numpy as np

log = logging.getLogger(__name__)

TARGET_TOTAL_S = 30.0
TARGET_RJMCMC_S = 10.0
GRIDS = ((3, 3), (5, 4), (7, 6), (10, 9))
"""Rooms per row and column: (2a+1)(2b+1) cells ≈ 49, 99, 195, 399."""


def _grid_scene(nx: int, ny: int, rng, room=3.0, wall=0.2, angle=math.radians(30.0), density=200.0, h=2.7):
    """Rooms of a rotated grid: their polygons, wall lines and sampled points."""
    import shapely
    import shapely.affinity as aff

    rooms = []
    for i in range(nx):
        for j in range(ny):
            x0, y0 = i * (room + wall) + wall, j * (room + wall) + wall
            rooms.append(aff.rotate(shapely.box(x0, y0, x0 + room, y0 + room), angle, origin=(0, 0),
                                    use_radians=True))
    c, s = math.cos(angle), math.sin(angle)
    nxv, nyv = np.array([c, s]), np.array([-s, c])
    lines = []
    for i in range(nx + 1):
        for off in (i * (room + wall), i * (room + wall) + wall):
            lines.append((nxv[0], nxv[1], off))
    for j in range(ny + 1):
        for off in (j * (room + wall), j * (room + wall) + wall):
            lines.append((nyv[0], nyv[1], off))
    pts, lab = [], []
    for r in rooms:
        co = np.asarray(shapely.geometry.polygon.orient(r, 1.0).exterior.coords)
        lo, hi = np.array(r.bounds[:2]), np.array(r.bounds[2:])
        for z in (0.0, h):
            q = lo + rng.random((int(density * np.prod(hi - lo)), 2)) * (hi - lo)
            q = q[shapely.contains_xy(r, q[:, 0], q[:, 1])]
            pts.append(np.column_stack([q, np.full(len(q), z) + rng.normal(0, 0.005, len(q))]))
            lab.append(np.ones(len(q), int))
        for a, b in zip(co[:-1], co[1:]):
            k = int(density * np.linalg.norm(b - a) * h)
            t, zz = rng.random(k), rng.random(k) * h
            d = b - a
            nrm = np.array([-d[1], d[0]]) / np.linalg.norm(d)
            xy = a + t[:, None] * d + rng.normal(0, 0.005, k)[:, None] * nrm
            pts.append(np.column_stack([xy, zz]))
            lab.append(np.zeros(k, int))
    return rooms, np.array(lines), np.vstack(pts), np.concatenate(lab), h


def _scaling(quick: bool) -> list:
    import shapely

    from engine.grammar.coverage import cellset_from_polygons, measure_coverage
    from engine.grammar.params import GenericParams
    from engine.grammar.generic import arrange_cells
    from engine.grammar.rjmcmc import search_spaces

    gp = GenericParams()
    out = []
    for nx, ny in (GRIDS[:2] if quick else GRIDS):
        rng = np.random.default_rng(0)
        rooms, lines, xyz, lab, h = _grid_scene(nx, ny, rng)
        b = shapely.union_all(rooms).bounds
        ext = shapely.box(b[0] - 0.3, b[1] - 0.3, b[2] + 0.3, b[3] + 0.3)
        t = time.perf_counter()
        cells = cellset_from_polygons(arrange_cells(lines, ext), (0.0, h))
        t_cells = time.perf_counter() - t
        t = time.perf_counter()
        cov = measure_coverage(cells, xyz[lab == 0], xyz[lab == 1], gp.coverage)
        t_cov = time.perf_counter() - t
        t = time.perf_counter()
        res = search_spaces(cells, cov, rng=0)
        t_search = time.perf_counter() - t
        row = {"rooms": len(rooms), "cells": len(cells), "faces": len(cells.faces), "points": int(len(xyz)),
               "cells_seconds": t_cells, "coverage_seconds": t_cov, "rjmcmc_seconds": t_search,
               "iterations": res.iterations, "spaces_found": len(res.spaces),
               "acceptance_rate": res.acceptance_rate,
               "microseconds_per_iteration": 1e6 * t_search / max(res.iterations, 1)}
        log.info("scaling: %s", row)
        out.append(row)
    return out


def _speedup(cells, cov, wall, hor, gp, n_incremental=2000, n_naive=3) -> dict:
    from engine.grammar.rjmcmc import SpaceSearch, naive_log_posterior, search_spaces

    res = search_spaces(cells, cov, rng=0)
    st = SpaceSearch(cells, cov)
    st.set_model(res.spaces)
    rng = np.random.default_rng(0)
    moves = []
    while len(moves) < n_incremental:
        c = int(rng.integers(len(cells)))
        m = st.move_add(c) or st.move_add_merge(c)
        if m is None and st.spaces:
            sid = list(st.spaces)[int(rng.integers(len(st.spaces)))]
            S = sorted(st.spaces[sid])
            m = st.move_split_remove(sid, S[int(rng.integers(len(S)))]) or st.move_remove(sid)
        if m is not None:
            moves.append(m)
    st._terms_cache.clear()  # time the computation, not the cache
    t = time.perf_counter()
    for m in moves:
        st.evaluate(*m)
    inc = (time.perf_counter() - t) / len(moves)
    t = time.perf_counter()
    for _ in range(n_naive):
        naive_log_posterior(res.spaces, cells, wall, hor, gp.search, gp.coverage)
    naive = (time.perf_counter() - t) / n_naive
    return {"cells": len(cells), "incremental_seconds_per_proposal": inc, "full_rescore_seconds": naive,
            "speedup": naive / inc if inc > 0 else float("inf"),
            "full_rescore_seconds_per_chain": naive * res.iterations,
            "incremental_seconds_per_chain": inc * res.iterations}


def run(out_dir: str, quick: bool) -> dict:
    """Run the three measurements; returns JSON-ready figures (see the module doc)."""
    import math as _m

    from engine.evaluation import evaluate
    from engine.grammar.coverage import measure_coverage
    from engine.grammar.generic import GenericParams, reconstruct_generic, storey_cells
    from engine.pipeline import preprocess
    from engine.synthetic import preset

    n = 200_000 if quick else 1_000_000
    t = time.perf_counter()
    sc = preset("syn_house", seed=1, noise="tls", target_points=n)
    t_scene = time.perf_counter() - t
    cloud = sc.cloud
    t = time.perf_counter()
    model = reconstruct_generic(cloud, rng=0)
    total = time.perf_counter() - t
    r = evaluate(model, sc.truth)
    i = list(r.buffers).index(0.1)
    c = r.curves["all"]
    tr = model.provenance.trace["storey_0"]
    end_to_end = {"preset": "syn_house", "noise": "tls", "points": len(cloud), "scene_seconds": t_scene,
                  "seconds": total, "steps": dict(model.provenance.timings),
                  "rjmcmc_seconds": model.provenance.timings.get("rjmcmc"),
                  "target_total_seconds": TARGET_TOTAL_S, "target_rjmcmc_seconds": TARGET_RJMCMC_S,
                  "cells": tr["cells"], "iterations": tr["iterations"], "acceptance_rate": tr["acceptance_rate"],
                  "rooms_found": len(model.spaces), "rooms_true": len(sc.truth.spaces),
                  "completeness_b10": float(c["completeness"][i]), "correctness_b10": float(c["correctness"][i]),
                  "accuracy_b10_m": float(c["accuracy"][i])}
    log.info("end to end: %s", end_to_end)
    # the same cells again for the speed-up measurement
    gp = GenericParams()
    prep = preprocess(cloud, rng=0)
    cells = storey_cells(prep, gp)[0].cells
    xyz = prep.working.xyz
    nz = np.abs(prep.working.normals[:, 2].astype(float))
    wall, hor = xyz[nz <= _m.sin(gp.coverage.coverage_angle)], xyz[nz >= _m.cos(gp.coverage.coverage_angle)]
    cov = measure_coverage(cells, wall, hor, gp.coverage)
    speed = _speedup(cells, cov, wall, hor, gp, n_naive=2 if quick else 3)
    log.info("speed-up: %s", speed)
    return {"end_to_end": end_to_end, "incremental_vs_full": speed, "scaling": _scaling(quick)}

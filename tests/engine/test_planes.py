"""engine.segmentation.planes: the fill test of a plane's support at the scan's own sampling.

A wall seen sparsely (far away, or only through a door, on a sparse scan: 10-20 points a
square metre) can never fill 15 % of 10 cm cells; measured at twice the support's
spacing to its nearest points of the tile it fills most of its rectangle. Clutter that
lines up by chance and the sparse noise tail beside a dense wall stay rejected: their
nearest points lie close."""
import numpy as np

from engine.segmentation.params import PlaneParams
from engine.segmentation.planes import _ransac_tile

PARAMS = PlaneParams()


def _wall(rng, n, x=0.0, length=2.6, height=2.5, sigma=0.005):
    """``n`` points on the wall x = ``x`` (y in [0, length], z in [0, height]) and normals."""
    p = np.c_[x + rng.normal(0, sigma, n), rng.uniform(0, length, n), rng.uniform(0, height, n)]
    return p, np.tile([1.0, 0.0, 0.0], (n, 1))


def _planes(pts, nrm, seed=0):
    return [(round(float(o), 2), len(i)) for _, o, i, _ in
            _ransac_tile("wall", pts, nrm, PARAMS, np.random.default_rng(seed))]


def test_a_sparsely_seen_wall_is_a_plane():
    """110 points on 6.5 m² (17 a square metre, 25 cm apart: hexagon_hall mobile at 100k
    points, a side room's wall behind a shelf seen only above it): on 10 cm cells they fill
    at most 110 / 650 = 0.17 of the rectangle, about 0.12 with the repeats a random sample
    has — rejected before, and the room stopped at the shelf's front with false doors and
    windows in its "wall"."""
    for seed in range(3):
        rng = np.random.default_rng(seed)
        p, n = _wall(rng, 110)
        assert _planes(p, n, seed) == [(0.0, 110)]


def test_clutter_lined_up_is_no_plane():
    """Five small objects (20 × 20 cm fronts, 40 points each, sampled as densely as the scan)
    in a row 4 m long: their points are close to each other, the fill is measured on 10 cm
    cells and stays low."""
    rng = np.random.default_rng(1)
    parts = []
    for y in (0.2, 1.1, 2.0, 2.9, 3.8):
        parts.append(np.c_[rng.normal(0, 0.004, 40), y + rng.uniform(0, 0.2, 40),
                           0.5 + rng.uniform(0, 0.2, 40)])
    p = np.concatenate(parts)
    p = np.r_[p, p[:, [0, 1, 2]] + [0.0, 0.0, 1.3]]  # and a second row higher up: 400 points
    assert _planes(p, np.tile([1.0, 0.0, 0.0], (len(p), 1))) == []


def test_stray_points_beside_a_dense_wall_are_no_second_plane():
    """A dense wall (8,000 points) and 70 stray points 4.5 cm in front of it spread over its
    whole face (a noise tail, or mixed pixels): among themselves they are as sparse as the
    wall above, but their nearest points of the tile are the wall's, 4.5 cm away — the
    fill stays on 10 cm cells and they are no plane (measured on their own spacing they
    would be one)."""
    for seed in range(3):
        rng = np.random.default_rng(seed)
        p, n = _wall(rng, 8000)
        q, m = _wall(rng, 70, x=0.045, sigma=0.002)
        assert _planes(np.r_[p, q], np.r_[n, m], seed) == [(0.0, 8000)]

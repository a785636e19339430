"""Parameters of the Manhattan shape grammar (SPEC.md §2 and §6).

The defaults are the thesis's values for real TLS data (Table 6.2: histogram bin 3–5 cm,
maximum wall thickness 0.125–0.5 m, shape buffer 0.05–0.2 m). :func:`params_from_data`
chooses the data-dependent ones from the point spacing and the noise of a cloud; the
rules for that choice are written next to each field.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Optional

import numpy as np

__all__ = ["ManhattanParams", "params_from_data", "estimate_noise", "estimate_spacing"]


@dataclass(frozen=True)
class ManhattanParams:
    """Parameters of the Manhattan grammar. Metres and radians.

    Choosing them from the data (what :func:`params_from_data` does):

    * ``spacing`` σ — the mean distance between neighbouring points on a surface; from
      the local density of the cloud, σ = 1/sqrt(points per m²).
    * ``shape_buffer`` δ — larger than the noise, smaller than a wall thickness:
      ``max(3 σ_noise, σ, 0.03)`` capped at half the minimum wall thickness.
    * ``bin_size`` — at most half the maximum wall thickness (SPEC.md §2); a few times
      the noise so that one surface falls into one or two bins.
    * ``tau`` τ — empirical; faces need not be fully covered (doors, clutter, occlusion).

    The thesis's own values (SPEC.md §6) are :meth:`spec_table`; :meth:`real_tls` loosens
    the wall tests for real furnished rooms.
    """

    tau: float = 0.3
    """τ: a face is "seen" when its point-on-face index reaches τ (0–1)."""
    bin_size: Optional[float] = None
    """Histogram bin of the place rule, metres (thesis: 0.03–0.05; ≤ max wall thickness / 2);
    None = choose from the data."""
    shape_buffer: Optional[float] = None
    """δ: points within this distance of a face count for its point-on-face index, metres;
    None = choose from the data."""
    max_wall_thickness: float = 0.5
    """A cuboid whose smaller horizontal size is at most this may be a wall, metres."""
    min_interval: float = 0.05
    """Two histogram peaks closer than this are one surface (no cuboid thinner), metres."""
    spacing: Optional[float] = None
    """σ of the point-on-face index, metres; None = estimate from the data."""
    noise: Optional[float] = None
    """σ_noise of the points across a surface, metres; None = estimate from the data.
    Point-on-face counts ignore points within 2 σ_noise of a face's edge."""
    min_wall_area: float = 1.5
    """A vertical histogram peak must hold at least this much surface (points × σ²), m²."""
    wall_top_band: float = 0.15
    """A wall surface reaches a ceiling: it must have points within this band below a
    ceiling level (furniture stops short of it), metres."""
    min_wall_top_length: float = 0.5
    """...over at least this length along the wall, metres."""
    extent_percentile: float = 0.5
    """Where no wall bounds the seen ceiling, the grid ends at this percentile (and 100 −
    it) of the ceiling points' coordinates (robust to a few stray points), percent."""
    min_bound_wall_area: float = 0.2
    """Where the grid would end at a ceiling's seen extent, a vertical surface holding at
    least this much (points × σ², m²) that reaches the ceiling and lies within
    ``max_wall_thickness`` of that extent closes it instead (a far end wall seen only in
    patches between furniture), m²."""
    min_level_area: float = 2.0
    """A floor or ceiling level must hold at least this much surface, m²."""
    min_storey_height: float = 1.8
    """Floor-to-ceiling distance below which a pair of levels is not a storey, metres."""
    normal_angle: float = float(np.deg2rad(20.0))
    """θ: a point whose normal is within θ of an axis counts for that axis's histogram."""
    normal_neighbours: int = 16
    """k nearest neighbours of the PCA normals (used when the cloud has none)."""
    min_slab_thickness: float = 0.1
    """A z range at least this long with (almost) no points is a slab between storeys, m."""
    slab_gap_share: float = 0.05
    """...where "almost no points" is less than this share of the median z-bin area."""
    corridor_aspect: float = 3.0
    """A space whose footprint is this many times longer than wide is named a corridor."""
    corridor_max_width: float = 2.5
    """...and is at most this wide, metres."""
    level_cell: float = 0.25
    """Cell of the 2D occupancy grid that tells ceilings (nothing above) from desks, metres."""
    level_exposed: float = 0.5
    """A horizontal level is a ceiling when at least this share of its cells has no
    horizontal surface above it in the storey (a floor: nothing below)."""

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def spec_table(cls, dataset: str = "synthetic", **changes) -> "ManhattanParams":
        """The thesis's values (SPEC.md §6, Table 6.2) instead of data-chosen ones.

        ``dataset``: "synthetic" (bin 0.05, max wall 0.5, buffer 0.05), "real_tls" (bin
        0.03, max wall 0.25, buffer 0.1) or "isprs" (bin 0.03, max wall 0.35, buffer 0.1).
        σ and σ_noise are still estimated from the data when left None.
        """
        rows = {"synthetic": (0.05, 0.5, 0.05), "real_tls": (0.03, 0.25, 0.1), "isprs": (0.03, 0.35, 0.1)}
        if dataset not in rows:
            raise ValueError(f"dataset must be one of {sorted(rows)}, not {dataset!r}")
        b, t, d = rows[dataset]
        return replace(cls(bin_size=b, max_wall_thickness=t, shape_buffer=d), **changes)

    @classmethod
    def real_tls(cls, **changes) -> "ManhattanParams":
        """Settings for real terrestrial scans of furnished rooms: the looser wall tests
        real rooms need — wall faces that are not one plane (window recesses, radiators)
        merge within 10 cm, sparse far walls count from 1 m², and a wall may stop up to
        0.3 m under the ceiling (soffits, curtain boxes). σ, δ and the bin still come from
        the data. (Synthetic rooms keep the defaults: with a 0.3 m band a 2.2 m shelf under
        a 2.4 m ceiling would count as a wall.)"""
        base = cls(min_interval=0.1, min_wall_area=1.0, wall_top_band=0.3)
        return replace(base, **changes)

    @property
    def complete(self) -> bool:
        """True when every data-dependent field (σ, σ_noise, δ, bin) is set."""
        return None not in (self.spacing, self.noise, self.shape_buffer, self.bin_size)

    def with_(self, **changes) -> "ManhattanParams":
        return replace(self, **changes)


def estimate_spacing(xyz: np.ndarray, sample: int = 20000, radius: float = 0.1, percentile: float = 10.0,
                     rng=0) -> float:
    """Surface point spacing σ = 1/sqrt(ρ), ρ a low percentile of the local surface density.

    Parameters
    ----------
    xyz : (n, 3) float64 — metres.
    sample : number of query points (random, ``rng``).
    radius : neighbourhood radius, metres; ρ = (neighbours) / (π r²).
    percentile : which percentile of ρ (0–100). A terrestrial scan is much denser near
        the scanner than on the far walls; taking the sparsest tenth (10) makes σ the
        spacing of the far surfaces, so that they can still reach τ (IPoF counts one
        point per σ × σ cell, so a denser patch cannot score above 1).

    Returns σ in metres (0.0 for fewer than two points). This is density-based rather
    than nearest-neighbour based: for random sampling the nearest-neighbour distance is
    about half of 1/sqrt(ρ), which would make a fully seen face score ~0.25, not 1.
    """
    rng = np.random.default_rng(rng)
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if len(xyz) < 2:
        return 0.0
    from scipy.spatial import cKDTree

    tree = cKDTree(xyz)
    q = xyz if len(xyz) <= sample else xyz[rng.choice(len(xyz), sample, replace=False)]
    r = radius
    for _ in range(4):  # widen the ball until it holds enough neighbours to count on
        counts = tree.query_ball_point(q, r=r, return_length=True).astype(np.float64)
        if np.percentile(counts, percentile) >= 8:
            break
        r *= 2
    rho = np.percentile(np.maximum(counts - 1, 1), percentile) / (np.pi * r**2)
    return float(1.0 / np.sqrt(rho))


def estimate_noise(xyz: np.ndarray, sample: int = 5000, k: int = 20, rng=0) -> float:
    """Surface noise σ_noise: median of the smallest PCA standard deviation over k
    neighbours (metres). On a plane this is the scatter across the surface."""
    rng = np.random.default_rng(rng)
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if len(xyz) <= k:
        return 0.0
    from scipy.spatial import cKDTree

    tree = cKDTree(xyz)
    q = xyz if len(xyz) <= sample else xyz[rng.choice(len(xyz), sample, replace=False)]
    _, idx = tree.query(q, k=k)
    nb = xyz[idx]  # (m, k, 3)
    c = nb - nb.mean(axis=1, keepdims=True)
    cov = np.einsum("mki,mkj->mij", c, c) / k
    ev = np.linalg.eigvalsh(cov)[:, 0]
    return float(np.sqrt(np.median(np.maximum(ev, 0))))


def params_from_data(xyz: np.ndarray, base: Optional[ManhattanParams] = None, rng=0) -> ManhattanParams:
    """Fill the data-dependent fields left None from a cloud's spacing and noise.

    ``xyz`` : (n, 3) float64, metres. ``base`` gives every other field (and any of these
    already chosen; defaults when None). The rules: σ from :func:`estimate_spacing`,
    σ_noise from :func:`estimate_noise`; δ = clip(max(3 σ_noise, σ), 0.03,
    max_wall_thickness / 4); bin = clip(2 σ_noise, 0.02, 0.05) but ≤ max_wall_thickness / 2.
    """
    base = base or ManhattanParams()
    spacing = base.spacing if base.spacing is not None else estimate_spacing(xyz, rng=rng)
    noise = base.noise if base.noise is not None else estimate_noise(xyz, rng=rng)
    buffer = base.shape_buffer if base.shape_buffer is not None else \
        float(np.clip(max(3 * noise, spacing), 0.03, base.max_wall_thickness / 4))
    bin_size = base.bin_size if base.bin_size is not None else \
        float(min(np.clip(2 * noise, 0.02, 0.05), base.max_wall_thickness / 2))
    return replace(base, spacing=float(spacing), shape_buffer=float(buffer), bin_size=float(bin_size),
                   noise=float(noise))

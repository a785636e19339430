"""Parameters of the two reconstruction methods (docs/method.md §2, §3 and §6).

:class:`ManhattanParams` (the shape grammar, §2): the default maximum wall thickness is the
thesis's synthetic row of Table 6.2 (its real TLS rows are in :meth:`ManhattanParams.spec_table`);
the histogram bin, the shape buffer δ, the spacing σ and the noise σ_noise default to None and
:func:`params_from_data` chooses them from the cloud by the rules written in its docstring.
:class:`GenericParams` (cells, coverage and rjMCMC search, §3) take the thesis's Table 6.5
values where it gives them.
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace
from typing import Optional

import numpy as np

from ..geometry.spacing import estimate_spacing
from ..quantities import Count, Factor, Flag, Metres, OptionalMetres, Percent, Radians, Ratio, SquareMetres

__all__ = ["ManhattanParams", "GenericParams", "CellParams", "CoverageParams", "RjmcmcParams",
           "params_from_data", "estimate_noise", "estimate_spacing"]


@dataclass(frozen=True)
class CellParams:
    """The generic method's cells: wall lines cut each storey's extent (docs/method.md §3.1)."""

    min_wall_area: SquareMetres = 0.5
    """Wall planes with a smaller covered area do not cut the floor, m²."""
    line_merge_angle: Radians = math.radians(2.0)
    """Two wall lines closer than this in angle (and ``line_merge_distance`` in offset) are one
    line, radians."""
    line_merge_distance: Metres = 0.015
    """Two wall lines closer than this in offset (and ``line_merge_angle`` in angle) are one
    line, metres: duplicates would only make slivers."""
    extent_margin: Metres = 0.3
    """The storey's extent (box around its points) is grown by this, metres."""
    min_cell_area: SquareMetres = 0.01
    """Cells smaller than this join their neighbour with the longest shared edge, m²."""
    min_cell_width: Metres = 0.03
    """Cells narrower than this (``2 × area / perimeter``) join their neighbour too, metres:
    wedges and strips between lines crossing at a few degrees are no room and no wall."""
    min_face_length: Metres = 0.02
    """Shared edges shorter than this do not make cells adjacent, metres."""
    second_faces: Flag = True
    """A wall line's second face seen too little to be a plane still cuts the cells when it
    is the other side of that wall (the Manhattan grammar's paired faces,
    :func:`.place.paired_faces`, along each wall direction; :func:`.generic.second_faces`)."""
    clutter_fronts: Flag = True
    """A line whose surface faces the same way as a longer one within a wall's thickness
    behind it, which runs on past both its ends, is furniture before a wall (a shelf's
    front): it makes no cut (:func:`.generic.clutter_fronts`; oriented normals only)."""


@dataclass(frozen=True)
class CoverageParams:
    """Coverage of cells and faces by the points, measured once per storey (docs/method.md §3.2)."""

    shape_buffer: Metres = 0.05
    """δ: points within this of a face belong to it, metres (above the noise, below half a
    wall's thickness)."""
    r_alpha: Metres = 0.2
    """Circumradius bound of the alpha shapes, metres (about twice the point spacing or more)."""
    coverage_angle: Radians = math.radians(45.0)
    """A point counts as floor/ceiling when its normal is within this of vertical, as wall
    when within it of horizontal, radians (wider than θ: sparse ceilings have noisy normals)."""
    min_wall_coverage: Ratio = 0.2
    """A cell face whose wall coverage reaches this share of its area is a seen wall."""
    min_ceiling_area: SquareMetres = 1.0
    """Horizontal planes at least this large in a storey's upper half are its ceiling levels,
    m²; ceiling points must lie near one (a door head is not a ceiling)."""
    ceiling_band: Metres = 0.1
    """Ceiling points must lie within this distance of a ceiling level (``min_ceiling_area``),
    metres."""
    ceiling_by_level: Flag = True
    """Every point within ``ceiling_band`` of a ceiling level counts as ceiling, whatever its
    normal, unless it stands over a wall (:func:`.levels.over_walls`): a sparse scan's scan
    lines leave too few neighbours across them for a normal."""
    alpha_spacing_factor: Factor = 5.0
    """r_α of the ceiling follows the local spacing of the thinned ceiling points: this many
    spacings, at least ``r_alpha`` and at most ``r_alpha_max``."""
    r_alpha_max: Metres = 0.6
    """Upper bound of the ceiling's spacing-following r_α, metres (<= r_α: one r_α everywhere)."""
    wall_band: Metres = 0.6
    """Wall coverage is measured in this band under the ceiling, metres; 0: the whole face."""
    coverage_grid: Metres = 0.04
    """Points are thinned to one per cell of this grid before coverage is measured, metres."""


@dataclass(frozen=True)
class RjmcmcParams:
    """Parameters of the rjMCMC search (docs/method.md §3.3, thesis Table 6.5 defaults)."""

    max_wall_thickness: Metres = 0.3
    """Prior: a space must be wider than this (smaller side of its scope), metres."""
    min_space_area: SquareMetres = 1.0
    """Prior: a space must also have at least this floor area, m² (a WC is about 1.2 m²). Departure
    from the thesis, whose prior has the width alone: a sliver between a slanted wall and
    the line of another wall can be wider than a wall and still score as a room. 0: width
    alone."""
    k1: Factor = 1.0 / 3.0
    """Weight of the horizontal coverage P_hor in the global likelihood."""
    k2: Factor = 1.0 / 3.0
    """Weight of the vertical coverage P_vert."""
    k3: Factor = 1.0 / 3.0
    """Weight of the plausibility P_plaus (lower it in cluttered scenes)."""
    mu_same: Factor = 1.0
    """μ when M_t and M_{t+1} have the same number of spaces."""
    mu_fewer_to_more: Factor = 0.83
    """μ when M_t has fewer spaces than M_{t+1}."""
    mu_more_to_fewer: Factor = 0.9
    """μ when M_t has more spaces than M_{t+1}."""
    connected_cover: Flag = True
    """Prior: the covered cells of a space (ceiling coverage ratio ≥ ``cover_ratio``) must
    be connected through shared faces (see the module doc)."""
    cover_ratio: Ratio = 0.5
    """A cell is *covered* when this share of its footprint is under the ceiling's alpha
    shape."""
    link_length: Metres = 0.15
    """Covered cells of a space must connect through faces at least this long, metres
    (about half a wall's thickness), that are not seen walls."""
    walls_part: Flag = True
    """Spaces may meet across a seen wall: the moves treat a cell as adjacent to a space only
    through faces that are no seen walls (see the module doc)."""
    beta: Factor = 0.0
    """Convergence factor β: accept when α > U, U ~ Uniform[β, 1] (0: plain MH)."""
    iterations: Count = 0
    """Chain length; 0 picks ``max(min_iterations, iterations_per_cell × cells)``."""
    iterations_per_cell: Count = 60
    """Automatic chain length per cell."""
    min_iterations: Count = 2000
    """Smallest automatic chain length."""
    min_ratio: Ratio = 1e-6
    """Coverage ratios and P_G are floored at this before the logarithm (a space with no
    ceiling point is then very unlikely rather than impossible)."""
    greedy_start: Flag = True
    """Start the chain from a greedy best-improvement ascent from the empty model (see the
    module doc); False starts from the empty model (or ``initial``) as the thesis does."""
    polish: Flag = True
    """Greedy best-improvement moves after the chain (see the module doc)."""
    area_weighted_local: Flag = True
    """``log P_L = Σ_i (|M_i.top| / Cov(hpoints)) · log(Cov(M_i.top)/|M_i.top|)`` instead of
    the plain product of ratios (see the module doc); False: the thesis's product."""
    absorb_covered: Flag = True
    """After the search, an untyped *covered* cell adjacent to exactly one space joins it
    (repeated until nothing changes): it lies under that room's ceiling. So does a
    *walled-in* one (see ``walled_in_ratio``). See the module doc."""
    join_open: Flag = True
    """After the search, an untyped covered cell between several spaces with no seen wall
    face towards any of them joins them into one space (rooms meeting without a wall are
    one space, issue 19); off: the search's split stands."""
    join_open_width: Metres = 2.0
    """...unless the cell is no thicker than a wall (``max_wall_thickness``) and open towards
    one of the spaces over less than this, metres: a gap in a wall line (a doorway, or the
    unseen end of a partition), not rooms meeting without a wall; the Manhattan grammar's
    ``min_passage_width``."""
    walled_in_ratio: Ratio = 0.1
    """An untyped cell adjacent to exactly one space and walled in otherwise (no way out but
    through that space, :meth:`SpaceSearch.walled_in`) joins it when at least this share of
    its footprint is under the ceiling — a sparsely seen corner; a column or a cupboard
    reaching the ceiling, walled-in too, has no ceiling over it. > 1: off."""
    walled_in_level: Metres = 0.15
    """...and when the space reaches it: through a face that is no seen wall, or under the same
    ceiling (its ceiling layer within this of that over a cell of the space it touches),
    metres. A strip inside an outer wall between its face and a window's glazing is behind
    the wall's face and has the window's head for a ceiling, 0.3-0.8 m under the room's."""
    corner_area: SquareMetres = 1.0
    """After that, a space takes in the corners behind its furniture: a group of uncovered
    cells it reaches through no seen wall, closed off by the lines of its own seen walls
    alone, up to this area in all, m² (0: off). See ``SpaceSearch.fill_corners``."""
    trace_every: Count = 50
    """Record (iteration, log-score, spaces) in the trace every this many iterations."""

    def __post_init__(self):
        if not (0.0 <= self.beta <= 1.0):
            raise ValueError("beta must lie in [0, 1]")
        if min(self.k1, self.k2, self.k3) < 0 or abs(self.k1 + self.k2 + self.k3 - 1.0) > 1e-6:
            raise ValueError("k1, k2, k3 must be non-negative and sum to 1")


@dataclass(frozen=True)
class GenericParams:
    """The generic method: cells, their coverage, the rjMCMC search (thesis Table 6.5)."""

    cells: CellParams = field(default_factory=CellParams)
    coverage: CoverageParams = field(default_factory=CoverageParams)
    search: RjmcmcParams = field(default_factory=RjmcmcParams)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class ManhattanParams:
    """Parameters of the Manhattan grammar. Metres and radians.

    Choosing them from the data (what :func:`params_from_data` does):

    * ``spacing`` σ — the distance between neighbouring points on a surface; from the
      local density ρ of the cloud (a low percentile, the sparse far walls), σ = 1/sqrt(ρ).
    * ``noise`` σ_noise — the scatter of the points across a surface (:func:`estimate_noise`).
    * ``shape_buffer`` δ — larger than the noise, smaller than a wall:
      ``clip(max(3 σ_noise, σ), 0.03, max_wall_thickness / 4)``.
    * ``bin_size`` — a few times the noise so that one surface falls into one or two bins,
      at most half the maximum wall thickness (docs/method.md §2):
      ``min(clip(2 σ_noise, 0.02, 0.05), max_wall_thickness / 2)``.
    * ``tau`` τ — empirical; faces need not be fully covered (doors, clutter, occlusion).

    The thesis's own values (docs/method.md §6) are :meth:`spec_table`; :meth:`real_tls`
    loosens the wall tests for real furnished rooms.
    """

    tau: Ratio = 0.3
    """τ: a face is "seen" when its point-on-face index reaches τ (0–1)."""
    bin_size: OptionalMetres = None
    """Histogram bin of the place rule, metres (thesis: 0.03–0.05; ≤ max wall thickness / 2);
    None = choose from the data."""
    shape_buffer: OptionalMetres = None
    """δ: points within this distance of a face count for its point-on-face index, metres;
    None = choose from the data."""
    max_wall_thickness: Metres = 0.5
    """A cuboid whose smaller horizontal size is at most this may be a wall, metres (the
    thesis's synthetic value; it also bounds δ and the bin)."""
    min_interval: Metres = 0.05
    """Two histogram peaks closer than this are one surface (no cuboid thinner), metres."""
    spacing: OptionalMetres = None
    """σ of the point-on-face index, metres; None = estimate from the data."""
    noise: OptionalMetres = None
    """σ_noise of the points across a surface, metres; None = estimate from the data.
    Point-on-face counts ignore points within 2 σ_noise of a face's edge."""
    min_wall_area: SquareMetres = 1.5
    """A vertical histogram peak must hold at least this much surface (points × σ²), m²."""
    min_paired_wall_area: SquareMetres = 0.2
    """A vertical surface holding at least this much (but less than ``min_wall_area``) still
    makes a cut when it is a wall's second face: behind a strong peak, at most
    ``max_wall_thickness`` away, the two seen from opposite sides (oriented normals only), m²;
    ``min_wall_area`` or more turns this off."""
    wall_top_band: Metres = 0.15
    """A wall surface reaches a ceiling: it must have points within this band below a
    ceiling level (furniture stops short of it), metres."""
    min_wall_top_length: Metres = 0.5
    """The points within ``wall_top_band`` below the ceiling must cover at least this length
    along the wall, metres."""
    wall_top_reach: Factor = 2.5
    """Those points must lie under the ceiling: within one ``level_cell`` of a cell its points
    occupy, or within this many point spacings σ when that is farther. Next to a wall the
    ceiling's own normals are spoiled over their neighbourhood (2.5 σ, docs/method.md §1): on
    a sparse scan (σ 16 cm) the ceiling read as unseen for 40 cm along a partition's top."""
    extent_percentile: Percent = 0.5
    """Where no wall bounds the seen ceiling, the grid ends at this percentile (and 100 −
    it) of the ceiling points' coordinates (robust to a few stray points), percent."""
    min_bound_wall_area: SquareMetres = 0.2
    """Where the grid would end at a ceiling's seen extent, a vertical surface holding at
    least this much (points × σ², m²) that reaches the ceiling and lies within
    ``max_wall_thickness`` of that extent closes it instead (a far end wall seen only in
    patches between furniture), m²."""
    min_level_area: SquareMetres = 2.0
    """A floor or ceiling level must hold at least this much surface, m²."""
    min_storey_height: Metres = 1.8
    """Floor-to-ceiling distance below which a pair of levels is not a storey, metres."""
    normal_angle: Radians = float(np.deg2rad(20.0))
    """θ: a point whose normal is within θ of an axis counts for that axis's histogram."""
    normal_neighbours: Count = 16
    """k nearest neighbours of the PCA normals (used when the cloud has none)."""
    min_slab_thickness: Metres = 0.1
    """A z range at least this long with (almost) no points is a slab between storeys, m."""
    slab_gap_share: Ratio = 0.05
    """A slab's z bins hold less than this share of the median z-bin area ("almost no
    points")."""
    corridor_aspect: Factor = 3.0
    """A space whose footprint is this many times longer than wide is named a corridor."""
    corridor_max_width: Metres = 2.5
    """A corridor (see ``corridor_aspect``) is at most this wide, metres."""
    min_space_width: Metres = 0.6
    """A space narrower than this is the gap between the faces of one wall (doubled wall
    lines, a party wall): it becomes wall (issue 19), metres."""
    min_space_area: SquareMetres = 1.0
    """A space smaller than this is no room (it becomes exterior), m²."""
    min_space_height: Metres = 1.8
    """A space lower than this (a band between two ceiling levels) is no room, metres."""
    void_height: Metres = 3.0
    """Points up to this far above a storey's top, over a cuboid without a seen ceiling, tell
    that its column is open upwards (a double-height void), metres."""
    void_floor_band: Metres = 0.6
    """Horizontal points up to this far above the storey's top are the floor of a storey above
    (then the column is not open), metres."""
    sloped_normal_min: Ratio = 0.2
    """Points whose normal has |n_z| from this up to cos θ are sloped (roof undersides)."""
    sloped_min_height: Metres = 0.5
    """Sloped points this far above an attic's floor and higher are roof undersides, metres."""
    sloped_ceiling_ratio: Factor = 3.0
    """A storey whose upper half holds this many times more sloped points than horizontal
    points at its ceiling levels has a sloped top (an attic): its roof undersides stand for the
    ceiling."""
    pocket_width: Metres = 1.0
    """An exterior cuboid on the floor at most this wide (wider than a wall), with some floor
    seen, closed all round by walls and rooms and open to a room, is part of that room: its
    ceiling fell between a far scan's lines (:func:`.passages.enclosed_pockets`); 0 turns it
    off, metres."""
    strip_density: Ratio = 0.25
    """A run of thin exterior cuboids between a room and a wall whose ceiling is seen at
    least this share of the room's density is the room's, behind furniture
    (:func:`.passages.furniture_strips`); 0 turns it off."""
    strip_band: Metres = 0.5
    """... measured against the room's ceiling in a band this wide (or as wide as the run)
    beside it, metres."""
    min_passage_width: Metres = 2.0
    """A thin unseen cuboid with floor under it between two interiors, at least this long, is a
    wide opening under a beam or lintel that joins them (narrower: a door); 0 turns it off."""
    faces_by_position: Flag = True
    """A wall face's point-on-face index counts too the points within δ of its plane whose
    normal lies along no axis but leans its way (its horizontal part along the face's axis),
    away from the floor and the ceiling: a sparse scan sees a wall as scan lines far apart,
    and a normal tilts about its scan line, between the wall's normal and the vertical."""
    ceiling_by_level: Flag = True
    """A point within δ of a ceiling level is on that ceiling whatever its normal, unless it
    stands over a wall (:func:`.levels.over_walls`): a sparse scan's scan lines leave a
    point's neighbourhood one line, and its normal tilts anywhere about it."""
    ceiling_reach: Factor = 3.0
    """In the sparse ceiling index (``ipof_top_sparse``) a ceiling point covers a disc of its
    local spacing, up to this many σ: a cuboid on the floor with its floor seen is interior
    when its ceiling, seen sparsely from far away (at a grazing angle, over a cabinet), is
    covered so (issue 19); ≤ 1 turns that off (the thesis's rule)."""
    min_room_evidence: Ratio = 0.1
    """A cuboid on the floor whose top is seen but whose floor and sides (all, or all but one
    under a partial top) are covered at most this much is no room part (a window head's
    soffit, an eave seen through glazing);
    0: the thesis's rule (a seen top alone makes it interior)."""
    max_furniture_area: SquareMetres = 2.5
    """A space on the floor up to this large whose floor is seen under at most
    ``min_room_evidence`` of its footprint (its parts weighted by their area) is the inside of
    furniture (a wardrobe in an alcove: a strip along its front catches the floor's noise),
    not a room; larger ones only when no part's floor is seen, m²."""
    min_roof_area: SquareMetres = 2.0
    """A roof plane under which attic rooms are cut needs this much plan area of points."""
    level_cell: Metres = 0.25
    """Cell of the 2D occupancy grid that tells ceilings (nothing above) from desks, metres."""
    level_exposed: Ratio = 0.5
    """A horizontal level is a ceiling when at least this share of its cells has no
    horizontal surface above it in the storey (a floor: nothing below)."""
    floor_share: Ratio = 0.25
    """The storey's floor is the lowest floor level (nothing below it) with at least this
    share of the largest one's area: the ground outside a door, seen through it a few
    centimetres under the floor, is no storey floor."""

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def spec_table(cls, dataset: str = "synthetic", **changes) -> "ManhattanParams":
        """The thesis's values (docs/method.md §6, thesis Table 6.2) instead of data-chosen ones.

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


def estimate_noise(xyz: np.ndarray, sample: int = 5000, k: int = 20, rng=0, tree=None) -> float:
    """Surface noise σ_noise: median of the smallest PCA standard deviation over k
    neighbours (metres). On a plane this is the scatter across the surface. ``tree``: a k-d
    tree of ``xyz`` (:func:`engine.geometry.kdtree.kdtree`) to share, or None. A rigid motion
    of ``xyz`` leaves σ_noise unchanged (the tree of the unmoved points serves)."""
    rng = np.random.default_rng(rng)
    xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
    if len(xyz) <= k:
        return 0.0
    from ..geometry.kdtree import kdtree
    from ..threads import thread_cap

    tree = kdtree(xyz) if tree is None else tree
    q = xyz if len(xyz) <= sample else xyz[rng.choice(len(xyz), sample, replace=False)]
    _, idx = tree.query(q, k=k, workers=thread_cap())
    nb = xyz[idx]  # (m, k, 3)
    c = nb - nb.mean(axis=1, keepdims=True)
    cov = np.matmul(c.transpose(0, 2, 1), c) / k
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

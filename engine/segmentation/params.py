"""Parameter dataclasses of the preprocessing stage (docs/method.md §1) and the plane
extraction (§3.1).

Defaults follow the thesis where it gives a value (θ = 10°, a z-histogram bin of 3 cm,
tiles of about room size; docs/method.md §6); the inlier bands start at terrestrial-scanner
noise and widen with the measured noise of the data. Every field is in SI units: metres,
radians, point counts.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..quantities import Count, Factor, Flag, Metres, Radians, Ratio

__all__ = [
    "CleanParams",
    "NormalParams",
    "AlignParams",
    "StoreyParams",
    "ClassifyParams",
    "PlaneParams",
    "PreprocessParams",
]

THETA = math.radians(10.0)
"""The angle tolerance θ ≤ 10° of the point clustering, the alignment and the plane extraction
(docs/method.md §1, §3.1), radians."""


@dataclass(frozen=True)
class CleanParams:
    """The working cloud: one representative input point per voxel (docs/method.md §1 "Clean")."""

    voxel_size: Metres = 0.02
    """Edge of the downsampling voxel, metres; 0 keeps every point. The full cloud is kept."""
    max_working_points: Count = 250_000
    """The voxel grows (by the square root of the excess: points lie on surfaces) until the
    working cloud has about this many points; 0: no bound."""
    max_points: Count = 2_000_000
    """A larger scan is first thinned at random to about this many points, before anything
    else (:func:`engine.pipeline.cap_points`): past a few million points a denser sample adds
    cost, not information. 0: no bound."""
    remove_outliers: Flag = False
    """Run the statistical outlier filter on the working cloud."""
    outlier_neighbors: Count = 12
    """k of the statistical filter: mean distance to the k nearest neighbours."""
    outlier_std_ratio: Factor = 3.0
    """An outlier's mean neighbour distance exceeds the cloud's mean by this many deviations."""
    cluster_voxel: Metres = 0.5
    """Edge of the coarse voxels whose 26-connected groups are the scan's point clusters,
    metres (wider than a wall or slab is thick, so one building is one group)."""
    min_cluster_share: Ratio = 0.05
    """Groups with fewer points than this share of the largest group's are stray clusters
    and removed before anything else; the extent used downstream is the building's (0: keep
    every point)."""
    min_points: Count = 100
    """Fewer usable points than this is an error."""
    scanner_margin: Metres = 1.0
    """A scanner position farther than this outside the building's points (their box) is not
    where the scan was taken (a file's default viewpoint at the origin of a georeferenced
    cloud, poses in another frame): it is dropped, and the points it holds get none, metres."""


@dataclass(frozen=True)
class NormalParams:
    """PCA normals over a neighbourhood (docs/method.md §1 "Normals")."""

    radius: Metres = 0.10
    """Search radius of the neighbourhood, metres."""
    radius_voxels: Factor = 3.0
    """The working cloud's radius is at least this many voxels (about 20 neighbours remain)."""
    radius_spacings: Factor = 2.5
    """The full cloud's radius (normals of every point, for the Manhattan grammar) is at least
    this many point spacings σ of the input's sparsest tenth: far walls of a terrestrial scan
    are sparse."""
    max_nn: Count = 30
    """At most this many neighbours enter the PCA."""
    fallback_knn: Count = 12
    """Points with too few neighbours within ``radius`` get the PCA normal of this many
    nearest neighbours instead."""
    orient_to_scanner: Flag = True
    """Flip normals to face the scanner of each point when scanner positions are known
    (``cloud.scanner_positions`` with ``cloud.scan_index``, or a single position)."""
    one_sided_planarity: Ratio = 0.1
    """With scanner positions, a point whose neighbourhood is far from planar (smallest over
    middle eigenvalue above this) and reaches ``one_sided_reach`` is estimated again over the
    neighbours seen from its side (:func:`engine.geometry.normals.one_sided_normals`): on
    sparse scans a neighbourhood spans both faces of a partition. 0: never."""
    one_sided_reach: Metres = 0.10
    """Only neighbourhoods at least this wide (radius √(2 · trace) of their covariance,
    metres) are estimated again: partitions are about 10 cm thick or more, so a narrower
    neighbourhood cannot reach the other face (and a noisy dense scan keeps its cost)."""
    sheet_gap: Metres = 0.10
    """Without scanner positions, such a point (the same gates) whose neighbours lie in two
    horizontal sheets at least this far apart in height (a floor and the ceiling under its
    slab; not a floor and the ground 5 cm under it outside a door, which turned FZK-Haus's
    storey floor 5 cm low) is estimated again over its own sheet
    (:func:`engine.geometry.normals.sheet_normals`). 0: never."""
    wall_sheet_gap: Metres = 0.05
    """Without scanner positions, such a point (wide and far from planar) whose neighbours lie
    in two vertical sheets side by side at least this far apart (the faces of a partition 7 cm
    thick or more, under 1 cm of noise) is estimated again over its own sheet
    (:func:`engine.geometry.normals.wall_sheet_normals`). 0: never."""


@dataclass(frozen=True)
class AlignParams:
    """Manhattan alignment from the normals (docs/method.md §1 "Manhattan alignment")."""

    max_normals: Count = 100_000
    """Random sample of normals used, for speed."""
    kmeans_restarts: Count = 4
    """Restarts of the antipodal-aware (axial) k-means; the best is kept."""
    kmeans_iterations: Count = 30
    """Iterations of each k-means run."""
    angle_tolerance: Radians = THETA
    """A normal within this angle of horizontal is a wall normal, within this angle of
    vertical a floor/ceiling normal, radians."""
    refine_tolerance: Radians = math.radians(5.0)
    """Normals farther than this from the current dominant directions are ignored in the
    refinement iterations, radians."""
    refine_iterations: Count = 4
    """Refinement passes of the vertical and of the yaw."""
    assume_upright: Flag = True
    """The scanner was levelled (input z within 45° of up): of the three dominant
    directions the one closest to z is the vertical, and it is oriented to +z. When False,
    the direction whose normals are the densest cluster is taken as vertical."""
    min_wall_fraction: Ratio = 0.05
    """Fewer wall (near-horizontal) normals than this share of the cloud is an error: there
    is no vertical structure to align to."""


@dataclass(frozen=True)
class StoreyParams:
    """Storeys from the z histogram of horizontal points (docs/method.md §1 "Storeys")."""

    bin_size: Metres = 0.03
    """Histogram bin of z, metres (thesis: 3–5 cm, docs/method.md §6)."""
    min_layer_gap: Metres = 0.15
    """Two histogram peaks closer than this are one layer, metres (a slab is thicker)."""
    layer_half_width: Metres = 0.06
    """Points within this of a layer's height belong to it, metres (3σ of mobile noise)."""
    grid_cell: Metres = 0.25
    """Cell of the occupancy grid that measures the area of a layer, metres."""
    min_area_fraction: Ratio = 0.15
    """A layer must cover at least this share of the building's occupied footprint to be a
    floor or a ceiling (a desk or a shelf does not)."""
    min_layer_points: Count = 200
    """A layer needs at least this many horizontal points."""
    side_window: Metres = 0.10
    """Height of the windows above and below a layer in which non-horizontal points are
    counted to tell a floor (walls rise above it) from a ceiling (walls hang below it),
    metres. Keep it below the slab thickness."""
    min_side_contrast: Factor = 0.3
    """|above − below| / (above + below) must reach this for a layer to be typed floor or
    ceiling; lower contrast (a desk, walls on both sides) discards the layer."""
    min_storey_height: Metres = 2.2
    """A ceiling lies at least this far above its floor; floors closer than this above a
    floor belong to the same storey, metres."""
    min_scanner_height: Metres = 0.3
    """A scanner (tripod, backpack, handheld) stands at least this far above the floor under
    it, metres."""
    max_scanner_height: Metres = 2.5
    """... and at most this far, metres."""
    min_standing_scanners: Count = 3
    """A layer of enough area, not a ceiling by its contrast, is a floor when at least this
    many scanner positions, and half of those between ``min_scanner_height`` and
    ``max_scanner_height`` above it, stand over its cells at that height."""
    angle_tolerance: Radians = THETA
    """A normal within this angle of vertical is a horizontal-surface normal, radians."""
    sloped_top_quantile: Ratio = 0.99
    """A storey without a flat ceiling (attic under a pitched roof) reaches this quantile of
    the heights of the downward-facing points above its floor (the ridge)."""


@dataclass(frozen=True)
class ClassifyParams:
    """Point clusters (docs/method.md §1 "Point clustering")."""

    angle_tolerance: Radians = THETA
    """θ: |n_z| ≤ sin θ is a wall point, |n_z| ≥ cos θ a floor/ceiling point, radians."""


@dataclass(frozen=True)
class PlaneParams:
    """Multi-scale RANSAC plane extraction and global refinement (docs/method.md §3.1)."""

    tile_size: Metres = 4.0
    """Edge of the local voxels (tiles) in x and y, metres (thesis: 3–5 m, about a room)."""
    tile_overlap: Factor = 0.5
    """Tiles are enlarged by this on every side so walls on tile borders are seen whole."""
    distance_threshold: Metres = 0.02
    """RANSAC inlier distance, metres; raised to ``noise_factor`` × the robust noise of the
    storey's floor heights (of each plane's residuals when no storeys are given) when the
    data are noisier (mobile scans)."""
    noise_factor: Factor = 2.5
    """Inlier band in units of the plane's robust residual σ (1.4826 × MAD)."""
    max_distance_threshold: Metres = 0.05
    """Cap of the adaptive inlier band, metres (below half the thinnest wall)."""
    iterations: Count = 200
    """RANSAC hypotheses per plane."""
    score_sample: Count = 2000
    """Hypotheses are scored on a random sample of at most this many points of the tile's
    pool (the chosen one is then refined on all of them)."""
    min_points: Count = 60
    """A plane needs at least this many supporting points (of the working cloud)."""
    min_extent: Metres = 0.3
    """A plane's support must span at least this in its longest direction, metres."""
    max_bend: Radians = math.radians(1.0)
    """When the two halves of a wall plane's inliers differ in direction by more than this,
    the plane straddles two walls meeting at a small angle and is refitted on the larger
    half, radians."""
    min_fill: Ratio = 0.15
    """A plane's support must occupy at least this share of its bounding rectangle on the
    plane (10 cm cells, or twice the support's median spacing where it is sparser): occluded
    walls still fill a good part of it, chance alignments of clutter do not."""
    max_rejections: Count = 5
    """Stop searching a tile after this many rejected hypotheses in a row (only clutter is
    left)."""
    max_planes_per_tile: Count = 40
    """Stop searching a tile after this many planes."""
    angle_tolerance: Radians = THETA
    """Orientation constraint: wall planes within θ of vertical, floor/ceiling planes within
    θ of horizontal, radians."""
    normal_agreement: Radians = math.radians(25.0)
    """A point supports a plane only when its normal is within this angle of the plane's
    (sign ignored), radians; keeps perpendicular walls' points apart at corners."""
    merge_angle: Radians = math.radians(4.0)
    """Global refinement: merge planes closer than this in angle, radians. Departure from
    the thesis (θ = 10°, docs/method.md §3.1): non-Manhattan plans have walls meeting at a
    few degrees, which θ would merge into one bent plane, while locally fitted pieces of one
    wall agree far more closely."""
    merge_distance: Metres = 0.04
    """Global refinement: merge planes (within ``merge_angle``) whose supports lie within this
    of each other (median point-to-plane distance in both directions), metres (≤ the data's
    nominal accuracy; docs/method.md §3.1). The larger of the two planes' adaptive inlier
    bands is used instead when it is wider (noisy mobile data, where the tails of one wall's
    noise otherwise form parallel planes ±2σ away)."""
    merge_keep: Ratio = 0.9
    """A merge is undone when the refitted plane keeps less than this share of the two
    supports within its band (the two were not one plane)."""
    max_merge_rounds: Count = 50
    """Safety bound on the refinement loop (it stops earlier when nothing merges)."""


@dataclass(frozen=True)
class PreprocessParams:
    """The one preprocessing stage both methods use (:func:`engine.pipeline.preprocess`)."""

    clean: CleanParams = field(default_factory=CleanParams)
    normals: NormalParams = field(default_factory=NormalParams)
    align: AlignParams = field(default_factory=AlignParams)
    storeys: StoreyParams = field(default_factory=StoreyParams)
    classify: ClassifyParams = field(default_factory=ClassifyParams)
    theta_spread_factor: Factor = 4.0
    """θ of the point clusters follows the normals' noise: θ = clip(factor × s,
    ``classify.angle_tolerance``, ``max_theta``), s the median tilt of the near-vertical
    normals (|n_z| < sin 30°); 0: fixed θ. Noisy (mobile) normals otherwise push sparsely seen
    walls into "other" (a departure from θ ≤ 10°, for noisy normals only)."""
    max_theta: Radians = math.radians(20.0)
    """Upper bound of the noise-adaptive θ, radians."""
    planes: PlaneParams = field(default_factory=PlaneParams)

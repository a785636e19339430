"""Parameter dataclasses of the preprocessing and space-partitioning steps.

Defaults follow SPEC.md §6 (θ = 10°, histogram bins of 3 cm, maximum wall thickness
0.3 m) and the TLS noise level of the synthetic presets (σ = 5 mm). Every field is in SI
units: metres, radians, point counts.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

__all__ = [
    "CleanParams",
    "NormalParams",
    "AlignParams",
    "StoreyParams",
    "ClassifyParams",
    "PlaneParams",
    "CellParams",
    "PreprocessParams",
]

THETA = math.radians(10.0)
"""SPEC.md §1: the angle tolerance θ ≤ 10° used for point clustering and plane merging."""


@dataclass(frozen=True)
class CleanParams:
    """Cleaning of the working cloud (SPEC.md §1 "Clean")."""

    voxel_size: float = 0.03
    """Edge of the downsampling voxel, metres; one representative point is kept per voxel.
    0 disables downsampling. The original cloud is always kept for evaluation."""
    max_working_points: int = 200_000
    """When the voxel grid keeps more points than this, the voxel is enlarged (by the square
    root of the excess: the points lie on surfaces) so the working cloud stays about this
    size — this bounds the time of normals, RANSAC and cells (1M → a few seconds)."""
    remove_outliers: bool = True
    """Run the statistical outlier filter on the (downsampled) working cloud."""
    outlier_neighbors: int = 12
    """k of the statistical filter: mean distance to the k nearest neighbours."""
    outlier_std_ratio: float = 3.0
    """A point is an outlier when its mean neighbour distance exceeds the cloud's mean
    by this many standard deviations."""
    min_points: int = 500
    """Fewer usable points than this is an error (too little data to find structure)."""


@dataclass(frozen=True)
class NormalParams:
    """PCA normals over a neighbourhood (SPEC.md §1 "Normals")."""

    radius: float = 0.10
    """Search radius of the neighbourhood, metres; :func:`preprocess` raises it to
    ``radius_voxels`` × the voxel size actually used."""
    radius_voxels: float = 3.0
    """Minimum radius in voxels of the working cloud (so about 20 neighbours remain)."""
    max_nn: int = 30
    """At most this many neighbours enter the PCA."""
    fallback_knn: int = 12
    """Points with too few neighbours within ``radius`` get the PCA normal of this many
    nearest neighbours instead."""
    orient_to_scanner: bool = True
    """Flip normals to face the scanner of each point when scanner positions are known
    (``cloud.scanner_positions`` with ``cloud.scan_index``, or a single position)."""


@dataclass(frozen=True)
class AlignParams:
    """Manhattan alignment from the normals (SPEC.md §1 "Manhattan alignment")."""

    max_normals: int = 100_000
    """Random sample of normals used, for speed."""
    kmeans_restarts: int = 4
    """Restarts of the antipodal-aware (axial) k-means; the best is kept."""
    kmeans_iterations: int = 30
    """Iterations of each k-means run."""
    angle_tolerance: float = THETA
    """A normal within this angle of horizontal is a wall normal, within this angle of
    vertical a floor/ceiling normal, radians."""
    refine_tolerance: float = math.radians(5.0)
    """Normals farther than this from the current dominant directions are ignored in the
    refinement iterations, radians."""
    refine_iterations: int = 4
    """Refinement passes of the vertical and of the yaw."""
    assume_upright: bool = True
    """The scanner was levelled (input z within 45° of up): of the three dominant
    directions the one closest to z is the vertical, and it is oriented to +z. When False,
    the direction whose normals are the densest cluster is taken as vertical."""
    min_wall_fraction: float = 0.05
    """Fewer wall (near-horizontal) normals than this share of the cloud is an error: there
    is no vertical structure to align to."""


@dataclass(frozen=True)
class StoreyParams:
    """Storeys from the z histogram of horizontal points (SPEC.md §1 "Storeys")."""

    bin_size: float = 0.03
    """Histogram bin of z, metres (SPEC.md §6: 3–5 cm)."""
    min_layer_gap: float = 0.15
    """Two histogram peaks closer than this are one layer, metres (a slab is thicker)."""
    layer_half_width: float = 0.06
    """Points within this of a layer's height belong to it, metres (3σ of mobile noise)."""
    grid_cell: float = 0.25
    """Cell of the occupancy grid that measures the area of a layer, metres."""
    min_area_fraction: float = 0.15
    """A layer must cover at least this share of the building's occupied footprint to be a
    floor or a ceiling (a desk or a shelf does not)."""
    min_layer_points: int = 200
    """A layer needs at least this many horizontal points."""
    side_window: float = 0.10
    """Height of the windows above and below a layer in which non-horizontal points are
    counted to tell a floor (walls rise above it) from a ceiling (walls hang below it),
    metres. Keep it below the slab thickness."""
    min_side_contrast: float = 0.3
    """|above − below| / (above + below) must reach this for a layer to be typed floor or
    ceiling; lower contrast (a desk, walls on both sides) discards the layer."""
    min_storey_height: float = 2.2
    """A ceiling lies at least this far above its floor; floors closer than this above a
    floor belong to the same storey, metres."""
    angle_tolerance: float = THETA
    """A normal within this angle of vertical is a horizontal-surface normal, radians."""


@dataclass(frozen=True)
class ClassifyParams:
    """Point clusters (SPEC.md §1 "Point clustering")."""

    angle_tolerance: float = THETA
    """θ: |n_z| ≤ sin θ is a wall point, |n_z| ≥ cos θ a floor/ceiling point, radians."""


@dataclass(frozen=True)
class PlaneParams:
    """Multi-scale RANSAC plane extraction and global refinement (SPEC.md §3.1)."""

    tile_size: float = 4.0
    """Edge of the local voxels (tiles) in x and y, metres (SPEC: 3–5 m)."""
    tile_overlap: float = 0.5
    """Tiles are enlarged by this on every side so walls on tile borders are seen whole."""
    distance_threshold: float = 0.02
    """RANSAC inlier distance, metres; raised to ``noise_factor`` × the robust noise of
    each plane's residuals when the data are noisier (mobile scans)."""
    noise_factor: float = 2.5
    """Inlier band in units of the plane's robust residual σ (1.4826 × MAD)."""
    max_distance_threshold: float = 0.05
    """Cap of the adaptive inlier band, metres (below half the thinnest wall)."""
    iterations: int = 200
    """RANSAC hypotheses per plane."""
    score_sample: int = 2000
    """Hypotheses are scored on a random sample of at most this many points of the tile's
    pool (the chosen one is then refined on all of them)."""
    min_points: int = 60
    """A plane needs at least this many supporting points (of the working cloud)."""
    min_extent: float = 0.3
    """A plane's support must span at least this in its longest direction, metres."""
    max_bend: float = math.radians(1.0)
    """When the two halves of a wall plane's inliers differ in direction by more than this,
    the plane straddles two walls meeting at a small angle and is refitted on the larger
    half, radians."""
    min_fill: float = 0.15
    """A plane's support must occupy at least this share of its bounding rectangle on the
    plane (10 cm cells); occluded walls fill 0.3 and more, chance alignments of clutter
    much less."""
    max_rejections: int = 5
    """Stop searching a tile after this many rejected hypotheses in a row (only clutter is
    left)."""
    max_planes_per_tile: int = 40
    """Stop searching a tile after this many planes."""
    angle_tolerance: float = THETA
    """Orientation constraint: wall planes within θ of vertical, floor/ceiling planes within
    θ of horizontal, radians."""
    normal_agreement: float = math.radians(25.0)
    """A point supports a plane only when its normal is within this angle of the plane's
    (sign ignored), radians; keeps perpendicular walls' points apart at corners."""
    merge_angle: float = math.radians(4.0)
    """Global refinement: merge planes closer than this in angle, radians. Departure from
    SPEC.md (θ = 10°): non-Manhattan plans have walls meeting at 6–7° (syn_house), which
    θ = 10° merged into one bent plane; locally fitted pieces of one wall agree within 1°."""
    merge_distance: float = 0.04
    """... and whose supports lie within this of each other (median point-to-plane distance
    in both directions), metres (≤ the data's nominal accuracy; SPEC.md §3.1). The larger
    of the two planes' adaptive inlier bands is used instead when it is wider (noisy mobile
    data, where the tails of one wall's noise otherwise form parallel planes ±2σ away)."""
    merge_keep: float = 0.9
    """A merge is undone when the refitted plane keeps less than this share of the two
    supports within its band (the two were not one plane)."""
    max_merge_rounds: int = 50
    """Safety bound on the refinement loop (it stops earlier when nothing merges)."""


@dataclass(frozen=True)
class CellParams:
    """Cell decomposition (SPEC.md §3.1 "Cell decomposition")."""

    max_extension: float = 2.0
    """A wall segment's end is extended along its line to the first other wall line it meets
    within this distance, metres; farther it stays a dangling end (no cell edge)."""
    far_extension: bool = True
    """An end that meets no wall line within ``max_extension`` is extended to the first
    wall segment its ray crosses, however far (inside the extent)."""
    far_tolerance: float = 0.05
    """... counting a crossing within this of the other segment's ends, metres."""
    chain_gap: float = 0.6
    """... and on through further wall segments each within this of the previous crossing
    (wall faces, shelves in front of corners; rooms and corridors are wider), metres."""
    snap_overshoot: float = 0.01
    """An extended end goes this far past the wall it meets so noding finds the crossing."""
    extent_margin: float = 0.3
    """The building's extent (the box around the storey's points) is grown by this, metres."""
    min_cell_area: float = 0.02
    """Slivers below this area (m²) are merged into their longest-shared-edge neighbour."""
    min_wall_area: float = 1.0
    """Wall planes with less covered area (m²) are not cut into the floor."""
    min_wall_height_fraction: float = 0.5
    """Wall planes whose support spans less than this share of the height of the ceiling
    they reach (furniture sides, low cupboards) are not cut into the floor."""
    max_top_gap: float = 0.25
    """... nor those whose support's top stays more than this below every ceiling level of
    the storey (tall shelves and cabinets stop short of the ceiling; walls reach it),
    metres."""
    min_ceiling_height: float = 1.8
    """Horizontal planes at least this far above the floor are ceilings that set the z
    levels of the cells, metres (lower ones are furniture tops)."""
    ceiling_margin: float = 0.3
    """Ceilings up to this far above the storey's ceiling height still count, metres."""
    min_face_length: float = 0.02
    """Shared edges shorter than this do not make two cells adjacent, metres."""
    wall_match_distance: float = 0.05
    """A wall plane lies on a shared face when its line is within this of the face's
    segment, metres."""
    wall_match_angle: float = THETA
    """... and within this angle of it, radians."""
    coverage_bin: float = 0.1
    """Length of the bins along a shared face used to measure its coverage by the wall
    plane's points, metres."""
    min_ceiling_area: float = 2.0
    """A horizontal plane needs this much covered area (m²) to be a ceiling level."""


@dataclass(frozen=True)
class PreprocessParams:
    """All steps of :func:`engine.segmentation.preprocess`."""

    clean: CleanParams = field(default_factory=CleanParams)
    normals: NormalParams = field(default_factory=NormalParams)
    align: AlignParams = field(default_factory=AlignParams)
    storeys: StoreyParams = field(default_factory=StoreyParams)
    classify: ClassifyParams = field(default_factory=ClassifyParams)
    planes: PlaneParams = field(default_factory=PlaneParams)
    cells: CellParams = field(default_factory=CellParams)
    align_manhattan: bool = True
    """Rotate the cloud so the dominant directions are the axes (False: only the vertical
    is levelled — for non-Manhattan buildings the yaw is left as it is)."""
    extract_planes: bool = True
    """Run plane extraction (and the cell decomposition when ``decompose_cells``)."""
    decompose_cells: bool = True
    """Build the cell complex of every storey."""

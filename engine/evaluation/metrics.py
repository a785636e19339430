"""Completeness, correctness and accuracy of a source model against a reference (docs/method.md §4).

For every visible reference surface ``R_j`` and buffer size ``b``::

    overlap_j(b) = | ∪_i  R_j ∩ 𝒫_j(S_i ∩ slab_b(R_j)) |
    M_comp(b)    = Σ_j overlap_j(b) / Σ_j |R_j|
    M_corr(b)    = Σ_j overlap_j(b) / Σ_i |S_i|

where ``S_i`` runs over the source surfaces of the same kind (wall / floor / ceiling), in the
same storey, parallel to ``R_j`` within θ; ``slab_b(R_j)`` is the slab ``|n_jᵀp − ρ_j| ≤ b``
around R_j's plane and ``𝒫_j`` the orthogonal projection onto it. *Buffer choice*: each
source surface is clipped to the slab (not accepted or rejected as a whole by its farthest
vertex), so a slightly tilted surface counts for the part of it that lies in the buffer;
the union makes duplicated source surfaces count once. A surface exactly ``b`` away is
inside the buffer.

Accuracy: points sampled on a regular grid on the visible reference surfaces; for each the
closest parallel source surface of the same kind whose outline contains the point's
projection; ``M_acc(r)`` = median of those distances that are ≤ the cut-off ``r``.

Localisation: the share of each reference surface covered (missing when ≤ a threshold) and
the share of each source surface that overlaps some reference surface (redundant when ≤ the
threshold), per buffer size; per-sample distances for colour maps.
"""
from __future__ import annotations

import logging
from dataclasses import asdict, dataclass, field
from typing import Mapping, Optional

import numpy as np

from ..errors import InputError
from ..geometry.transforms import frame_transform
from ..model import BuildingModel
from ..progress import Progress
from .loading import transform_model
from .patches import PlanarPatch, drop_shared_faces, overlap_on, safe_union, patches_from_model, points_inside, sample_patch_grid

__all__ = ["EvaluationParams", "EvaluationResult", "evaluate", "DEFAULT_BUFFERS", "GROUPS"]

log = logging.getLogger(__name__)

DEFAULT_BUFFERS = tuple(round(0.01 * k, 2) for k in range(1, 11))
"""b = r from 1 cm to 10 cm (docs/method.md §4), metres."""
GROUPS = ("wall", "floor", "ceiling")
"""Semantic groups compared like with like."""


@dataclass(frozen=True)
class EvaluationParams:
    """Parameters of :func:`evaluate` (SI units)."""

    buffers: tuple = DEFAULT_BUFFERS
    """Buffer sizes b (= accuracy cut-offs r), metres, ascending."""
    max_angle: float = float(np.radians(10.0))
    """θ: largest angle between a source and a reference surface compared, radians."""
    oriented: bool = True
    """Compare only surfaces facing the same way (normals within θ). Room faces are
    oriented, so this keeps the two sides of a thin wall apart; set False for meshes with
    unreliable face orientation."""
    surface_types: tuple = ("interior",)
    """Shape types whose faces are compared: "interior" (the faces of the room volumes,
    as in the thesis), or "wall"/"slab" for solid elements."""
    groups: tuple = GROUPS
    """Surface kinds evaluated (each against the same kind only)."""
    match_storey: bool = True
    """Compare only surfaces of the same storey (when both models give storey numbers and
    have the same number of storeys)."""
    sample_spacing: float = 0.05
    """Grid spacing of the accuracy samples on the reference surfaces, metres."""
    merge_coplanar: bool = True
    """Merge coplanar faces of one shape (triangulated meshes) before comparing."""
    localisation_buffer: Optional[float] = None
    """Buffer at which missing/redundant verdicts are given (None: the largest buffer)."""
    missing_threshold: float = 0.05
    """A reference (source) surface whose covered share is at most this is missing
    (redundant)."""
    shared_face_gap: float = 0.03
    """Faces of two spaces facing each other at most this far apart (metres) are a virtual
    boundary of an open plan, not a surface: they are left out of the reference and of a
    source model, except where one of the source's walls stands between them (it claims a
    wall there) (:func:`~engine.evaluation.patches.drop_shared_faces`); 0 keeps them."""

    def __post_init__(self):
        b = tuple(float(x) for x in self.buffers)
        if not b or any(x <= 0 for x in b) or list(b) != sorted(b):
            raise ValueError("buffers must be positive and ascending")
        object.__setattr__(self, "buffers", b)


@dataclass(frozen=True, eq=False)
class EvaluationResult:
    """Curves and localisation of one source/reference comparison.

    Attributes
    ----------
    buffers : (k,) float64
        Buffer sizes b = cut-offs r, metres.
    curves : dict
        ``curves[group]["completeness" | "correctness" | "accuracy"]`` : (k,) float64, for
        each group of ``params.groups`` and "all". Accuracy in metres (NaN when no sample
        has a source surface within the cut-off). Completeness is NaN for a group without
        reference surfaces, correctness for one without source surfaces.
    reference, source : list of PlanarPatch
    visible : (n_ref,) bool
        Which reference surfaces were compared.
    reference_covered : (n_ref, k) float64
        Covered share of each reference surface per buffer (0 for interpreted ones).
    source_covered : (n_src, k) float64
        Share of each source surface overlapping some reference surface per buffer.
    samples : (m, 3) float64
        Accuracy sample points on the reference, metres.
    sample_patch : (m,) int64
        Index into ``reference`` of each sample.
    sample_distance : (m,) float64
        Distance to the closest containing source surface, metres (inf if none within the
        largest cut-off).
    missing, redundant : list of str
        Keys of missing reference / redundant source surfaces at the localisation buffer.
    params : EvaluationParams
    """

    buffers: np.ndarray
    curves: dict
    reference: list
    source: list
    visible: np.ndarray
    reference_covered: np.ndarray
    source_covered: np.ndarray
    samples: np.ndarray
    sample_patch: np.ndarray
    sample_distance: np.ndarray
    missing: list
    redundant: list
    params: EvaluationParams
    localisation_index: int = -1
    extra: dict = field(default_factory=dict)

    def curve(self, metric: str, group: str = "all") -> np.ndarray:
        """(k,) float64 — one curve, e.g. ``curve("completeness", "wall")``."""
        return self.curves[group][metric]

    def to_dict(self) -> dict:
        """JSON-ready summary: curves, per-surface shares, verdicts, parameters."""
        def clean(a):
            return [None if not np.isfinite(x) else float(x) for x in np.asarray(a, dtype=float)]

        li = self.localisation_index
        return {
            "buffers_m": clean(self.buffers),
            "curves": {g: {m: clean(v) for m, v in c.items()} for g, c in self.curves.items()},
            "localisation_buffer_m": float(self.buffers[li]),
            "missing": list(self.missing),
            "redundant": list(self.redundant),
            "reference_surfaces": [
                dict(p.to_dict(), visible=bool(self.visible[j]), covered=clean(self.reference_covered[j]))
                for j, p in enumerate(self.reference)],
            "source_surfaces": [dict(p.to_dict(), covered=clean(self.source_covered[i]))
                                for i, p in enumerate(self.source)],
            "samples": int(len(self.samples)),
            "params": {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self.params).items()},
        }


def _as_patches(model, params: EvaluationParams, what: str) -> list[PlanarPatch]:
    if isinstance(model, BuildingModel):
        return patches_from_model(model, params.surface_types, kinds=params.groups, merge=params.merge_coplanar)
    patches = [p for p in model if isinstance(p, PlanarPatch)]
    if len(patches) != len(list(model)):
        raise InputError(f"the {what} must be a BuildingModel or a list of PlanarPatch")
    return [p for p in patches if p.kind in params.groups]


def _aabb(p: PlanarPatch) -> np.ndarray:
    pts = np.vstack(p.outline3d())
    return np.stack([pts.min(axis=0), pts.max(axis=0)])


def _candidates(ref: list, src: list, params: EvaluationParams, use_storey: bool) -> list[list[int]]:
    """For each reference patch, the source patches that may meet its largest buffer."""
    cos_t = np.cos(params.max_angle)
    bmax = params.buffers[-1]
    src_box = [_aabb(s) for s in src]
    src_pts = [np.vstack(s.outline3d()) for s in src]
    out = []
    for r in ref:
        rb = _aabb(r)
        cand = []
        for i, s in enumerate(src):
            if s.kind != r.kind:
                continue
            if use_storey and r.storey >= 0 and s.storey >= 0 and r.storey != s.storey:
                continue
            c = float(r.normal @ s.normal)
            if (c if params.oriented else abs(c)) < cos_t:
                continue
            if np.any(src_box[i][0] > rb[1] + bmax) or np.any(src_box[i][1] < rb[0] - bmax):
                continue
            d = r.signed_distance(src_pts[i])
            if d.min() > bmax or d.max() < -bmax:
                continue
            cand.append(i)
        out.append(cand)
    return out


class _Overlap:
    """``overlap_on(target, other, b)`` for many b: the full projection is computed once and
    reused for every buffer that holds the whole of ``other``; none for buffers that hold
    none of it; only buffers cutting through ``other`` clip it to the slab."""

    def __init__(self, target: PlanarPatch, other: PlanarPatch, pts: np.ndarray):
        self.target, self.other = target, other
        d = target.signed_distance(pts)
        self.near = float(0.0 if d.min() <= 0 <= d.max() else np.abs(d).min())
        self.far = float(np.abs(d).max())
        self._full = False

    def at(self, b: float):
        if b < self.near:
            return None
        if b >= self.far:
            if self._full is False:
                self._full = overlap_on(self.target, self.other, np.inf)
            return self._full
        return overlap_on(self.target, self.other, b)


def _union_area(pieces) -> float:
    pieces = [p for p in pieces if p is not None]
    if not pieces:
        return 0.0
    if len(pieces) == 1:
        return float(pieces[0].area)
    return float(safe_union(pieces).area)


def _walled(model: BuildingModel):
    """``point -> bool``: one of the model's active walls holds the (3,) point (2 cm slack)."""
    from shapely import STRtree, prepare
    from shapely.geometry import Point, Polygon

    items = []
    for w in model.walls:
        if not w.active:
            continue
        fp = w.geometry.footprint()
        if fp is None:
            continue
        poly = Polygon(fp).buffer(0.02)
        prepare(poly)
        items.append((poly, w.bounds[0, 2] - 0.02, w.bounds[1, 2] + 0.02))
    if not items:
        return None
    tree = STRtree([g for g, _, _ in items])

    def walled(p) -> bool:
        pt = Point(float(p[0]), float(p[1]))
        return any(items[i][1] <= p[2] <= items[i][2] and items[i][0].contains(pt) for i in tree.query(pt))
    return walled


def _visible_mask(ref: list, visible) -> np.ndarray:
    if visible is None:
        return np.ones(len(ref), dtype=bool)
    if isinstance(visible, Mapping):
        return np.array([bool(visible.get(p.key, visible.get(p.key.split(".")[0], True))) for p in ref], dtype=bool)
    keys = set(visible)
    return np.array([p.key in keys or p.key.split(".")[0] in keys for p in ref], dtype=bool)


def evaluate(source, reference, params: Optional[EvaluationParams] = None, *, visible=None,
             progress=None, should_stop=None) -> EvaluationResult:
    """Compare a source model with a reference model (docs/method.md §4).

    Parameters
    ----------
    source, reference : BuildingModel or list of PlanarPatch
        The model under test and the ground truth. Their surfaces of
        ``params.surface_types`` are compared. Models whose ``transform``/``offset`` differ
        are compared in the reference's frame.
    params : EvaluationParams
    visible : None, mapping key → bool, or iterable of keys
        Which reference surfaces are visible (see :func:`annotate_visibility`); None: all.
    progress, should_stop : callbacks (see :class:`engine.progress.Progress`).

    Returns
    -------
    EvaluationResult

    Raises
    ------
    InputError
        The reference has no surface to compare.
    """
    params = params or EvaluationParams()
    p = Progress.wrap(progress, should_stop)
    if isinstance(source, BuildingModel) and isinstance(reference, BuildingModel):
        m = frame_transform(source.transform, source.offset, reference.transform, reference.offset)
        if not np.allclose(m, np.eye(4), atol=1e-9):
            log.info("moving the source into the reference's frame (their transforms/offsets differ)")
            source = transform_model(source, m)
    src = _as_patches(source, params, "source")
    if isinstance(source, BuildingModel):
        src = drop_shared_faces(src, params.shared_face_gap, params.max_angle, walled=_walled(source))
    ref = drop_shared_faces(_as_patches(reference, params, "reference"), params.shared_face_gap, params.max_angle)
    if not ref:
        raise InputError(f"the reference has no surfaces of types {params.surface_types} and kinds {params.groups}")
    vis = _visible_mask(ref, visible)
    use_storey = params.match_storey
    if use_storey and isinstance(source, BuildingModel) and isinstance(reference, BuildingModel):
        use_storey = len(source.storeys) == len(reference.storeys)
    buffers = np.asarray(params.buffers, dtype=np.float64)
    k = len(buffers)
    p(0.0, "pairing surfaces")
    cand = _candidates(ref, src, params, use_storey)
    # source patch -> reference patches it may overlap (for per-source localisation)
    back: dict[int, list[int]] = {}
    for j, cs in enumerate(cand):
        if vis[j]:
            for i in cs:
                back.setdefault(i, []).append(j)

    ref_cov_area = np.zeros((len(ref), k))
    src_cov_area = np.zeros((len(src), k))
    src_pts = [np.vstack(s.outline3d()) for s in src]
    ref_pts = [np.vstack(r.outline3d()) for r in ref]
    ref_pairs = {j: [_Overlap(ref[j], src[i], src_pts[i]) for i in cand[j]] for j in range(len(ref))
                 if vis[j] and cand[j]}
    src_pairs = {i: [_Overlap(src[i], ref[j], ref_pts[j]) for j in js] for i, js in back.items()}
    for bi, b in enumerate(buffers):
        p(0.05 + 0.75 * bi / k, f"buffer {b * 100:.0f} cm")
        for j, pairs in ref_pairs.items():
            ref_cov_area[j, bi] = _union_area([o.at(b) for o in pairs])
        for i, pairs in src_pairs.items():
            src_cov_area[i, bi] = _union_area([o.at(b) for o in pairs])

    # accuracy samples
    p(0.8, "accuracy samples")
    samples, sample_patch, sample_dist = [], [], []
    bmax = buffers[-1]
    for j, r in enumerate(ref):
        if not vis[j]:
            continue
        xy = sample_patch_grid(r, params.sample_spacing)
        best = np.full(len(xy), np.inf)
        for i in cand[j]:
            s = src[i]
            pts = r.to3d(xy)
            d = np.abs(s.signed_distance(pts))
            near = d <= max(bmax, 0) + 1e-12
            near &= d < best
            if not near.any():
                continue
            idx = np.flatnonzero(near)
            inside = points_inside(s, s.to2d(pts[idx]))
            best[idx[inside]] = d[idx[inside]]
        samples.append(r.to3d(xy))
        sample_patch.append(np.full(len(xy), j, dtype=np.int64))
        sample_dist.append(best)
    samples = np.vstack(samples) if samples else np.zeros((0, 3))
    sample_patch = np.concatenate(sample_patch) if sample_patch else np.zeros(0, dtype=np.int64)
    sample_dist = np.concatenate(sample_dist) if sample_dist else np.zeros(0)

    p(0.95, "curves")
    ref_area = np.array([r.area for r in ref])
    src_area = np.array([s.area for s in src])
    ref_kind = np.array([r.kind for r in ref])
    src_kind = np.array([s.kind for s in src])
    sample_kind = ref_kind[sample_patch] if len(sample_patch) else np.zeros(0, dtype=ref_kind.dtype)
    curves = {}
    for g in tuple(params.groups) + ("all",):
        rm = vis & ((ref_kind == g) if g != "all" else True)
        sm = (src_kind == g) if g != "all" else np.ones(len(src), dtype=bool)
        num = ref_cov_area[rm].sum(axis=0)
        den_r = ref_area[rm].sum()
        den_s = src_area[sm].sum() if len(src) else 0.0
        comp = num / den_r if den_r > 0 else np.full(k, np.nan)
        corr = num / den_s if den_s > 0 else np.full(k, np.nan)
        dm = sample_dist[(sample_kind == g) if g != "all" else np.ones(len(sample_dist), dtype=bool)]
        acc = np.array([np.median(dm[dm <= r]) if np.any(dm <= r) else np.nan for r in buffers])
        curves[g] = {"completeness": np.minimum(comp, 1.0) if den_r > 0 else comp,
                     "correctness": np.minimum(corr, 1.0) if den_s > 0 else corr,
                     "accuracy": acc}

    li = k - 1 if params.localisation_buffer is None else int(np.argmin(np.abs(buffers - params.localisation_buffer)))
    ref_share = np.where(ref_area[:, None] > 0, ref_cov_area / np.maximum(ref_area, 1e-12)[:, None], 0.0)
    src_share = np.where(src_area[:, None] > 0, src_cov_area / np.maximum(src_area, 1e-12)[:, None], 0.0) \
        if len(src) else np.zeros((0, k))
    ref_share = np.minimum(ref_share, 1.0)
    src_share = np.minimum(src_share, 1.0)
    missing = [r.key for j, r in enumerate(ref) if vis[j] and ref_share[j, li] <= params.missing_threshold]
    redundant = [s.key for i, s in enumerate(src) if src_share[i, li] <= params.missing_threshold]
    p(1.0, "done")
    log.info("evaluated %d source against %d reference surfaces: completeness %.3f, correctness %.3f at b=%.2f m",
             len(src), int(vis.sum()), curves["all"]["completeness"][-1], curves["all"]["correctness"][-1],
             buffers[-1])
    return EvaluationResult(buffers, curves, ref, src, vis, ref_share, src_share, samples, sample_patch,
                            sample_dist, missing, redundant, params, li)

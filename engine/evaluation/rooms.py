"""Rooms of a reconstruction scored against the true model (issue 19).

Per truth storey (with the true spaces of other storeys reaching through its mid-height: a
stairwell, a void; the part of them not under its own rooms): the true rooms joined without a wall between them (open plans) are merged
into one, and so are the model spaces lying mostly inside one such open plan (a split of an
open plan is no error); then model and true rooms are matched one to one by footprint IoU
(Hungarian assignment, pairs below ``min_iou`` do not count). The scores are the room recall
and precision, the mean IoU of the matched pairs, the model spaces that are small (under
``small_area`` m²) or low (under ``low_height`` m) with no true room of that kind matched to
them, and the model's footprint area outside the true interior envelope (the true rooms'
union with the wall gaps closed, :func:`~engine.evaluation.elements.exterior_outline`).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Optional

import numpy as np
import shapely
from scipy.optimize import linear_sum_assignment
from shapely.geometry import Polygon
from shapely.ops import unary_union

from ..errors import InputError
from ..model import BuildingModel
from .footprints import _in_truth_frame, _plan, _storey_of, _truth_storey, _zrange, exterior_outline
from .groups import DisjointSets

__all__ = ["RoomScoreParams", "room_scores", "merge_open_plans", "scanned_spaces"]


@dataclass(frozen=True)
class RoomScoreParams:
    """Thresholds of :func:`room_scores` (metres, m²)."""

    min_iou: float = 0.5
    """A matched pair has at least this footprint IoU."""
    touch: float = 0.05
    """Two footprints within this of each other share a boundary."""
    open_length: float = 0.5
    """Rooms sharing at least this much boundary with no wall on it are one open plan."""
    wall_slack: float = 0.05
    """A wall footprint grown by this covers a shared boundary."""
    small_area: float = 1.5
    """Spaces under this area (m²) are small."""
    low_height: float = 1.8
    """Spaces lower than this are low."""
    envelope_slack: float = 0.1
    """Footprint within this of the true envelope counts as inside."""

    def __post_init__(self):
        for k, v in asdict(self).items():
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise InputError(f"RoomScoreParams.{k} must be a finite number >= 0, not {v!r}")
        if not 0 < self.min_iou <= 1:
            raise InputError(f"RoomScoreParams.min_iou must be in (0, 1], not {self.min_iou!r}")
        if self.touch <= 0:
            raise InputError(f"RoomScoreParams.touch must be > 0, not {self.touch!r}")


def merge_open_plans(plans: list, walls: list, params: RoomScoreParams = RoomScoreParams()) -> list[list[int]]:
    """Groups (lists of indices into ``plans``) of footprints joined along at least
    ``params.open_length`` of boundary that no wall footprint covers."""
    n = len(plans)
    sets = DisjointSets(n)
    wall_u = unary_union([w.buffer(params.wall_slack) for w in walls]) if walls else Polygon()
    grown = [p.buffer(params.touch) for p in plans]
    for i in range(n):
        for j in range(i + 1, n):
            if not grown[i].intersects(grown[j]):
                continue
            shared = grown[i].intersection(grown[j])
            if not wall_u.is_empty:
                shared = shared.difference(wall_u)
            if shared.is_empty:
                continue
            length = float(shared.area) / (2.0 * params.touch)  # a band about 2·touch wide
            if length >= params.open_length:
                sets.union(i, j)
    return sets.groups()


def _model_groups(mplans: list, open_plans: list) -> list[list[int]]:
    """Model spaces lying mostly (> half their area) inside one true open plan are one group
    (a split of an open plan is no error); every other space is its own group."""
    groups, seen = [], set()
    for op in open_plans:
        g = [j for j, p in enumerate(mplans) if j not in seen and p.area > 0
             and float(p.intersection(op).area) > 0.5 * float(p.area)]
        if g:
            groups.append(g)
            seen.update(g)
    groups += [[j] for j in range(len(mplans)) if j not in seen]
    return sorted(groups)


def scanned_spaces(truth: BuildingModel, xyz: np.ndarray, min_share: float = 0.3, margin: float = 0.1,
                   cell: float = 0.25) -> set:
    """Ids of the true spaces a scan can be scored on: scan points (``xyz`` (n, 3), the
    truth's frame) within ``margin`` m of their floor or of their top cover at least
    ``min_share`` of their footprint (``cell`` m grid cells). A roof space with no scanner
    whose floor no ray reaches is left out; a room seen only through its door is in."""
    xyz = np.asarray(xyz, dtype=np.float64)
    out = set()
    for s in truth.spaces:
        lo, hi = s.bounds
        plan = _plan(s, truth)
        if plan.is_empty or plan.area <= 0:
            continue
        box = (xyz[:, 0] > lo[0]) & (xyz[:, 0] < hi[0]) & (xyz[:, 1] > lo[1]) & (xyz[:, 1] < hi[1])
        for z in (lo[2], hi[2]):
            m = box & (np.abs(xyz[:, 2] - z) < margin)
            if not m.any():
                continue
            q = xyz[m]
            q = q[shapely.contains_xy(plan, q[:, 0], q[:, 1])]
            cells = np.unique(np.floor(q[:, :2] / cell).astype(np.int64), axis=0)
            if len(cells) * cell * cell >= min_share * float(plan.area):
                out.add(s.id)
                break
    return out


def room_scores(model: BuildingModel, truth: BuildingModel,
                params: Optional[RoomScoreParams] = None, *, seen: Optional[set] = None) -> dict:
    """Room recall, precision and mean IoU per storey and overall (module doc).

    ``seen``: ids of the true spaces to score (:func:`scanned_spaces`); None: all. Model
    spaces lying mostly in an unscored true space of their storey are left out too.

    Returns
    -------
    dict — ``true``, ``model``, ``matched`` (after open-plan merging), ``recall``,
    ``precision``, ``mean_iou`` (matched pairs; NaN when none), ``small_spurious`` (model
    spaces under the area or height floors that match no such true room), ``outside_m2``
    (model footprint outside the true envelope), ``per_storey`` (the same per truth storey,
    with the ``ious`` of the true rooms: 0 for unmatched), ``storeys`` (model vs truth counts).
    """
    params = params or RoomScoreParams()
    model = _in_truth_frame(model, truth)
    nst = max(len(truth.storeys), 1)
    unseen = [(_truth_storey(s, truth), _plan(s, truth)) for s in truth.spaces
              if seen is not None and s.id not in seen]
    tspaces = [s for s in truth.spaces if seen is None or s.id in seen]
    t_storey = [_truth_storey(s, truth) for s in tspaces]
    m_storey = [_storey_of(s, truth) for s in model.spaces]
    per = []
    tot = dict(true=0, model=0, matched=0, small_spurious=0)
    ious_all, outside = [], 0.0
    for k in range(nst):
        trooms = [s for s, st in zip(tspaces, t_storey) if st == k or (st == -1 and k == 0)
                  or (st != k and _spans(s, truth, k))]
        mrooms = [s for s, st in zip(model.spaces, m_storey) if st == k or (st == -1 and k == 0)]
        tplans = [_plan(s, truth) for s in trooms]
        own = unary_union([p for s, p in zip(trooms, tplans) if _truth_storey(s, truth) == k] or [Polygon()])
        tplans = [p if _truth_storey(s, truth) == k else p.difference(own) for s, p in zip(trooms, tplans)]
        kept = [i for i, p in enumerate(tplans) if p.area > 0.05]
        trooms, tplans = [trooms[i] for i in kept], [tplans[i] for i in kept]
        mplans = [_plan(s, model) for s in mrooms]
        keep = [j for j, p in enumerate(mplans)
                if not any(ku == k and float(p.intersection(u).area) > 0.5 * float(p.area) for ku, u in unseen)]
        mrooms, mplans = [mrooms[j] for j in keep], [mplans[j] for j in keep]
        if not trooms and not mrooms:
            continue
        twalls = [_plan(w, truth) for w in truth.walls if _truth_storey(w, truth) == k or _spans(w, truth, k)]
        tgroups = merge_open_plans(tplans, [w for w in twalls if not w.is_empty], params)
        tg = [unary_union([tplans[i] for i in g]) for g in tgroups]
        mgroups = _model_groups(mplans, [g for g, idx in zip(tg, tgroups) if len(idx) > 1])
        mg = [unary_union([mplans[i] for i in g]) for g in mgroups]
        iou = np.zeros((len(tg), len(mg)))
        for i, a in enumerate(tg):
            for j, b in enumerate(mg):
                if a.intersects(b):
                    inter = float(a.intersection(b).area)
                    if inter > 0:
                        iou[i, j] = inter / float(a.union(b).area)
        pairs = []
        if iou.size:
            ri, ci = linear_sum_assignment(-iou)
            pairs = [(int(i), int(j), float(iou[i, j])) for i, j in zip(ri, ci) if iou[i, j] >= params.min_iou]
        t_iou = np.zeros(len(tg))
        for i, _, v in pairs:
            t_iou[i] = v
        m2t = {j: i for i, j, _ in pairs}
        t_small = [any(_small(trooms[x], tplans[x], params) for x in g) for g in tgroups]
        spurious = sum(1 for j, g in enumerate(mgroups) for x in g
                       if _small(mrooms[x], mplans[x], params) and not (j in m2t and t_small[m2t[j]]))
        env = unary_union([exterior_outline(truth, k)] + [p for s, p in zip(trooms, tplans)
                                                          if _truth_storey(s, truth) != k])
        env = env.buffer(params.envelope_slack) if not env.is_empty else env
        out_k = sum(float(p.difference(env).area) if not env.is_empty else float(p.area) for p in mg)
        outside += out_k
        per.append(dict(storey=k, true=len(tg), model=len(mg), matched=len(pairs),
                        recall=len(pairs) / len(tg) if tg else float("nan"),
                        precision=len(pairs) / len(mg) if mg else float("nan"),
                        mean_iou=float(np.mean([v for _, _, v in pairs])) if pairs else float("nan"),
                        ious=[round(float(v), 3) for v in t_iou], small_spurious=spurious,
                        outside_m2=round(out_k, 3),
                        true_groups=[[trooms[x].name or trooms[x].id for x in g] for g in tgroups],
                        true_group_ids=[[trooms[x].id for x in g] for g in tgroups]))
        tot["true"] += len(tg)
        tot["model"] += len(mg)
        tot["matched"] += len(pairs)
        tot["small_spurious"] += spurious
        ious_all += [v for _, _, v in pairs]
    return dict(tot, recall=tot["matched"] / tot["true"] if tot["true"] else float("nan"),
                precision=tot["matched"] / tot["model"] if tot["model"] else float("nan"),
                mean_iou=float(np.mean(ious_all)) if ious_all else float("nan"),
                outside_m2=round(outside, 3), per_storey=per,
                storeys={"model": len(model.storeys), "truth": len(truth.storeys)})


def _spans(s, truth: BuildingModel, k: int) -> bool:
    """Does a true space of another storey (a stairwell, a void) reach through storey k's
    mid-height? Then it is a room of that storey too."""
    if not 0 <= k < len(truth.storeys):
        return False
    st = truth.storeys[k]
    z0, z1 = _zrange(s)
    mid = 0.5 * (st.floor_z + st.ceiling_z)
    return z0 < mid < z1


def _small(s, plan, params: RoomScoreParams) -> bool:
    z0, z1 = _zrange(s)
    return float(plan.area) < params.small_area or (z1 - z0) < params.low_height

"""Plan view (top view) of a reconstructed model, optionally over the true one (issue 19).

:func:`plan_view` writes one PNG with one panel per storey, side by side: the true room
footprints as grey outlines (with their names, in grey) and the true walls as a light grey
fill; the reconstructed spaces filled, one colour each, labelled with name, area (and, with
a truth, the footprint IoU of the best-overlapping true room; with a ``confidence``
attribute, that figure); the reconstructed walls as dark bars (their footprints); doors
(magenta) and windows (cyan); optionally a thinned slice of the scan at each storey's
mid-height as tiny dots; a scale bar and a legend. x right, y up, metres, in the truth's
frame when a truth is given (the model is moved into it), else in the model's frame.

matplotlib (Agg backend) is imported only when a picture is drawn; without it the call
raises :class:`~engine.errors.MissingDependencyError`.
"""
from __future__ import annotations

import os
from typing import Optional

import numpy as np
from shapely.geometry import Polygon
from shapely.ops import unary_union

from ..errors import InputError, MissingDependencyError
from ..fileutil import atomic_path
from ..geometry.polygon import polygon_parts
from ..geometry.transforms import apply_transform, frame_transform
from ..model import BuildingModel, ShapeType, Storey
from ..pointcloud import PointCloud
from .footprints import _in_truth_frame, _plan, _storey_of, _truth_storey, _zrange

__all__ = ["plan_view", "plan_differences", "MAX_SLICE_POINTS", "SLICE_HALF_HEIGHT"]

MAX_SLICE_POINTS = 30_000
"""At most this many scan points are drawn per storey (an even subsample of the slice)."""
SLICE_HALF_HEIGHT = 0.1
"""The scan slice is the points within this (metres) of a storey's mid-height."""
_MARGIN = 1.0
"""Metres shown around everything drawn."""
_PAD_W, _PAD_H, _LEGEND_W = 0.9, 1.0, 1.9
"""Inches around each map (axis labels, title) and of the legend column."""
_COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2", "#bcbd22",
           "#17becf", "#aec7e8", "#ffbb78", "#98df8a", "#ff9896", "#c5b0d5", "#c49c94", "#f7b6d2",
           "#dbdb8d", "#9edae5")
"""Fill colours of the reconstructed spaces, in turn."""
_WALL, _TRUE_WALL, _TRUE_ROOM = "#222222", "#d9d9d9", "#7f7f7f"
_DOOR, _WINDOW, _POINTS, _TRUE_WALL_EDGE = "#d000d0", "#00a0d0", "#e8400c", "#b8b8b8"


def _storey_list(model: BuildingModel, truth: Optional[BuildingModel]) -> tuple:
    st = (truth.storeys if truth is not None else model.storeys)
    if st:
        return tuple(st)
    shapes = list((truth or model).shapes) + list(model.shapes)
    if not shapes:
        return (Storey(0, 0.0, 3.0),)
    z = np.array([_zrange(s) for s in shapes])
    return (Storey(0, float(z[:, 0].min()), float(z[:, 1].max())),)


def _of_storey(s, ref: BuildingModel, storeys: tuple, k: int, own: bool) -> bool:
    """Is shape ``s`` on storey ``k`` of ``storeys`` (its storey by height, or reaching
    through the storey's mid-height)? ``own``: ``s.storey`` is an index into ``storeys``."""
    if len(storeys) == 1:
        return True
    k_s = (s.storey if own and 0 <= s.storey < len(storeys) else _storey_of(s, ref))
    if k_s == k:
        return True
    z0, z1 = _zrange(s)
    mid = 0.5 * (storeys[k].floor_z + storeys[k].ceiling_z)
    return s.type == ShapeType.WALL and z0 < mid < z1


def _path(geom):
    """matplotlib Path of a shapely (multi)polygon, holes included."""
    from matplotlib.path import Path

    paths = []
    for p in polygon_parts(geom):
        for ring in [p.exterior, *p.interiors]:
            c = np.asarray(ring.coords)[:, :2]
            if len(c) >= 4:
                paths.append(Path(c, closed=True))
    return Path.make_compound_path(*paths) if paths else None


def _patch(ax, geom, **kw):
    from matplotlib.patches import PathPatch

    p = _path(geom)
    if p is not None:
        ax.add_patch(PathPatch(p, **kw))


def _iou(a, b) -> float:
    if a.is_empty or b.is_empty or not a.intersects(b):
        return 0.0
    return float(a.intersection(b).area) / float(a.union(b).area)


def _scale_length(span: float) -> float:
    for v in (20.0, 10.0, 5.0, 2.0, 1.0, 0.5):
        if v <= 0.25 * span:
            return v
    return 0.2


def _cloud_in_frame(cloud: PointCloud, model: BuildingModel, truth: Optional[BuildingModel]) -> np.ndarray:
    ref = truth if truth is not None else model
    m = frame_transform(np.eye(4), cloud.offset, ref.transform, ref.offset)
    xyz = np.asarray(cloud.xyz, dtype=np.float64)
    return xyz if np.allclose(m, np.eye(4), atol=1e-9) else apply_transform(m, xyz)


def plan_view(model: BuildingModel, truth: Optional[BuildingModel] = None, *, storey: Optional[int] = None,
              cloud: Optional[PointCloud] = None, path: str | os.PathLike, title: str = "",
              dpi: int = 100, panel_size: tuple = (7.0, 7.0), legend_width: float = _LEGEND_W,
              max_points: int = MAX_SLICE_POINTS) -> dict:
    """Write a plan view of ``model`` (module doc) to the PNG ``path``, atomically.

    Parameters
    ----------
    model : the reconstruction.
    truth : the true model; its storeys make the panels, its rooms and walls are drawn
        under the model's, and the model is moved into its frame.
    storey : index of the one storey to draw (of the truth's storeys, else the model's),
        or a sequence of them; None: every storey with a room (true or modelled), side by side.
    cloud : the scan; a thinned slice at each storey's mid-height is drawn as dots.
    path : the PNG written.
    title : the figure's title (default: the truth's or the model's name).
    dpi, panel_size, legend_width : each storey's map is drawn at one scale (inches per
        metre) so that the extent of everything drawn plus a metre around it fits in
        ``panel_size`` (width, height) inches; the picture is ``n_panels * (map width +
        0.9) + legend_width`` by ``map height + 0.9`` inches, times ``dpi`` pixels.
    max_points : at most this many scan points per panel.

    Returns
    -------
    dict — ``path``, ``width``/``height`` (pixels), ``panels`` (per storey drawn: its
    ``storey`` index, ``name``, ``spaces`` and ``walls`` of the model drawn, ``true_rooms``,
    ``points`` drawn, and ``labels``: the text of each space drawn).

    Raises
    ------
    InputError — ``storey`` is not an index of the storeys.
    MissingDependencyError — matplotlib is not installed.
    """
    storeys = _storey_list(model, truth)
    if storey is None:
        ks = list(range(len(storeys)))
    else:
        ks = list(storey) if isinstance(storey, (list, tuple, range, np.ndarray)) else [storey]
        for k in ks:
            if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or not 0 <= k < len(storeys):
                raise InputError(f"storey must be an index 0..{len(storeys) - 1} of the storeys (or a sequence "
                                 f"of them), not {storey!r}")
        if not ks:
            raise InputError("storey: no storey to draw (an empty sequence)")
        ks = [int(k) for k in ks]
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.lines import Line2D
        from matplotlib.patches import Patch
    except ImportError:
        raise MissingDependencyError("matplotlib", "the plan view") from None
    own = truth is None and bool(model.storeys)
    m = _in_truth_frame(model, truth) if truth is not None else model
    ref = truth if truth is not None else m
    xyz = _cloud_in_frame(cloud, model, truth) if cloud is not None and len(cloud) else None

    mspaces = [(s, _plan(s, m)) for s in m.spaces]
    mwalls = [(s, _plan(s, m)) for s in m.walls]
    mopen = [(s, _plan(s, m)) for s in m.doors + m.windows]
    tspaces = [(s, _plan(s, truth)) for s in truth.spaces] if truth is not None else []
    twalls = [(s, _plan(s, truth)) for s in truth.walls] if truth is not None else []
    everything = [p for _, p in mspaces + mwalls + tspaces + twalls if not p.is_empty]
    if everything:
        lo = np.array(unary_union(everything).bounds[:2]) - _MARGIN
        hi = np.array(unary_union(everything).bounds[2:]) + _MARGIN
    else:
        lo, hi = np.array([-5.0, -5.0]), np.array([5.0, 5.0])

    if storey is None and len(ks) > 1:  # leave out storeys with no room, true or modelled
        full = [k for k in ks if any(_of_storey(s, ref, storeys, k, own) for s, _ in mspaces)
                or any(_truth_storey(s, truth) == k for s, _ in tspaces)]
        ks = full or ks
    ext = hi - lo
    scale = min(float(panel_size[0]) / ext[0], float(panel_size[1]) / ext[1])  # inches per metre
    aw, ah = ext[0] * scale, ext[1] * scale
    pw = aw + _PAD_W
    W, H = len(ks) * pw + legend_width, ah + _PAD_H
    fig = plt.figure(figsize=(W, H), dpi=dpi)
    panels = []
    color_of = {}
    for n, k in enumerate(ks):
        ax = fig.add_axes([(n * pw + 0.65) / W, 0.45 / H, aw / W, ah / H])
        st = storeys[k]
        mid = 0.5 * (st.floor_z + st.ceiling_z)
        info = dict(storey=k, name=st.name or f"storey {k}", spaces=0, walls=0, true_rooms=0, points=0, labels=[])
        if xyz is not None:
            idx = np.flatnonzero(np.abs(xyz[:, 2] - mid) <= SLICE_HALF_HEIGHT)
            if len(idx) > max_points:
                idx = idx[:: int(np.ceil(len(idx) / max_points))]
            ax.scatter(xyz[idx, 0], xyz[idx, 1], s=0.4, c=_POINTS, linewidths=0, rasterized=True, zorder=4.5)
            info["points"] = int(len(idx))
        for s, p in twalls:
            if _of_storey(s, truth, storeys, k, False):
                _patch(ax, p, facecolor=_TRUE_WALL, edgecolor="none", zorder=0)
                _patch(ax, p, facecolor="none", edgecolor=_TRUE_WALL_EDGE, hatch="////", lw=0.4, zorder=3.6)
        trooms = []
        for s, p in tspaces:
            k_s = _truth_storey(s, truth)
            z0, z1 = _zrange(s)
            if k_s == k or (len(storeys) == 1) or z0 < mid < z1:
                trooms.append((s, p))
                _patch(ax, p, facecolor="none", edgecolor=_TRUE_ROOM, lw=1.3, ls="-" if k_s == k else "--",
                       zorder=4)
        info["true_rooms"] = len(trooms)
        for s, p in mspaces:
            if not _of_storey(s, ref, storeys, k, own) or p.is_empty:
                continue
            c = color_of.setdefault(s.id, _COLORS[len(color_of) % len(_COLORS)])
            _patch(ax, p, facecolor=c, alpha=0.45, edgecolor=c, lw=0.8, zorder=2)
            label = f"{s.name or s.id}\n{p.area:.1f} m²"
            ious = [_iou(p, q) for _, q in trooms]
            if ious:
                label += f"\nIoU {max(ious):.2f}"
            conf = s.attributes.get("confidence")
            if isinstance(conf, (int, float)) and not isinstance(conf, bool):
                label += f"\nconf {float(conf):.2f}"
            rp = p.representative_point()
            ax.text(rp.x, rp.y, label, fontsize=6.5, ha="center", va="center", zorder=6,
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec=c, alpha=0.75, lw=0.6))
            info["spaces"] += 1
            info["labels"].append(label.replace("\n", " "))
        for s, p in trooms:  # true names in the top left corner of the room
            x0, _, _, y1 = p.bounds
            ax.text(x0 + 0.12, y1 - 0.1, s.name or s.id, fontsize=5.5, ha="left", va="top",
                    color="#555555", style="italic", zorder=5, clip_on=True)
        for s, p in mwalls:
            if _of_storey(s, ref, storeys, k, own) and not p.is_empty:
                _patch(ax, p, facecolor=_WALL, edgecolor=_WALL, lw=0.3, zorder=3)
                info["walls"] += 1
        for s, p in mopen:
            if _of_storey(s, ref, storeys, k, own) and not p.is_empty:
                col = _DOOR if s.type == ShapeType.DOOR else _WINDOW
                _patch(ax, p, facecolor=col, edgecolor=col, lw=0.8, zorder=3.5)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal", adjustable="box")
        ax.grid(True, lw=0.3, color="#e0e0e0", zorder=-1)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("x (m)", fontsize=8)
        if n == 0:
            ax.set_ylabel("y (m)", fontsize=8)
        ax.set_title(f"{info['name']}  (floor {st.floor_z:.2f} m, slice at {mid:.2f} m)", fontsize=9)
        bar = _scale_length(float(hi[0] - lo[0]))
        x0, y0 = lo[0] + 0.3, lo[1] + 0.4 * _MARGIN  # in the margin below the building
        ax.plot([x0, x0 + bar], [y0, y0], color="black", lw=3, solid_capstyle="butt", zorder=7)
        ax.text(x0 + bar + 0.2, y0, f"{bar:g} m", ha="left", va="center", fontsize=7, zorder=7)
        panels.append(info)
    handles = [Patch(fc="#9ecae1", ec="#1f77b4", alpha=0.6, label="model space"),
               Patch(fc=_WALL, ec=_WALL, label="model wall"),
               Patch(fc=_DOOR, ec=_DOOR, label="model door"),
               Patch(fc=_WINDOW, ec=_WINDOW, label="model window")]
    if truth is not None:
        handles += [Line2D([], [], color=_TRUE_ROOM, lw=1.3, label="true room"),
                    Line2D([], [], color=_TRUE_ROOM, lw=1.3, ls="--", label="true room of\nanother storey"),
                    Patch(fc=_TRUE_WALL, ec=_TRUE_WALL_EDGE, hatch="////", lw=0.4, label="true wall"),
                    Line2D([], [], ls="", label="label: model name,\narea, best IoU with\none true room")]
    if xyz is not None:
        handles.append(Line2D([], [], ls="", marker="o", ms=2, color=_POINTS,
                              label=f"scan, ±{SLICE_HALF_HEIGHT:g} m\nat mid-height"))
    fig.legend(handles=handles, loc="upper left", bbox_to_anchor=((len(ks) * pw + 0.05) / W, (0.45 + ah) / H), fontsize=7,
               frameon=False)
    fig.suptitle(title or (truth.name if truth is not None else model.name) or "plan view", fontsize=10,
                 y=1 - 0.06 / H, va="top")
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    plt.close(fig)
    return dict(path=os.fspath(path), width=int(round(W * dpi)), height=int(round(H * dpi)), panels=panels)


def plan_differences(model: BuildingModel, truth: BuildingModel, *, storeys=None, slack: float = 0.1,
                     min_area: float = 0.1) -> list[dict]:
    """Where the plan of ``model`` leaves the truth's, per truth storey: the pieces (each at
    least ``min_area`` m²) of

    * ``extra wall`` — model wall footprint farther than ``slack`` (m) from every true wall;
    * ``missing wall`` — true wall footprint farther than ``slack`` from every model wall;
    * ``space off rooms`` — model space footprint farther than ``slack`` from every true room
      (on a true wall, or outside the building);
    * ``room uncovered`` — true room footprint farther than ``slack`` from every model space.

    A storey's shapes are those of :func:`plan_view`'s panel (spaces by their storey, walls
    and true rooms also when they reach through its mid-height). The model is moved into the
    truth's frame. ``storeys``: the truth storey indices to look at (default: all).

    Returns
    -------
    list of dict — ``storey`` (truth index), ``storey_name``, ``kind``, ``area`` (m²),
    ``bbox`` (x0, y0, x1, y1, metres), ``names`` (the model or true shapes concerned),
    largest first within a storey.
    """
    if not truth.storeys:
        raise InputError("plan_differences needs a truth with storeys")
    m = _in_truth_frame(model, truth)
    wanted = None if storeys is None else {int(k) for k in storeys}
    storeys = tuple(truth.storeys)
    out = []
    for k, st in enumerate(storeys):
        if wanted is not None and k not in wanted:
            continue
        mid = 0.5 * (st.floor_z + st.ceiling_z)
        mw = [(s, _plan(s, m)) for s in m.walls if _of_storey(s, truth, storeys, k, False)]
        tw = [(s, _plan(s, truth)) for s in truth.walls if _of_storey(s, truth, storeys, k, False)]
        ms = [(s, _plan(s, m)) for s in m.spaces if _of_storey(s, truth, storeys, k, False)]
        ts = [(s, _plan(s, truth)) for s in truth.spaces
              if _truth_storey(s, truth) == k or len(storeys) == 1 or _zrange(s)[0] < mid < _zrange(s)[1]]
        if not ms and not ts:
            continue
        for kind, a, b in (("extra wall", mw, tw), ("missing wall", tw, mw), ("space off rooms", ms, ts),
                           ("room uncovered", ts, ms)):
            ua = unary_union([p for _, p in a if not p.is_empty] or [Polygon()])
            ub = unary_union([p for _, p in b if not p.is_empty] or [Polygon()])
            diff = ua.difference(ub.buffer(slack, join_style="mitre")) if not ub.is_empty else ua
            found = []
            for piece in polygon_parts(diff):
                if piece.area < min_area:
                    continue
                names = sorted({(s.name or s.id) for s, p in a if p.intersects(piece) and
                                float(p.intersection(piece).area) > 0.5 * min_area})
                found.append(dict(storey=k, storey_name=st.name or f"storey {k}", kind=kind,
                                  area=round(float(piece.area), 2),
                                  bbox=tuple(round(float(v), 2) for v in piece.bounds), names=names))
            out += sorted(found, key=lambda d: -d["area"])
    return out

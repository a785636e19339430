"""Top-view picture of a synthetic scene: points by truth label, true rooms and walls."""
from __future__ import annotations

import os
from typing import Optional

import numpy as np

from ..errors import MissingDependencyError
from ..fileutil import atomic_path
from ..model import BuildingModel, ShapeType
from ..pointcloud import PointCloud
from .scan import LABEL_NAMES

__all__ = ["top_view_png", "MAX_DRAWN_POINTS"]

MAX_DRAWN_POINTS = 300_000
"""At most this many points are drawn (an even subsample); the picture stays the same."""
_LABEL_COLORS = ("#4c72b0", "#c0c0c0", "#f0c05a", "#dd5555", "#8fbf7a", "#30c0e0", "#a0522d")
"""Colour of each label value (wall, floor, ceiling, clutter, outside, glass, door leaf)."""
_DRAWN = (4, 1, 3, 0, 6, 5)
"""Labels drawn, bottom to top (ceilings would hide everything)."""
_OUTSIDE_MARGIN = 3.0
"""The picture shows this much (metres) around the building's walls."""


def top_view_png(path: str | os.PathLike, cloud: PointCloud, truth: BuildingModel, *,
                 title: str = "", storey: Optional[int] = None, dpi: int = 110) -> None:
    """Write a top view (x right, y up, metres) of ``cloud`` coloured by ``fields["label"]``
    (ceiling points left out so the floor plan shows) with the outlines of the true spaces
    (green), walls (black), doors (magenta) and windows (cyan), and the scanner positions;
    points outside the building (surroundings) are drawn up to a few metres from it.

    ``storey`` : draw only that storey; None draws one panel per storey, side by side.
    Large clouds are drawn from an even subsample of :data:`MAX_DRAWN_POINTS` points.
    Written atomically.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.lines import Line2D
    except ImportError:  # pragma: no cover
        raise MissingDependencyError("matplotlib", "the top-view picture") from None
    xyz = cloud.xyz
    lab = cloud.fields.get("label", np.zeros(len(xyz), np.int32))
    if storey is not None and 0 <= storey < len(truth.storeys):
        storeys = [storey]
    else:
        storeys = list(range(len(truth.storeys))) or [None]
    fig, axes = plt.subplots(1, len(storeys), figsize=(9 * len(storeys) + 1.5, 8), squeeze=False)
    sp = cloud.scanner_positions if cloud.scanner_positions is not None else np.zeros((0, 3))
    for ax, s in zip(axes[0], storeys):
        keep = lab != 2  # ceilings would hide everything
        shapes = list(truth.shapes)
        sps = sp
        if s is not None:
            st = truth.storeys[s]
            keep &= (xyz[:, 2] > st.floor_z - 0.2) & (xyz[:, 2] < st.ceiling_z + 0.2)
            shapes = [x for x in shapes if x.storey == s]
            sps = sp[(sp[:, 2] > st.floor_z) & (sp[:, 2] < st.ceiling_z)]
        idx = np.flatnonzero(keep)
        if len(idx) > MAX_DRAWN_POINTS:
            idx = idx[:: int(np.ceil(len(idx) / MAX_DRAWN_POINTS))]
        for k in _DRAWN:
            sel = idx[lab[idx] == k]
            ax.scatter(xyz[sel, 0], xyz[sel, 1], s=0.05, c=_LABEL_COLORS[k], rasterized=True, linewidths=0)
        for x in shapes:
            fp = x.footprint()
            if fp is None:
                continue
            ring = np.vstack([fp, fp[:1]])
            if x.type == ShapeType.INTERIOR:
                ax.plot(ring[:, 0], ring[:, 1], color="#2a9d3a", lw=0.8)
                c = fp.mean(axis=0)
                ax.text(c[0], c[1], x.name, fontsize=7, ha="center", va="center", color="#114411")
            elif x.type == ShapeType.WALL:
                ax.plot(ring[:, 0], ring[:, 1], color="black", lw=0.6)
            elif x.type == ShapeType.DOOR:
                ax.plot(ring[:, 0], ring[:, 1], color="magenta", lw=1.2)
            elif x.type == ShapeType.WINDOW:
                ax.plot(ring[:, 0], ring[:, 1], color="#0090c0", lw=1.2)
        walls = [x.footprint() for x in shapes if x.type == ShapeType.WALL and x.footprint() is not None]
        if walls:
            lo, hi = np.vstack(walls).min(axis=0), np.vstack(walls).max(axis=0)
            ax.set_xlim(lo[0] - _OUTSIDE_MARGIN, hi[0] + _OUTSIDE_MARGIN)
            ax.set_ylim(lo[1] - _OUTSIDE_MARGIN, hi[1] + _OUTSIDE_MARGIN)
        if len(sps):
            ax.plot(sps[:, 0], sps[:, 1], "k+", ms=5)
        ax.set_aspect("equal")
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        if s is not None and len(storeys) > 1:
            ax.set_title(truth.storeys[s].name or f"storey {s}", fontsize=9)
    handles = [Line2D([], [], ls="", marker="o", ms=5, color=_LABEL_COLORS[k], label=LABEL_NAMES[k])
               for k in (0, 1, 3, 4, 5, 6)]
    handles.append(Line2D([], [], ls="", marker="+", ms=6, color="k", label="scanner"))
    handles.append(Line2D([], [], color="#2a9d3a", label="true space"))
    handles.append(Line2D([], [], color="black", label="true wall"))
    handles.append(Line2D([], [], color="magenta", label="door"))
    handles.append(Line2D([], [], color="#0090c0", label="window"))
    axes[0][-1].legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)
    fig.suptitle(title or truth.name)
    fig.tight_layout()
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    plt.close(fig)

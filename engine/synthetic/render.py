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
_LABEL_COLORS = ("#4c72b0", "#c0c0c0", "#f0c05a", "#dd5555")


def top_view_png(path: str | os.PathLike, cloud: PointCloud, truth: BuildingModel, *,
                 title: str = "", storey: Optional[int] = None, dpi: int = 110) -> None:
    """Write a top view (x right, y up, metres) of ``cloud`` coloured by ``fields["label"]``
    with the outlines of the true spaces (green), walls (black) and doors (magenta).

    ``storey`` : only that storey's shapes and the points between its floor and ceiling;
    None draws everything. Points with z above 1.0 m over their storey floor are drawn
    first so walls stay visible. Written atomically.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:  # pragma: no cover
        raise MissingDependencyError("matplotlib", "the top-view picture") from None
    xyz = cloud.xyz
    lab = cloud.fields.get("label", np.zeros(len(xyz), np.int32))
    keep = np.ones(len(xyz), bool)
    shapes = list(truth.shapes)
    if storey is not None and 0 <= storey < len(truth.storeys):
        st = truth.storeys[storey]
        keep &= (xyz[:, 2] > st.floor_z - 0.2) & (xyz[:, 2] < st.ceiling_z + 0.2)
        shapes = [s for s in shapes if s.storey == storey]
    idx = np.flatnonzero(keep & (lab != 2))  # ceilings would hide everything
    if len(idx) > MAX_DRAWN_POINTS:
        idx = idx[:: int(np.ceil(len(idx) / MAX_DRAWN_POINTS))]
    fig, ax = plt.subplots(figsize=(10, 8))
    for k in (1, 3, 0):
        sel = idx[lab[idx] == k]
        ax.scatter(xyz[sel, 0], xyz[sel, 1], s=0.05, c=_LABEL_COLORS[k], rasterized=True, linewidths=0)
    for s in shapes:
        fp = s.footprint()
        if fp is None:
            continue
        ring = np.vstack([fp, fp[:1]])
        if s.type == ShapeType.INTERIOR:
            ax.plot(ring[:, 0], ring[:, 1], color="#2a9d3a", lw=0.8)
            c = fp.mean(axis=0)
            ax.text(c[0], c[1], s.name, fontsize=7, ha="center", va="center", color="#114411")
        elif s.type == ShapeType.WALL:
            ax.plot(ring[:, 0], ring[:, 1], color="black", lw=0.6)
        elif s.type == ShapeType.DOOR:
            ax.plot(ring[:, 0], ring[:, 1], color="magenta", lw=1.2)
    if cloud.scanner_positions is not None and len(cloud.scanner_positions):
        sp = cloud.scanner_positions
        ax.plot(sp[:, 0], sp[:, 1], "k+", ms=5, label="scanner")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or truth.name)
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], ls="", marker="o", ms=5, color=_LABEL_COLORS[k], label=LABEL_NAMES[k])
               for k in (0, 1, 3)]
    handles.append(Line2D([], [], ls="", marker="+", ms=6, color="k", label="scanner"))
    handles.append(Line2D([], [], color="#2a9d3a", label="true space"))
    handles.append(Line2D([], [], color="black", label="true wall"))
    handles.append(Line2D([], [], color="magenta", label="door"))
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7)
    fig.tight_layout()
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, dpi=dpi, format="png")
    plt.close(fig)

"""Evaluation outputs: JSON, CSV, a PNG plot of the three curves, coloured PLY files.

Files written by :func:`write_evaluation_outputs` into ``out_dir`` (each atomically):

* ``evaluation.json`` — curves per group, per-surface shares, missing/redundant surfaces;
* ``curves.csv`` — one row per group and buffer size;
* ``curves.png`` — completeness, correctness and accuracy over b = r (matplotlib, Agg);
* ``reference_surfaces.ply`` — reference surfaces coloured by covered share (red 0 → green 1,
  grey = interpreted), vertex property ``covered``;
* ``source_surfaces.ply`` — source surfaces coloured the same way by their overlap share;
* ``accuracy_points.ply`` — the accuracy samples with their ``distance`` (metres, -1 when
  no source surface is within the largest cut-off), coloured blue (0) → red (≥ largest b);
* ``elements.json`` — only when ``elements`` is given: the element scores of
  :func:`engine.evaluation.elements.evaluate_elements` (also under ``"elements"`` in
  ``evaluation.json``).
"""
from __future__ import annotations

import csv
import io
import json
import os
from typing import Mapping, Optional

import numpy as np

from ..fileutil import atomic_path, atomic_write_text
from ..io import ply
from .metrics import EvaluationResult
from .patches import polygon_triangles

__all__ = ["write_evaluation_outputs", "write_ply_arrays", "ramp_colors", "write_patch_mesh"]

GREY = (160, 160, 160)


def write_ply_arrays(path, vertex: Mapping[str, np.ndarray], faces: Optional[np.ndarray] = None) -> None:
    """Write a binary little-endian PLY with the given vertex properties (and triangles):
    :func:`engine.io.ply.write_ply_arrays` (types follow the arrays; ``x``, ``y``, ``z`` first;
    ``faces`` (m, 3) int or None)."""
    ply.write_ply_arrays(path, vertex, faces, comments=("written by indoor engine.evaluation",))


def ramp_colors(values: np.ndarray, lo: float, hi: float, *, reverse: bool = False) -> np.ndarray:
    """(n,) values → (n, 3) uint8 colours on a red → yellow → green ramp (NaN → grey)."""
    v = np.asarray(values, dtype=np.float64)
    t = np.clip((v - lo) / max(hi - lo, 1e-12), 0, 1)
    if reverse:
        t = 1 - t
    r = np.where(t < 0.5, 1.0, 2 * (1 - t))
    g = np.where(t < 0.5, 2 * t, 1.0)
    out = np.column_stack([r, g, np.zeros_like(t)]) * 220
    out[~np.isfinite(v)] = GREY
    return out.astype(np.uint8)


def write_patch_mesh(path, patches, values: np.ndarray, *, lo: float = 0.0, hi: float = 1.0,
                     name: str = "value", mask: Optional[np.ndarray] = None) -> None:
    """Triangulate patches into one PLY mesh coloured by one value per patch.

    ``values`` : (len(patches),) float64; ``mask`` False → grey (value written as NaN).
    """
    verts, faces, cols, vals = [], [], [], []
    k = 0
    for j, p in enumerate(patches):
        v, f = polygon_triangles(p)
        if len(f) == 0:
            continue
        val = float(values[j]) if (mask is None or mask[j]) else float("nan")
        verts.append(v)
        faces.append(f + k)
        k += len(v)
        vals.append(np.full(len(v), val))
        cols.append(np.repeat(ramp_colors(np.array([val]), lo, hi), len(v), axis=0))
    if verts:
        v = np.vstack(verts)
        f = np.vstack(faces)
        c = np.vstack(cols)
        val = np.concatenate(vals)
    else:
        v, f, c, val = np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), np.zeros((0, 3), np.uint8), np.zeros(0)
    write_ply_arrays(path, {"x": v[:, 0], "y": v[:, 1], "z": v[:, 2], "red": c[:, 0], "green": c[:, 1],
                            "blue": c[:, 2], name: val.astype(np.float32)}, f)


def _plot(result: EvaluationResult, path: str, title: str) -> None:
    import matplotlib  # heavy, and only for this plot

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    b = result.buffers * 100
    fig = Figure(figsize=(12, 3.8), dpi=100)
    axes = fig.subplots(1, 3)
    groups = [g for g in list(result.params.groups) + ["all"] if g in result.curves]
    for g in groups:
        c = result.curves[g]
        if np.all(~np.isfinite(c["completeness"])) and np.all(~np.isfinite(c["correctness"])):
            continue
        style = "-" if g == "all" else "--"
        axes[0].plot(b, c["completeness"], style, marker="o", ms=3, label=g)
        axes[1].plot(b, c["correctness"], style, marker="o", ms=3, label=g)
        axes[2].plot(b, c["accuracy"] * 100, style, marker="o", ms=3, label=g)
    for ax, t, yl in zip(axes, ("Completeness", "Correctness", "Accuracy"), ("share", "share", "median |d| (cm)")):
        ax.set_title(t)
        ax.set_xlabel("buffer b = cut-off r (cm)")
        ax.set_ylabel(yl)
        ax.grid(True, alpha=0.3)
    axes[0].set_ylim(0, 1.05)
    axes[1].set_ylim(0, 1.05)
    axes[0].legend(loc="lower right", fontsize=8)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    with atomic_path(path, suffix=".png") as tmp:
        fig.savefig(tmp, format="png")


def write_evaluation_outputs(result: EvaluationResult, out_dir, *, title: str = "",
                             extra: Optional[dict] = None, elements: Optional[dict] = None) -> dict:
    """Write the evaluation files into ``out_dir``; returns name → path of what was written.

    ``extra`` : more keys for ``evaluation.json``; ``elements`` : the dict of
    :func:`~engine.evaluation.elements.evaluate_elements`, written to ``elements.json`` and
    under ``"elements"`` in ``evaluation.json`` (key ``"elements"`` of the returned paths).
    """
    out_dir = os.fspath(out_dir)
    os.makedirs(out_dir, exist_ok=True)
    paths = {k: os.path.join(out_dir, f) for k, f in (
        ("json", "evaluation.json"), ("csv", "curves.csv"), ("png", "curves.png"),
        ("reference_ply", "reference_surfaces.ply"), ("source_ply", "source_surfaces.ply"),
        ("points_ply", "accuracy_points.ply"))}
    d = result.to_dict()
    if extra:
        d.update(extra)
    if elements is not None:
        d["elements"] = elements
        paths["elements"] = os.path.join(out_dir, "elements.json")
        atomic_write_text(paths["elements"], json.dumps(elements, indent=2))
    atomic_write_text(paths["json"], json.dumps(d, indent=2))
    s = io.StringIO()
    w = csv.writer(s)
    w.writerow(["group", "buffer_m", "completeness", "correctness", "accuracy_m"])
    for g, c in result.curves.items():
        for i, b in enumerate(result.buffers):
            w.writerow([g, f"{b:.4f}"] + ["" if not np.isfinite(c[m][i]) else f"{c[m][i]:.6f}"
                                          for m in ("completeness", "correctness", "accuracy")])
    atomic_write_text(paths["csv"], s.getvalue())
    _plot(result, paths["png"], title)
    li = result.localisation_index
    write_patch_mesh(paths["reference_ply"], result.reference, result.reference_covered[:, li],
                     name="covered", mask=result.visible)
    write_patch_mesh(paths["source_ply"], result.source,
                     result.source_covered[:, li] if len(result.source) else np.zeros(0), name="covered")
    dist = np.where(np.isfinite(result.sample_distance), result.sample_distance, -1.0)
    col = ramp_colors(np.where(dist >= 0, dist, np.nan), 0.0, float(result.buffers[-1]), reverse=True)
    pts = result.samples
    write_ply_arrays(paths["points_ply"], {"x": pts[:, 0], "y": pts[:, 1], "z": pts[:, 2], "red": col[:, 0],
                                           "green": col[:, 1], "blue": col[:, 2],
                                           "distance": dist.astype(np.float32),
                                           "surface": result.sample_patch.astype(np.int32)})
    return paths

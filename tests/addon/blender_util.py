"""Helpers for the add-on tests: load the source tree as the extension package, fresh scenes.

In the source tree the repository root *is* the extension package (its ``__init__.py``
forwards to ``blender_indoor_addon``), so tests import it under a fixed package name with
importlib instead of touching ``sys.path``.
"""
from __future__ import annotations

import importlib.util
import os
import sys

import numpy as np

from scenes import ROOT

PACKAGE = "indoor_reconstruction"
"""The name the source tree is imported under in tests (the manifest id)."""


def load_package(name: str = PACKAGE):
    """Import the repository root as the package ``name`` (once) and return it.

    ``name.blender_indoor_addon`` and ``name.engine`` are then importable, and the add-on's
    relative imports of the engine resolve inside this package.
    """
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(
        name, os.path.join(ROOT, "__init__.py"), submodule_search_locations=[ROOT])
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def addon_module(name: str = PACKAGE):
    """The ``blender_indoor_addon`` subpackage of the loaded package."""
    load_package(name)
    return importlib.import_module(name + ".blender_indoor_addon")


def engine_module(sub: str = "", name: str = PACKAGE):
    """``name.engine`` or one of its submodules (e.g. ``"io"``) — the add-on's own engine copy."""
    load_package(name)
    return importlib.import_module(name + ".engine" + ("." + sub if sub else ""))


def fresh_scene():
    """Load the factory start-up file (no user start-up file, no app template)."""
    import bpy

    bpy.ops.wm.read_homefile(app_template="", use_factory_startup=True)
    return bpy.context.scene


def scene_state():
    """A comparable snapshot of the data a failing operator must leave untouched."""
    import bpy

    return {
        "objects": sorted(o.name for o in bpy.data.objects),
        "meshes": sorted(m.name for m in bpy.data.meshes),
        "collections": sorted(c.name for c in bpy.data.collections),
        "scene_children": sorted(c.name for c in bpy.context.scene.collection.children),
        "node_groups": sorted(g.name for g in bpy.data.node_groups),
        "materials": sorted(m.name for m in bpy.data.materials),
    }


def write_binary_ply(path, xyz, *, colors=None, intensity=None, normals=None, extra=None):
    """Write a little-endian binary PLY with the usual property names (test helper).

    ``xyz`` (n, 3) float64 → x y z double; ``colors`` (n, 3) uint8 → red green blue;
    ``intensity`` (n,) float32; ``normals`` (n, 3) float32 → nx ny nz; ``extra``: dict of
    name → (n,) int32 or float32 arrays.
    """
    n = len(xyz)
    cols = [("x", "<f8", xyz[:, 0]), ("y", "<f8", xyz[:, 1]), ("z", "<f8", xyz[:, 2])]
    if colors is not None:
        cols += [(c, "u1", colors[:, i]) for i, c in enumerate(("red", "green", "blue"))]
    if intensity is not None:
        cols.append(("intensity", "<f4", intensity))
    if normals is not None:
        cols += [(c, "<f4", normals[:, i]) for i, c in enumerate(("nx", "ny", "nz"))]
    for k, v in (extra or {}).items():
        cols.append((k, "<i4" if np.asarray(v).dtype.kind in "iu" else "<f4", v))
    rec = np.empty(n, dtype=[(c, t) for c, t, _ in cols])
    for c, _, v in cols:
        rec[c] = v
    ply_type = {"<f8": "double", "u1": "uchar", "<f4": "float", "<i4": "int"}
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {n}"]
    header += [f"property {ply_type[t]} {c}" for c, t, _ in cols]
    header.append("end_header")
    with open(path, "wb") as f:
        f.write(("\n".join(header) + "\n").encode("ascii"))
        f.write(rec.tobytes())

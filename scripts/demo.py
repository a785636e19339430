"""The demo: the bundled sample scan through the add-on, headless.

    .venv/bin/python scripts/demo.py --out out/demo            # bpy module (make demo)
    blender -b -P scripts/demo.py -- --out out/demo            # a real Blender >= 4.2

Writes into OUT: ``scan.blend`` (the scan as a point mesh in the "Scan" collection and the
reconstructed model in "Indoor Model": Spaces, Walls, ..., hidden Cells), ``model.ifc``
(IFC4 from the engine), ``preview.png`` (Cycles CPU or Workbench renders: a top view cut
below the ceiling and an oblique view with the see-through spaces and walls, side by side)
and ``summary.json`` (the cloud summary, the model report, per-stage timings, versions).

Unless ``--synthetic none``, the same stages run on a synthetic ``office_mw`` scan generated on
the fly (7 rooms and a corridor; into ``OUT/office_mw/``); unless ``--no-changes``, the
``change_demo`` preset's old model and newer scan go through Detect changes (into
``OUT/changes/``, its preview shows existing points grey, new red, room faces by coverage).

Each stage is a function ``stage_<name>(state) -> dict`` that reads and extends ``state``;
later capabilities (evaluation, change detection) add stages to :data:`STAGES`.
"""
from __future__ import annotations

import argparse
import importlib
import importlib.util
import json
import logging
import os
import site
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGE = "indoor_reconstruction"
DEFAULT_SCAN = os.path.join(ROOT, "tests", "data", "room_scan1.pcd")

log = logging.getLogger("indoor.demo")


# --------------------------------------------------------------------------- set-up
def _blender_argv(argv):
    """Our arguments: after ``--`` inside Blender, else everything after the script."""
    if "--" in argv:
        return argv[argv.index("--") + 1:]
    try:
        import bpy

        if bpy.app.binary_path:  # `blender -b -P demo.py` without "--": Blender's own options only
            return []
    except ImportError:
        pass
    return argv[1:]


def _borrow_venv_packages():
    """Inside a real Blender binary its Python lacks scipy, open3d, ...: use the project's
    .venv site-packages (the same rule as tests/run_tests.py; Blender's numpy stays first)."""
    venv_site = os.path.join(ROOT, ".venv", "lib", "python%d.%d" % sys.version_info[:2], "site-packages")
    if os.path.isdir(venv_site):
        site.addsitedir(venv_site)


def load_package(name=PACKAGE):
    """Import the source tree (the repository root is the extension package) as ``name``."""
    if name in sys.modules:
        return sys.modules[name]
    spec = importlib.util.spec_from_file_location(
        name, os.path.join(ROOT, "__init__.py"), submodule_search_locations=[ROOT])
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def parse_args(argv):
    p = argparse.ArgumentParser(prog="demo.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--out", default=os.path.join(ROOT, "out", "demo"), help="output folder")
    p.add_argument("--scan", default=DEFAULT_SCAN, help="scan file (default: the bundled room scan)")
    p.add_argument("--method", choices=("auto", "manhattan", "generic"), default="auto",
                   help="reconstruction method")
    p.add_argument("--seed", type=int, default=0, help="reconstruction seed")
    p.add_argument("--engine", choices=("cycles", "workbench"), default="cycles",
                   help="preview renderer: Cycles CPU shows the colour attribute; Workbench (4.5) "
                        "draws Geometry Nodes point clouds in one colour")
    p.add_argument("--resolution", type=int, default=900, help="height of the preview, pixels")
    p.add_argument("--point-radius", type=float, default=0.01, help="drawn point radius, metres")
    p.add_argument("--section-drop", type=float, default=0.2,
                   help="the previews hide points above this share of the room height below its top")
    p.add_argument("--preview-point-radius", type=float, default=0.02,
                   help="drawn point radius in the preview, metres")
    p.add_argument("--synthetic", default="office_mw",
                   help="also reconstruct this engine.synthetic preset's scan, into OUT/<preset>/ "
                        "('none' to skip)")
    p.add_argument("--synthetic-points", type=int, default=150_000,
                   help="about how many points the synthetic scans have")
    p.add_argument("--changes", action=argparse.BooleanOptionalAction, default=True,
                   help="also run change detection on change_demo, into OUT/changes/")
    return p.parse_args(argv)


# --------------------------------------------------------------------------- stages
def stage_setup(state):
    """Fresh factory scene, the add-on registered from the source tree."""
    import bpy

    bpy.ops.wm.read_homefile(app_template="", use_factory_startup=True)
    for obj in list(bpy.data.objects):  # the default cube, light and camera
        bpy.data.objects.remove(obj, do_unlink=True)
    pkg = load_package()
    pkg.register()
    state["package"] = pkg
    state["addon"] = importlib.import_module(PACKAGE + ".blender_indoor_addon")
    return {"blender": bpy.app.version_string}


def stage_import(state):
    """The scan through the add-on's Import scan operator; the engine's summary of it."""
    import bpy

    scan = os.path.abspath(state.get("scan_path") or state["args"].scan)
    result = bpy.ops.indoor.import_scan(filepath=scan, point_radius=state["args"].point_radius)
    if result != {"FINISHED"}:
        raise SystemExit(f"demo: importing {scan} failed ({result}); see the log above")
    obj = bpy.context.view_layer.objects.active
    state["scan_object"] = obj
    cloud = state["package"].engine.io.read_point_cloud(scan)  # for the summary only
    summary = cloud.summary()
    summary["source"] = os.path.relpath(scan, ROOT) if scan.startswith(ROOT) else scan
    return {"object": obj.name, "vertices": len(obj.data.vertices),
            "attributes": sorted(a.name for a in obj.data.attributes if not a.name.startswith(".")),
            "cloud": summary}


def stage_reconstruct(state):
    """The add-on's Reconstruct operator on the imported scan (auto method, fixed seed)."""
    import bpy

    args = state["args"]
    bpy.context.view_layer.objects.active = state["scan_object"]
    result = bpy.ops.indoor.reconstruct(method=args.method, seed=args.seed)
    if result != {"FINISHED"}:
        raise SystemExit(f"demo: reconstruction failed ({result}); see the log above")
    bridge = importlib.import_module(PACKAGE + ".blender_indoor_addon.bridge")
    model = bridge.stored_model()
    state["model"] = model
    report = importlib.import_module(PACKAGE + ".engine.reconstruct").model_report(model)
    top = bpy.context.scene.collection.children[bridge.MODEL_COLLECTION]
    return {"method": args.method, "seed": args.seed,
            "collections": {c.name: len(c.objects) for c in top.children},
            "report": report}


def stage_ifc(state):
    """The stored model written as IFC4 (atomically) by the engine."""
    write_ifc = importlib.import_module(PACKAGE + ".engine.ifc").write_ifc
    path = os.path.join(state["out"], "model.ifc")
    write_ifc(state["model"], path)
    return {"ifc": os.path.basename(path), "bytes": os.path.getsize(path)}


def stage_save_blend(state):
    import bpy

    path = os.path.join(state["out"], "scan.blend")
    atomic_path = state["package"].engine.fileutil.atomic_path
    with atomic_path(path, suffix=".blend") as tmp:
        os.remove(tmp)  # else Blender keeps the empty placeholder as a ".blend1" backup
        bpy.ops.wm.save_as_mainfile(filepath=tmp, copy=True, compress=True)
    return {"blend": os.path.basename(path)}


def _look_at(obj, target):
    from mathutils import Vector

    direction = Vector(target) - obj.location
    obj.rotation_euler = direction.to_track_quat("-Z", "Y").to_euler()


def _render_view(scene, camera, path):
    import bpy

    scene.camera = camera
    scene.render.filepath = path
    bpy.ops.render.render(write_still=True)


def _robust_bounds(obj):
    """3rd–97th percentile box of the vertices (a few far outliers must not set the framing)."""
    import numpy as np

    bridge = importlib.import_module(PACKAGE + ".blender_indoor_addon.bridge")
    xyz, _ = bridge.object_points(obj)
    return np.percentile(xyz, 3, axis=0), np.percentile(xyz, 97, axis=0)


def stage_render(state):
    """Previews (Cycles CPU or Workbench): top view and oblique view, both with the points above
    a section height hidden so the room is seen from inside; joined side by side into
    ``state["out"]/state.get("preview_name", "preview.png")`` (also used by batch.py)."""
    import bpy
    import numpy as np

    args, obj, scene = state["args"], state["scan_object"], bpy.context.scene
    bridge = importlib.import_module(PACKAGE + ".blender_indoor_addon.bridge")
    out = {}
    lo, hi = _robust_bounds(obj)
    centre = (lo + hi) / 2
    size = hi - lo
    scene.render.engine = "CYCLES" if args.engine == "cycles" else "BLENDER_WORKBENCH"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 8
    scene.cycles.use_denoising = False
    scene.cycles.max_bounces = 2
    scene.cycles.transparent_max_bounces = 4
    mat = bpy.data.materials.new("Preview height")
    mat.use_nodes = True
    nt = mat.node_tree
    attr = nt.nodes.new("ShaderNodeAttribute")
    attr.attribute_type = "GEOMETRY"
    attr.attribute_name = state.get("preview_attribute") or "height_color"
    em = nt.nodes.new("ShaderNodeEmission")
    nt.links.new(attr.outputs["Color"], em.inputs["Color"])
    nt.links.new(em.outputs["Emission"], nt.nodes["Material Output"].inputs["Surface"])
    shading = scene.display.shading
    shading.light = "FLAT"
    shading.color_type = "VERTEX"  # "Attribute" in the UI: the active colour attribute
    if state.get("preview_attribute"):  # e.g. the change colours
        attr_layer = obj.data.color_attributes.get(state["preview_attribute"])
        obj.data.color_attributes.active_color = attr_layer
        obj.data.color_attributes.render_color_index = obj.data.color_attributes.active_color_index
        out["colour"] = state["preview_attribute"]
    elif not obj.data.color_attributes:  # a scan without colour: colour by height for the preview
        lo_z, hi_z = lo[2], hi[2]
        bridge.add_height_colors(obj, z_range=(lo_z, hi_z))
        out["colour"] = "height"
    else:
        out["colour"] = "scan colours"
        attr.attribute_name = "color"
    bridge.set_display(obj, point_radius=args.preview_point_radius, material=mat)
    shading.show_cavity = False
    shading.show_shadows = False
    scene.display.render_aa = "8"
    top = scene.collection.children.get(bridge.MODEL_COLLECTION)
    if top is not None:  # the previews show the spaces (see-through), walls and doors with the points
        for coll in top.children:
            if coll.name not in ("Walls", "Doors", "Spaces"):
                coll.hide_render = True
        sun = bpy.data.objects.new("Preview sun", bpy.data.lights.new("Preview sun", "SUN"))
        sun.data.energy = 3.0
        sun.rotation_euler = (0.6, 0.2, 0.8)
        scene.collection.objects.link(sun)
        shading.color_type = "VERTEX" if args.engine == "workbench" else shading.color_type
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    world.color = (0.02, 0.02, 0.025)
    scene.render.film_transparent = False
    scene.render.image_settings.file_format = "PNG"
    scene.render.resolution_percentage = 100
    h = int(args.resolution)

    paths = []
    # top view, orthographic, the camera's near clip just below the ceiling
    cam_top = bpy.data.objects.new("Top view", bpy.data.cameras.new("Top view"))
    scene.collection.objects.link(cam_top)
    cam_top.data.type = "ORTHO"
    cam_top.location = (centre[0], centre[1], hi[2] + 5.0)
    cam_top.rotation_euler = (0.0, 0.0, 0.0)
    cut_z = hi[2] - args.section_drop * size[2]
    bridge.set_display(obj, section=True, section_z=cut_z)  # look into the room: no ceiling
    cam_top.data.clip_end = cam_top.location.z - lo[2] + 5.0
    aspect_top = size[0] / max(size[1], 1e-6)
    cam_top.data.ortho_scale = 1.08 * max(size[0], size[1])
    scene.render.resolution_x, scene.render.resolution_y = int(h * min(max(aspect_top, 0.5), 2.0)), h
    spaces = top.children.get("Spaces") if top is not None else None
    if spaces is not None:  # the top view shows the plan: no see-through boxes over it
        spaces.hide_render = True
    name = state.get("preview_name", "preview.png")
    paths.append(os.path.join(state["out"], f".{name}.top.png"))
    t = time.perf_counter()
    _render_view(scene, cam_top, paths[-1])
    out["top_render_s"] = round(time.perf_counter() - t, 3)
    out["top_cut_z_m"] = float(cut_z)

    # oblique view from the south-west, above, same cut so the room is visible
    cam_ob = bpy.data.objects.new("Oblique view", bpy.data.cameras.new("Oblique view"))
    scene.collection.objects.link(cam_ob)
    cam_ob.data.lens = 28
    radius = float(np.linalg.norm(size[:2]))
    cam_ob.location = (centre[0] - 0.55 * radius, centre[1] - 0.65 * radius, hi[2] + 0.6 * radius)
    _look_at(cam_ob, (centre[0], centre[1], lo[2]))
    cam_ob.data.clip_start = 0.1
    cam_ob.data.clip_end = 10 * radius
    scene.render.resolution_x, scene.render.resolution_y = int(h * 4 / 3), h
    if spaces is not None and not state.get("preview_attribute"):  # change previews: no boxes
        spaces.hide_render = False
    paths.append(os.path.join(state["out"], f".{name}.oblique.png"))
    t = time.perf_counter()
    _render_view(scene, cam_ob, paths[-1])
    out["oblique_render_s"] = round(time.perf_counter() - t, 3)

    preview = os.path.join(state["out"], name)
    _join_images(paths, preview, state["package"].engine.fileutil.atomic_path)
    for p in paths:
        os.remove(p)
    out["preview"] = os.path.basename(preview)
    return out


def _join_images(paths, dest, atomic_path):
    """Place PNGs side by side (same height) into one PNG, through Blender's image API."""
    import bpy
    import numpy as np

    images = [bpy.data.images.load(p) for p in paths]
    try:
        h = images[0].size[1]
        gap = 8
        width = sum(im.size[0] for im in images) + gap * (len(images) - 1)
        canvas = np.zeros((h, width, 4), dtype=np.float32)
        canvas[..., 3] = 1.0
        x = 0
        for im in images:
            w, ih = im.size
            px = np.empty(w * ih * 4, dtype=np.float32)
            im.pixels.foreach_get(px)
            canvas[:ih, x:x + w] = px.reshape(ih, w, 4)
            x += w + gap
        joined = bpy.data.images.new("preview", width, h, alpha=False)
        joined.pixels.foreach_set(canvas.ravel())
        with atomic_path(dest, suffix=".png") as tmp:
            joined.filepath_raw = tmp
            joined.file_format = "PNG"
            joined.save()
        bpy.data.images.remove(joined)
    finally:
        for im in images:
            bpy.data.images.remove(im)


def stage_synthetic_scan(state):
    """A synthetic scan of ``args.synthetic`` (engine.synthetic), written as ``scan.ply``; the
    stages after it treat it like any scan file. Its true model is kept for the summary."""
    synthetic = importlib.import_module(PACKAGE + ".engine.synthetic")
    write_ply = importlib.import_module(PACKAGE + ".engine.io").write_ply
    args = state["args"]
    scene = synthetic.preset(state["preset"], seed=args.seed, target_points=args.synthetic_points)
    path = os.path.join(state["out"], "scan.ply")
    write_ply(path, scene.cloud, dtype="f4")
    state["scan_path"] = path
    state["truth"] = scene.truth
    state["synthetic"] = scene
    truth = scene.truth
    return {"preset": state["preset"], "points": len(scene.cloud), "scan": os.path.basename(path),
            "truth": {"spaces": len(truth.spaces), "walls": len(truth.walls), "doors": len(truth.doors)}}


def stage_evaluate(state):
    """The add-on's Evaluate operator: the reconstructed model against the preset's true model
    (written as ``truth.json``); the curves and surfaces go to ``evaluation/``."""
    import bpy

    path = os.path.join(state["out"], "truth.json")
    state["package"].engine.fileutil.atomic_write_text(path, state["truth"].to_json())
    result = bpy.ops.indoor.evaluate(filepath=path, out_dir=os.path.join(state["out"], "evaluation"))
    if result != {"FINISHED"}:
        raise SystemExit(f"demo: evaluation failed ({result}); see the log above")
    return json.loads(bpy.context.scene.indoor.eval_summary)


def stage_old_model(state):
    """change_demo: the old building's model (the preset's truth) put in the scene by the bridge."""
    import bpy

    bridge = importlib.import_module(PACKAGE + ".blender_indoor_addon.bridge")
    by_coll = bridge.model_to_objects(state["truth"], scene=bpy.context.scene)
    state["model"] = state["truth"]
    return {"collections": {k: len(v) for k, v in by_coll.items()}}


def stage_changes(state):
    """The add-on's Detect changes operator: the imported (newer) scan against the stored model;
    the preview shows existing points grey and new ones red, room faces by coverage."""
    import bpy
    import numpy as np

    obj = state["scan_object"]
    bpy.context.view_layer.objects.active = obj
    result = bpy.ops.indoor.detect_changes(use_active=True)
    if result != {"FINISHED"}:
        raise SystemExit(f"demo: change detection failed ({result}); see the log above")
    bridge = importlib.import_module(PACKAGE + ".blender_indoor_addon.bridge")
    state["preview_attribute"] = bridge.CHANGE_TYPE_COLOR
    summary = json.loads(bpy.context.scene.indoor.change_summary)
    top = bpy.context.scene.collection.children.get(bridge.MODEL_COLLECTION)
    if top is not None:  # the preview shows the change colours, not the model's boxes
        for coll in top.children:
            coll.hide_render = True
    changes = bpy.context.scene.collection.children.get(bridge.CHANGES_COLLECTION)
    for face in (changes.objects if changes is not None else ()):  # floors/ceilings would hide the points
        face.hide_render = face.get("indoor_kind") != "wall"
    truth_new = state["synthetic"].cloud.fields.get("new")
    if truth_new is not None:  # the preset knows which points belong to the new structure
        mesh = obj.data
        t = np.empty(len(mesh.vertices), dtype=np.int32)
        mesh.attributes[bridge.CHANGE_TYPE].data.foreach_get("value", t)
        is_new = np.asarray(truth_new).astype(bool)
        summary["true_new_found"] = float(np.mean(t[is_new] == 1)) if is_new.any() else None
        summary["true_existing_kept"] = float(np.mean(t[~is_new] == 0)) if (~is_new).any() else None
    return summary


STAGES = [("setup", stage_setup), ("import", stage_import), ("reconstruct", stage_reconstruct),
          ("ifc", stage_ifc), ("render", stage_render), ("save_blend", stage_save_blend)]
"""(name, function) in order; each returns a JSON-ready dict stored under its name."""
SYNTHETIC_STAGES = [("setup", stage_setup), ("synthetic_scan", stage_synthetic_scan),
                    ("import", stage_import),
                    ("reconstruct", stage_reconstruct), ("ifc", stage_ifc), ("render", stage_render),
                    ("evaluate", stage_evaluate), ("save_blend", stage_save_blend)]
"""The same on a synthetic scan generated on the fly (into OUT/<preset>/), evaluated against the
preset's true model."""
CHANGE_STAGES = [("setup", stage_setup), ("synthetic_scan", stage_synthetic_scan),
                 ("old_model", stage_old_model),
                 ("import", stage_import), ("changes", stage_changes), ("render", stage_render),
                 ("save_blend", stage_save_blend)]
"""Change detection on change_demo (into OUT/changes/): old model vs. newer scan."""


def _run_stages(args, stages, out, scan_label, **extra):
    os.makedirs(out, exist_ok=True)
    state = {"args": args, "out": out, **extra}
    summary = {"scan": scan_label, "stages": {}, "timings_s": {}}
    t_all = time.perf_counter()
    for name, fn in stages:
        t = time.perf_counter()
        summary["stages"][name] = fn(state)
        summary["timings_s"][name] = round(time.perf_counter() - t, 3)
        log.info("demo: %s done in %.2f s", name, summary["timings_s"][name])
    summary["timings_s"]["total"] = round(time.perf_counter() - t_all, 3)
    state["package"].engine.fileutil.atomic_write_text(
        os.path.join(out, "summary.json"), json.dumps(summary, indent=2) + "\n")
    return summary


def run(args):
    out = os.path.abspath(args.out)
    summary = _run_stages(args, STAGES, out, os.path.relpath(os.path.abspath(args.scan), ROOT))
    if args.synthetic != "none":
        _run_stages(args, SYNTHETIC_STAGES, os.path.join(out, args.synthetic), f"synthetic {args.synthetic}",
                    preset=args.synthetic)
    if args.changes:
        _run_stages(args, CHANGE_STAGES, os.path.join(out, "changes"), "synthetic change_demo",
                    preset="change_demo")
    return summary


def main(argv=None):
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    args = parse_args(_blender_argv(sys.argv if argv is None else argv))
    try:
        import bpy  # noqa: F401
    except ImportError:
        raise SystemExit("demo.py needs Blender: run it with the bpy module or `blender -b -P`")
    if bpy.app.binary_path:  # a Blender executable (empty under the bpy module)
        _borrow_venv_packages()
    try:
        summary = run(args)
    finally:
        # Unregister before exit: with classes still registered the bpy module (4.5) hangs
        # while shutting down.
        pkg = sys.modules.get(PACKAGE)
        if pkg is not None:
            pkg.unregister()
    s = summary["stages"]["import"]
    logging.getLogger("indoor.demo").info(
        "demo: %d points -> %s (scan.blend, model.ifc, preview.png, summary.json) in %.1f s",
        s["vertices"], args.out, summary["timings_s"]["total"])
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Batch conversion inside Blender: scans → IFC + JSON (as ``indoor convert``) + .blend + PNG each.

    blender -b -P scripts/batch.py -- SCAN [SCAN ...] --out DIR [--method auto] [--seed 0]
                                      [--params FILE.toml] [--set stage.key=value ...]
    .venv/bin/python scripts/batch.py SCAN [SCAN ...] --out DIR         # with the bpy module

For each scan: ``engine.reconstruct.convert_file`` writes ``DIR/<name>.ifc`` and
``DIR/<name>.json``; the add-on's Import scan operator builds the point mesh on a fresh
scene, the bridge adds the model (collections Spaces, Walls, ..., hidden Cells), saved as
``DIR/<name>.blend``; then a preview ``DIR/<name>.png`` is rendered (Workbench by default,
headless; the demo's render: a top view cut below the ceiling and an oblique view). A bad
file is reported on one line (any error: an engine error or a bug, ``--debug`` for the
traceback) and the batch goes on; ``--params``/``--set`` choose the reconstruction parameters
as for ``indoor convert`` (a bad file or key is a usage error); ``DIR/batch.json`` maps each input to its outputs and lists
the failures with their kind. Inputs that share a name get ``<name>_2``, ... The output folder
is checked before any work. Exit code: 0 all done, 1 some failed, 2 usage, 130 interrupted
(Ctrl-C or SIGTERM; the files finished before it stay intact).
"""
from __future__ import annotations

import argparse
import importlib
import importlib.util
import logging
import os
import site
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGE = "indoor_reconstruction"

log = logging.getLogger("indoor.batch")


def _argv(argv):
    if "--" in argv:
        return argv[argv.index("--") + 1:]
    return argv[1:]


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
    p = argparse.ArgumentParser(prog="batch.py", description=__doc__.split("\n\n")[0])
    p.add_argument("scans", nargs="+", help="scan files")
    p.add_argument("--out", required=True, help="output folder")
    p.add_argument("--method", choices=("auto", "manhattan", "generic"), default="auto")
    p.add_argument("--seed", type=int, default=0, help="random seed >= 0")
    p.add_argument("--units", default="auto", choices=("auto", "m", "mm", "cm", "in", "ft"),
                   help="units of the scans (auto: detected, rescaled to metres)")
    p.add_argument("--up", default="auto", choices=("auto", "z", "-z", "y", "-y", "x", "-x"),
                   help="up axis of the scans (auto: detected and rotated to z up)")
    p.add_argument("--params", default=None, metavar="FILE",
                   help="TOML parameter file (as written by `indoor params --toml`)")
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", dest="settings",
                   help="set one parameter, e.g. generic.cells.min_wall_area=0.7 (after --params; repeatable)")
    p.add_argument("--debug", action="store_true", help="print the traceback of any error")
    p.add_argument("--no-ifc", action="store_true", help="skip the IFC file")
    p.add_argument("--engine", choices=("workbench", "cycles"), default="workbench", help="preview renderer")
    p.add_argument("--resolution", type=int, default=600, help="height of the preview, pixels (0: none)")
    p.add_argument("--section-drop", type=float, default=0.2,
                   help="the previews hide points above this share of the room height below its top")
    p.add_argument("--preview-point-radius", type=float, default=0.02, help="drawn point radius, metres")
    return p.parse_args(argv)


def convert_one(pkg, scan, args, name, params=None):
    """IFC + JSON through the engine, then the .blend with the scan's point mesh and the model;
    every output is named ``<name>.*`` (distinct per input, see ``engine.jobs.output_stems``);
    ``params`` is the engine's ``Params`` (None: the defaults)."""
    import bpy

    reconstruct = importlib.import_module(PACKAGE + ".engine.reconstruct")
    atomic_path = pkg.engine.fileutil.atomic_path
    t0 = time.perf_counter()
    result = reconstruct.convert_file(scan, args.out, method=args.method, seed=args.seed, name=name,
                                      units=args.units, up=args.up, write_ifc=not args.no_ifc,
                                      params=params)
    t1 = time.perf_counter()
    bpy.ops.wm.read_homefile(app_template="", use_factory_startup=True)
    for obj in list(bpy.data.objects):
        bpy.data.objects.remove(obj, do_unlink=True)
    res = bpy.ops.indoor.import_scan(filepath=os.path.abspath(scan))
    if res != {"FINISHED"}:
        raise RuntimeError("import into Blender failed")
    bridge = importlib.import_module(PACKAGE + ".blender_indoor_addon.bridge")
    bridge.model_to_objects(result.model, scene=bpy.context.scene)
    blend = os.path.join(args.out, name + ".blend")
    with atomic_path(blend, suffix=".blend") as tmp:
        os.remove(tmp)  # else Blender keeps the empty placeholder as a ".blend1" backup
        bpy.ops.wm.save_as_mainfile(filepath=tmp, copy=True, compress=True)
    t2 = time.perf_counter()
    png = None
    if args.resolution > 0:  # after saving: the render adds cameras and changes visibility
        demo = _demo_module()
        state = {"args": args, "out": args.out, "package": pkg, "preview_name": name + ".png",
                 "scan_object": bpy.context.view_layer.objects.active}
        demo.stage_render(state)
        png = os.path.join(args.out, name + ".png")
    return {"input": scan, "ifc": result.ifc_path, "json": result.json_path, "blend": blend, "png": png,
            "convert_s": round(t1 - t0, 3), "blender_s": round(t2 - t1, 3),
            "render_s": round(time.perf_counter() - t2, 3)}


def _demo_module():
    """scripts/demo.py (its render stage), imported by path."""
    name = "indoor_demo_script"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, os.path.join(ROOT, "scripts", "demo.py"))
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


def main(argv=None):
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    args = parse_args(_argv(sys.argv if argv is None else argv))
    import bpy

    if bpy.app.binary_path:  # a real Blender: borrow the project's .venv packages (see run_tests.py)
        venv_site = os.path.join(ROOT, ".venv", "lib", "python%d.%d" % sys.version_info[:2], "site-packages")
        if os.path.isdir(venv_site):
            site.addsitedir(venv_site)
    pkg = load_package()
    jobs = importlib.import_module(PACKAGE + ".engine.jobs")
    errors = importlib.import_module(PACKAGE + ".engine.errors")
    if args.seed < 0:
        log.error("error: input error: --seed must be a whole number >= 0, not %d", args.seed)
        return jobs.EXIT_USAGE
    params_mod = importlib.import_module(PACKAGE + ".engine.params")
    try:
        params = params_mod.load_params(args.params) if args.params else params_mod.Params()
        params = params_mod.with_settings(params, args.settings)
    except errors.InputError as e:  # a bad parameter file or key: usage, before any work
        log.error("error: %s", errors.error_line(e))
        return jobs.EXIT_USAGE
    try:
        jobs.check_output_dir(args.out)  # before any work
    except errors.IndoorError as e:
        log.error("error: %s", errors.error_line(e))
        return jobs.EXIT_FAILED
    names = jobs.output_stems(args.scans)
    done, failed, interrupted = [], [], False

    def report(f):
        log.error("failed: %s", f.message)
        if args.debug and f.traceback:
            log.error("%s", f.traceback)

    pkg.register()
    try:
        with jobs.terminate_as_interrupt():
            for scan, name in zip(args.scans, names):
                result, failure = jobs.guarded(scan, lambda s=scan, n=name: convert_one(pkg, s, args, n, params),
                                               debug=args.debug, on_failure=report)
                if failure is None:
                    done.append(result)
                    log.info("ok: %s", scan)
                else:
                    failed.append(failure)
    except KeyboardInterrupt:
        interrupted = True
        log.error("interrupted: the files finished before it are intact")
    finally:
        pkg.unregister()  # the bpy module hangs at exit with classes still registered
    if done or len(args.scans) > 1:
        os.makedirs(args.out, exist_ok=True)
        jobs.write_batch_record(args.out, done, failed, interrupted=interrupted)
    log.info("%d converted, %d failed", len(done), len(failed))
    if interrupted:
        return jobs.EXIT_INTERRUPTED
    return jobs.EXIT_OK if not failed else jobs.EXIT_FAILED


if __name__ == "__main__":
    code = main()
    if code == 130:  # interrupted: end at once (see engine.cli.run), the outputs are complete
        sys.stdout.flush()
        sys.stderr.flush()
        logging.shutdown()
        os._exit(code)
    sys.exit(code)

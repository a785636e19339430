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
import json
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
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="convert on a local Dask cluster of N worker processes (each with the bpy module)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="convert on an existing Dask cluster (tcp://HOST:PORT); its workers need the bpy "
                        "module and this source tree, and write the outputs where they run")
    p.add_argument("--memory-limit", default=None, metavar="SIZE", help="memory limit per local worker, e.g. 4GB")
    return p.parse_args(argv)


def cluster_task(scan, args, name, params_dict):
    """One scan on a Dask worker: IFC + JSON + .blend + PNG written by the worker (into
    ``args.out`` as the worker sees it). Runs in the worker's process; the add-on is
    registered there once. Returns a ``batch.json`` entry, ``status`` done or failed."""
    import time as _time

    if "bpy" not in sys.modules:  # the client's sys.path came along and holds bpy's own scripts/modules,
        sys.path[:] = [p for p in sys.path if f"{os.sep}bpy{os.sep}" not in p]  # whose bpy/ hides the module
        import bpy  # noqa: F401
    pkg = load_package()
    jobs = importlib.import_module(PACKAGE + ".engine.jobs")
    params_mod = importlib.import_module(PACKAGE + ".engine.params")
    if not getattr(pkg, "_batch_registered", False):
        pkg.register()
        pkg._batch_registered = True
    try:
        from distributed import get_worker

        worker = get_worker().address
    except (ImportError, ValueError):
        worker = "local"
    t0 = _time.perf_counter()
    params = params_mod.params_from_dict(params_dict)
    result, failure = jobs.guarded(scan, lambda: convert_one(pkg, scan, args, name, params), debug=args.debug)
    if failure is not None:
        return {"input": scan, "status": "failed", "kind": failure.kind, "error": failure.message,
                "traceback": failure.traceback, "worker": worker,
                "seconds": round(_time.perf_counter() - t0, 3)}
    return {**result, "status": "done", "worker": worker, "seconds": round(_time.perf_counter() - t0, 3)}


def run_on_cluster(pkg, args, names, params, report):
    """Every scan as one task on the Dask cluster (``--workers`` / ``--scheduler``), through
    ``engine.cluster.run_jobs`` (a dead worker's scan is retried once); ``batch.json`` is
    rewritten as each scan finishes. Returns ``(done, failed, interrupted)``."""
    import cloudpickle

    cluster = importlib.import_module(PACKAGE + ".engine.cluster")
    jobs_mod = importlib.import_module(PACKAGE + ".engine.jobs")
    if __name__ in sys.modules:  # run as a script: the task goes by value, workers need not import it
        cloudpickle.register_pickle_by_value(sys.modules[__name__])
    import json

    params_dict = json.loads(json.dumps(params.to_dict()))  # tuples as lists, as in a parameter file
    from types import SimpleNamespace  # not engine.cluster.Job: the workers load the package by path

    # absolute paths: a worker's current folder is its own (Blender changes it, too)
    args = argparse.Namespace(**{**vars(args), "out": os.path.abspath(args.out)})
    jobs = [SimpleNamespace(path=os.path.abspath(scan), name=name) for scan, name in zip(args.scans, names)]
    done, failed = [], []

    def task(job, data=None):  # the Job carries the scan and its output name
        return cluster_task(job.path, args, job.name, params_dict)

    def on_result(i, r):
        r["input"] = args.scans[i]
        if r.get("status") == "done":
            done.append(r)
            log.info("ok: %s (%s)", r["input"], r.get("worker"))
        else:
            f = jobs_mod.Failure(args.scans[i], r.get("kind", "internal"), r.get("error", ""), r.get("traceback", ""),
                                 details={k: r[k] for k in ("worker", "seconds", "attempts") if k in r})
            failed.append(f)
            report(f)
        os.makedirs(args.out, exist_ok=True)
        jobs_mod.write_batch_record(args.out, done, failed, interrupted=False)

    with cluster.connect(args.scheduler, args.workers, args.memory_limit) as client:
        link = cluster.dashboard_link(client)
        if link:
            log.info("Dask dashboard: %s", link)
        try:
            cluster.run_jobs(client, jobs, task=task, on_result=on_result)
        except KeyboardInterrupt:
            return done, failed, True
    return done, failed, False


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
    frame = result.model.provenance.parameters.get("frame") or {}  # found once, by the engine
    res = bpy.ops.indoor.import_scan(filepath=os.path.abspath(scan), units=frame.get("units", args.units),
                                     up_axis=frame.get("up", args.up),
                                     frame_record=json.dumps(frame, default=str) if frame else "")
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

    if args.workers or args.scheduler:
        try:
            with jobs.terminate_as_interrupt():
                done, failed, interrupted = run_on_cluster(pkg, args, names, params, report)
        except KeyboardInterrupt:
            interrupted = True
        except errors.IndoorError as e:  # dask missing, scheduler unreachable
            log.error("error: %s", errors.error_line(e))
            return jobs.EXIT_FAILED
        if interrupted:
            log.error("interrupted: the files finished before it are intact")
        if done or failed:
            jobs.write_batch_record(args.out, done, failed, interrupted=interrupted)
        log.info("%d converted, %d failed", len(done), len(failed))
        return jobs.EXIT_INTERRUPTED if interrupted else jobs.EXIT_OK if not failed else jobs.EXIT_FAILED

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
    # Every output is complete and in place (atomic writes): end at once, interrupted (see
    # engine.cli.run) or not. Tearing down the bpy module frees the scene's million-vertex
    # mesh and the add-on's data one by one: 0.2 s of a 1M-point batch (bench batch).
    bpy = sys.modules.get("bpy")
    if code == 130 or not (bpy and bpy.app.binary_path):  # a real Blender exits by its own path
        sys.stdout.flush()
        sys.stderr.flush()
        logging.shutdown()
        os._exit(code)
    sys.exit(code)

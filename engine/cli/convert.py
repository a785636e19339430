"""``indoor convert SCAN... -o OUT_DIR``: reconstruct building models, write IFC and JSON;
in process, or one task per file on a Dask cluster (``--workers N``, ``--scheduler ADDR``)."""
from __future__ import annotations

import os
import sys
import time

from .. import cluster, reconstruct
from ..errors import Cancelled
from ..jobs import (Failure, check_output_dir, output_stems, polled, seed_argument, stop_requested,
                    write_batch_record)
from ..segmentation.frame import UNITS, UP_AXES
from .console import ConsoleProgress, UsageError, batch_exit, emit, run_batch
from .params import add_params_options, params_from_args

__all__ = ["add_convert", "cmd_convert"]


def add_convert(sub) -> None:
    """Add the ``convert`` subcommand to an argparse subparsers object."""
    p = sub.add_parser("convert", help="reconstruct building models from scans, write IFC and JSON",
                       description="Reconstruct each SCAN and write OUT_DIR/<name>.ifc and <name>.json; "
                                   "OUT_DIR/batch.json maps every input to its outputs and lists the "
                                   "failures. Inputs that share a name get <name>_2, <name>_3, ... "
                                   "Exit code: 0 all done, 1 some files failed, 2 usage, 130 interrupted.")
    p.add_argument("scans", nargs="+", metavar="SCAN")
    p.add_argument("-o", "--out", required=True, metavar="OUT_DIR", help="output folder")
    p.add_argument("--method", choices=("auto", "manhattan", "generic"), default="auto",
                   help="auto: Manhattan grammar when the walls are Manhattan, else cells + rjMCMC")
    p.add_argument("--seed", type=seed_argument, default=0, help="random seed >= 0 (same seed, same model)")
    p.add_argument("--units", choices=("auto", *UNITS), default="auto",
                   help="units of the scan's coordinates; auto detects mm, cm, in, ft from the extent and "
                        "the storey heights and rescales to metres (default auto)")
    p.add_argument("--up", choices=("auto", *UP_AXES), default="auto",
                   help="which axis of the scan points up; auto detects y-up and upside-down scans from "
                        "the floor and ceiling planes and rotates them (default auto)")
    p.add_argument("--no-ifc", action="store_true", help="write only the JSON model and report")
    p.add_argument("--ifc-parts", action="store_true",
                   help="also write the parts of merged spaces (cuboids, cells) as PARTIAL IfcSpace; "
                        "by default the IFC has one IfcSpace per room")
    g = p.add_argument_group("batches", "SCAN may also be a folder (every scan inside, recursively) or a "
                                        "list of paths (@FILE, FILE.lst). See docs/cluster.md.")
    g.add_argument("--workers", type=_positive_int, default=None, metavar="N",
                   help="convert on a local Dask cluster of N worker processes (one thread each)")
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="convert on an existing Dask cluster, e.g. tcp://HOST:8786")
    g.add_argument("--memory-limit", default=None, metavar="SIZE",
                   help="memory limit per local worker, e.g. 4GB (default: the machine's memory / N)")
    g.add_argument("--timeout", type=_positive_float, default=None, metavar="S",
                   help="give up a file after S seconds (checked at the engine's progress steps)")
    g.add_argument("--resume", action="store_true",
                   help="skip files whose outputs exist and whose input hash and parameters match "
                        "(OUT_DIR/<name>.manifest.json)")
    g.add_argument("--ship", action="store_true",
                   help="send each scan's bytes to its worker and the outputs back (no shared file system)")
    add_params_options(p)
    p.set_defaults(func=cmd_convert)


def _positive_int(text: str) -> int:
    import argparse

    try:
        v = int(text)
    except ValueError:
        v = 0
    if v < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, not {text!r}")
    return v


def _positive_float(text: str) -> float:
    import argparse

    try:
        v = float(text)
    except ValueError:
        v = 0.0
    if not v > 0:
        raise argparse.ArgumentTypeError(f"must be a number of seconds > 0, not {text!r}")
    return v


def _line(r) -> str:
    if r.get("status") == "skipped":
        return f"{r['input']}: up to date (--resume) -> {r.get('ifc') or r.get('json')}"
    where = f", {r['worker']}" if r.get("worker") not in (None, "local") else ""
    return (f"{r['input']}: {r['spaces']} spaces, {r['walls']} walls, {r['doors']} doors "
            f"({r['method']}, {r['seconds']:.1f} s{where}) -> {r['ifc'] or r['json']}")


def cmd_convert(args) -> int:
    """Run ``indoor convert``; returns 0, 1 when some file failed, 130 interrupted."""
    params = params_from_args(args)  # a bad parameter file or key: a usage error before any work
    check_output_dir(args.out)  # before any work: a bad folder fails in a second, not after hours
    if args.workers and args.scheduler:
        raise UsageError("give --workers N (a local cluster) or --scheduler ADDRESS, not both")
    if args.ship and not (args.workers or args.scheduler):
        raise UsageError("--ship sends scans to Dask workers: give --workers or --scheduler too")
    scans = cluster.expand_inputs(args.scans)
    if not scans:
        raise UsageError("no scan found in " + ", ".join(args.scans))
    names = output_stems(scans)
    options = {"method": args.method, "seed": args.seed, "units": args.units, "up": args.up,
               "write_ifc": not args.no_ifc, "ifc_parts": args.ifc_parts}
    phash = cluster.params_hash(options, params)
    skipped, todo = [], list(range(len(scans)))
    if args.resume:
        todo = []
        for i, scan in enumerate(scans):
            m = cluster.manifest_ok(args.out, names[i], scan, phash)
            if m is None:
                todo.append(i)
            else:
                outs = {os.path.splitext(o)[1][1:]: os.path.join(args.out, o) for o in m["outputs"]}
                skipped.append({"input": scan, "status": "skipped", "json": outs.get("json"), "ifc": outs.get("ifc")})
    if args.workers or args.scheduler:
        results, failures, interrupted = _on_cluster(args, scans, names, todo, options, params, phash, skipped)
    else:
        results, failures, interrupted = _in_process(args, scans, names, todo, options, params, phash)
    done = skipped + results
    if done or os.path.exists(os.path.join(args.out, "batch.json")):  # never a file for a run that wrote nothing
        write_batch_record(args.out, done, failures, interrupted=interrupted)
    lines = [_line(r) for r in done]
    if failures:
        lines.append(f"{len(failures)} of {len(scans)} files failed: " + ", ".join(f.file for f in failures))
    emit(args, {"converted": results, "skipped": skipped, "failed": [f.to_dict() for f in failures],
                "interrupted": interrupted}, lines)
    return batch_exit(failures, interrupted)


def _in_process(args, scans, names, todo, options, params, phash):
    def work(i, bar):
        path, t0 = scans[i], time.perf_counter()
        deadline = time.monotonic() + args.timeout if args.timeout else None

        def should_stop():
            if deadline is not None and time.monotonic() > deadline:
                raise Cancelled(f"timed out after {args.timeout:g} s (--timeout)", path)
            return stop_requested()

        with polled():  # SIGTERM: the engine stops at its next progress check
            r = reconstruct.convert_file(path, args.out, name=names[i], params=params, progress=bar,
                                         should_stop=should_stop, **options)
        if args.resume and os.path.isfile(path):  # in process, manifests only when resuming (a cluster: always)
            cluster.write_manifest(args.out, names[i], path, cluster.file_sha256(path), phash,
                                   [r.json_path, r.ifc_path])
        return {"input": r.report["source"]["path"], "status": "done", "json": r.json_path, "ifc": r.ifc_path,
                **r.report["summary"], "method": r.model.provenance.method,
                "seconds": round(time.perf_counter() - t0, 3), "worker": "local"}

    items = [scans[i] for i in todo]
    return run_batch(args, items, "converting", lambda item, bar, i: work(i, bar), names=todo)


def _on_cluster(args, scans, names, todo, options, params, phash, skipped):
    """One task per file on the Dask cluster; batch.json rewritten as each file finishes."""
    out_abs = os.path.abspath(args.out)  # the scan paths as given: they name the model (GlobalIds)
    jobs = [cluster.Job(scans[i], names[i], out_abs, options, params, args.timeout) for i in todo]
    results, failures = [], []
    quiet = args.quiet or args.json
    bar = ConsoleProgress(f"converting {len(jobs)} files", quiet=quiet)

    def on_result(k, r):
        i = todo[k]
        r["input"] = scans[i]
        if r.get("status") == "done":
            if "files" in r:
                cluster.write_shipped(args.out, r)
            cluster.write_manifest(args.out, names[i], scans[i], r.pop("sha256", None) or "", phash,
                                   [r.get("json"), r.get("ifc")])
            r.pop("pid", None)
            r.pop("name", None)
            results.append(r)
        else:
            if r.get("attempts", 1) > 1:
                cluster.remove_partials(args.out, names[i])
            f = Failure(scans[i], r.get("kind", "internal"), r.get("error", ""), r.get("traceback", ""),
                        details={k2: r[k2] for k2 in ("worker", "seconds", "peak_mb", "attempts") if k2 in r})
            failures.append(f)
            bar.close()  # the error on its own line, then the bar goes on below it
            f.print(args.debug)
        write_batch_record(args.out, skipped + results, failures, interrupted=False,
                           extra={"total": len(scans), "pending": len(jobs) - len(results) - len(failures)})

    def on_tick(done, failed, running):
        bar((done + failed) / max(1, len(jobs)), f"{done} done, {failed} failed, {running} running")

    interrupted = False
    with cluster.connect(args.scheduler, args.workers, args.memory_limit) as client:
        link = cluster.dashboard_link(client)
        if link and not quiet:
            print(f"Dask dashboard: {link}", file=sys.stderr)
        try:
            cluster.run_jobs(client, jobs, on_result=on_result, on_tick=on_tick, ship=args.ship)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            bar.close()
    return results, failures, interrupted

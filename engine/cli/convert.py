"""``indoor convert SCAN... -o OUT_DIR``: reconstruct building models, write IFC and JSON."""
from __future__ import annotations

from .. import reconstruct
from ..jobs import check_output_dir, output_stems, polled, seed_argument, stop_requested, write_batch_record
from ..segmentation.frame import UNITS, UP_AXES
from .console import batch_exit, emit, run_batch
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
    add_params_options(p)
    p.set_defaults(func=cmd_convert)


def cmd_convert(args) -> int:
    """Run ``indoor convert``; returns 0, 1 when some file failed, 130 interrupted."""
    params = params_from_args(args)  # a bad parameter file or key: a usage error before any work
    check_output_dir(args.out)  # before any work: a bad folder fails in a second, not after hours
    names = output_stems(args.scans)

    def work(path, bar, name):
        with polled():  # SIGTERM: the engine stops at its next progress check
            r = reconstruct.convert_file(path, args.out, method=args.method, seed=args.seed, name=name,
                                         units=args.units, up=args.up, write_ifc=not args.no_ifc,
                                         ifc_parts=args.ifc_parts, params=params, progress=bar,
                                         should_stop=stop_requested)
        return {"input": r.report["source"]["path"], "json": r.json_path, "ifc": r.ifc_path,
                **r.report["summary"], "method": r.model.provenance.method,
                "seconds": r.report["timings_s"]["total"]}

    results, failures, interrupted = run_batch(args, args.scans, "converting", work, names=names)
    if results:  # a record of what was written, never a file for a run that wrote nothing
        write_batch_record(args.out, results, failures, interrupted=interrupted)
    lines = [f"{r['input']}: {r['spaces']} spaces, {r['walls']} walls, {r['doors']} doors "
             f"({r['method']}, {r['seconds']:.1f} s) -> {r['ifc'] or r['json']}" for r in results]
    if failures:
        lines.append(f"{len(failures)} of {len(args.scans)} files failed: "
                     + ", ".join(f.file for f in failures))
    emit(args, {"converted": results, "failed": [f.to_dict() for f in failures],
                "interrupted": interrupted}, lines)
    return batch_exit(failures, interrupted)

"""Run the benchmarks: ``python -m bench --out out/bench [--only NAME ...] [--quick]``.

Discovers ``bench/bench_*.py`` with :mod:`pkgutil`; each module's ``run(out_dir, quick)``
returns a dict written to ``<out>/<name>.json``. One failing benchmark does not stop the
others; the exit code is non-zero if any failed.
"""
from __future__ import annotations

import argparse
import importlib
import json
import logging
import os
import pkgutil
import platform
import sys
import time
import traceback

import numpy as np

from engine.fileutil import atomic_write_text

log = logging.getLogger("bench")
PREFIX = "bench_"


def discover() -> dict:
    """``{name: module name}`` of every ``bench/bench_<name>.py``, sorted by name."""
    here = os.path.dirname(os.path.abspath(__file__))
    found = {}
    for info in pkgutil.iter_modules([here]):
        if info.name.startswith(PREFIX) and not info.ispkg:
            found[info.name[len(PREFIX):]] = f"{__package__ or 'bench'}.{info.name}"
    return dict(sorted(found.items()))


def machine() -> dict:
    return {
        "python": platform.python_version(),
        "numpy": np.__version__,
        "platform": platform.platform(),
        "processor": platform.processor() or platform.machine(),
        "cpu_count": os.cpu_count(),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench", description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=os.path.join("out", "bench"), help="folder for <name>.json")
    parser.add_argument("--only", action="append", metavar="NAME",
                        help="run only this benchmark (repeatable); NAME or bench_NAME")
    parser.add_argument("--quick", action="store_true", help="small sizes, for a smoke test")
    parser.add_argument("--list", action="store_true", help="list the benchmarks and exit")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    found = discover()
    if args.list:
        print("\n".join(found))
        return 0
    names = list(found)
    if args.only:
        wanted = [n[len(PREFIX):] if n.startswith(PREFIX) else n for n in args.only]
        unknown = [n for n in wanted if n not in found]
        if unknown:
            parser.error(f"unknown benchmark(s) {', '.join(unknown)}; known: {', '.join(found) or 'none'}")
        names = wanted
    os.makedirs(args.out, exist_ok=True)
    failed = []
    for name in names:
        log.info("running %s%s", name, " (quick)" if args.quick else "")
        t0 = time.perf_counter()
        try:
            module = importlib.import_module(found[name])
            result = module.run(args.out, args.quick)
            status = "ok"
        except Exception:  # one broken benchmark must not hide the others' figures
            result = {"error": traceback.format_exc()}
            status = "failed"
            failed.append(name)
            log.error("benchmark %s failed:\n%s", name, result["error"])
        payload = {"benchmark": name, "status": status, "quick": bool(args.quick),
                   "elapsed_s": round(time.perf_counter() - t0, 3),
                   "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                   "machine": machine(), "results": result}
        path = os.path.join(args.out, f"{name}.json")
        atomic_write_text(path, json.dumps(payload, indent=2) + "\n")
        print(f"{name}: {status} in {payload['elapsed_s']:.1f} s -> {path}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

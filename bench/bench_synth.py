"""Speed of ``indoor synth``: the office_mw preset (about 1M points, terrestrial σ = 5 mm)
written end to end (scan PLY, truth JSON, top-view PNG) in a fresh process, as a user runs
it — target ≤ 20 s; then every preset in both noise modes in this process (simulation
only), with point counts, scanner positions and the truth's size.
"""
from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
import tempfile
import time

log = logging.getLogger(__name__)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FULL_POINTS = 1_000_000
QUICK_POINTS = 200_000
PER_PRESET_POINTS = 300_000
QUICK_PER_PRESET_POINTS = 50_000
TARGET_SECONDS = 20.0

_CLI = r"""
import argparse, json, sys, time
t0 = time.perf_counter()
from engine.synthetic.cli import add_synth
p = argparse.ArgumentParser(); sub = p.add_subparsers(); add_synth(sub)
a = p.parse_args(sys.argv[1:]); a.quiet = True; a.json = True
import io, contextlib
buf = io.StringIO()
with contextlib.redirect_stdout(buf):
    a.func(a)
out = json.loads(buf.getvalue())
with open("/proc/self/status") as f:
    hwm = [int(l.split()[1]) / 1024 for l in f if l.startswith("VmHWM")][0]
out["process_seconds"] = time.perf_counter() - t0
out["peak_rss_mb"] = hwm
print(json.dumps(out))
"""


def run(out_dir: str, quick: bool) -> dict:
    """Run the benchmark; returns figures (seconds, points, MB)."""
    from engine.synthetic import PRESETS, preset

    points = QUICK_POINTS if quick else FULL_POINTS
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", _CLI, "synth", "office_mw", "-o", tmp, "--seed", "0",
                               "--points", str(points)], cwd=ROOT, capture_output=True, text=True, check=True)
        wall = time.perf_counter() - t0
        cli = json.loads(proc.stdout.strip().splitlines()[-1])
        sizes = {os.path.basename(v): os.path.getsize(v) for v in cli["files"].values()}
    result = {
        "office_mw_cli": {
            "points": cli["points"], "scanner_positions": cli["scans"], "seconds_wall": round(wall, 2),
            "seconds_in_process": {k: v for k, v in cli["seconds"].items()},
            "peak_rss_mb": round(cli["peak_rss_mb"], 1), "file_bytes": sizes,
            "target_seconds": TARGET_SECONDS, "meets_target": wall <= TARGET_SECONDS,
        },
        "presets": {},
    }
    n = QUICK_PER_PRESET_POINTS if quick else PER_PRESET_POINTS
    for name in PRESETS:
        for noise in ("tls", "mobile"):
            t0 = time.perf_counter()
            sc = preset(name, seed=0, noise=noise, target_points=n)
            dt = time.perf_counter() - t0
            result["presets"][f"{name}/{noise}"] = {
                "points": len(sc.cloud), "target": n, "scanner_positions": int(sc.cloud.scan_count),
                "seconds": round(dt, 2), "truth": sc.truth.summary(), "variants": sorted(sc.variants),
            }
            log.info("%s/%s: %d points in %.2f s", name, noise, len(sc.cloud), dt)
    return result

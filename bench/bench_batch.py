"""The Blender batch against the CLI on the same scans (issue 15: within 1.2x of the CLI).

Each scan (the 1M-point office_mw, TLS and mobile; ``--quick``: 100k points) is converted
twice, each in a fresh child process as a user runs it: ``indoor convert`` (IFC + JSON), then
``scripts/batch.py`` with the bpy module (IFC + JSON, the point mesh and the model in a .blend,
no preview render: the CLI draws none). Per scan: both wall times, their ratio, the batch's
own split (``convert_s``: the engine, ``blender_s``: import, model, .blend), the size of the
.blend, and the machine's load at the start and the end. Skipped (with the reason) when the
bpy module is missing.
"""
from __future__ import annotations

import importlib.util
import json
import logging
import os
import subprocess
import sys
import tempfile
import time

log = logging.getLogger(__name__)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCANS = (("office_mw", "tls"), ("office_mw", "mobile"))
POINTS, QUICK_POINTS = 1_000_000, 100_000
TARGET_RATIO = 1.2


def _run(cmd: list, env: dict) -> tuple[float, int, str]:
    t0 = time.perf_counter()
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    return time.perf_counter() - t0, r.returncode, r.stderr.decode(errors="replace")[-600:]


def run(out_dir: str, quick: bool = False) -> dict:
    if importlib.util.find_spec("bpy") is None:
        return {"skipped": "the bpy module is not installed (make setup installs it)"}
    env = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")}
    n = QUICK_POINTS if quick else POINTS
    result = {"load_start": list(os.getloadavg()), "points": n, "target_ratio": TARGET_RATIO, "scans": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for preset, noise in SCANS:
            name = f"{preset}_{noise}"
            folder = os.path.join(tmp, name)
            _, rc, err = _run([sys.executable, "-m", "engine", "synth", preset, "-o", folder, "--noise", noise,
                               "--points", str(n), "--seed", "0", "--no-png", "--no-ifc", "--quiet"], env)
            if rc != 0:
                raise RuntimeError(f"synth {name} failed: {err}")
            scan = os.path.join(folder, preset + ".ply")
            cli_s, rc_cli, err_cli = _run([sys.executable, "-m", "engine", "convert", scan, "-o",
                                           os.path.join(folder, "cli"), "--method", "auto", "--quiet"], env)
            out = os.path.join(folder, "blender")
            batch_s, rc_b, err_b = _run([sys.executable, os.path.join(ROOT, "scripts", "batch.py"), scan,
                                         "--out", out, "--method", "auto", "--resolution", "0"], env)
            r = {"cli_s": round(cli_s, 2), "batch_s": round(batch_s, 2), "rc": [rc_cli, rc_b]}
            if rc_cli or rc_b:
                r["error"] = (err_cli if rc_cli else err_b).strip()
            else:
                with open(os.path.join(out, "batch.json")) as f:
                    done = json.load(f)
                one = done["done"][0]
                r.update({k: one.get(k) for k in ("convert_s", "blender_s")})
                blend = os.path.join(out, preset + ".blend")
                r["blend_mb"] = round(os.path.getsize(blend) / 1e6, 2) if os.path.exists(blend) else None
                r["ratio"] = round(batch_s / cli_s, 2)
            log.info("%s %d: CLI %.1f s, Blender batch %.1f s", name, n, cli_s, batch_s)
            result["scans"][name] = r
    result["load_end"] = list(os.getloadavg())
    return result


if __name__ == "__main__":  # python -m bench.bench_batch [--quick]
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    print(json.dumps(run("out/bench", "--quick" in sys.argv), indent=1))

"""How a whole ``indoor convert`` (scan file → IFC + JSON) grows with the points (issue 15).

Each case is one preset scanned at three sizes, 1×, 3× and 10× (``SERIES``), plus a 10M-point
office; every scan is written by ``indoor synth`` and converted by ``indoor convert`` in a
child process of its own, as a user runs it, so the figures include the interpreter start,
the imports, reading the file and writing both outputs. Per conversion: wall seconds, CPU
seconds (user + system of the child), peak RSS of the child (``wait4``), the stages the
model's provenance records and the report's read / reconstruct / IFC / report times, the
IFC's share of the wall time (target ≤ 10 %), the spaces, walls, doors and windows found;
per series, the time ratio 10× : 1× (target ≤ 12) and the machine's load average at the
start and the end. ``--quick``: 30k / 100k / 300k points and no 10M run.
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

SERIES = {
    "office_mw_tls": ("office_mw", "tls", "auto", (1_000_000, 3_000_000, 10_000_000)),
    "office_mw_mobile": ("office_mw", "mobile", "auto", (100_000, 300_000, 1_000_000)),
    "syn_house_generic": ("syn_house", "tls", "generic", (100_000, 300_000, 1_000_000)),
}
"""name → (preset, noise, method, point counts 1×, 3×, 10×)."""
QUICK_SIZES = (30_000, 100_000, 300_000)


def _convert_rss(scan: str, out: str, method: str, env: dict) -> dict:
    """Convert ``scan`` in a child process: wall and CPU seconds, the child's own peak RSS
    (``os.wait4``), the report's timings and counts."""
    cmd = [sys.executable, "-m", "engine", "convert", scan, "-o", out, "--method", method, "--quiet"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env)
    _, status, ru = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    wall = time.perf_counter() - t0
    r = {"wall_s": round(wall, 2), "cpu_s": round(ru.ru_utime + ru.ru_stime, 2),
         "peak_rss_mb": round(ru.ru_maxrss / 1024.0, 1), "rc": proc.returncode}
    if proc.returncode != 0:
        return r
    stem = os.path.splitext(os.path.basename(scan))[0]
    with open(os.path.join(out, stem + ".json")) as f:
        data = json.load(f)
    rep = data["report"]
    r["stages_s"] = {k: round(v, 3) for k, v in (data["provenance"].get("timings") or {}).items()}
    r["report_s"] = rep.get("timings_s", {})
    r["found"] = {k: rep["summary"].get(k) for k in ("spaces", "walls", "doors", "windows", "slabs")}
    r["method"] = data["provenance"].get("method")
    r["points"] = rep["source"]["points"]
    r["ifc_mb"] = round(os.path.getsize(os.path.join(out, stem + ".ifc")) / 1e6, 2)
    # writing's share of the whole command (the IFC; the JSON's own write is not in its report)
    r["write_share"] = round(float(r["report_s"].get("ifc", 0.0)) / wall, 3) if wall > 0 else None
    return r


def _synth(preset: str, noise: str, n: int, folder: str, env: dict) -> str:
    cmd = [sys.executable, "-m", "engine", "synth", preset, "-o", folder, "--noise", noise, "--points", str(n),
           "--seed", "0", "--no-png", "--no-ifc", "--quiet"]
    r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    if r.returncode != 0:
        raise RuntimeError(f"synth {preset} {n} failed: {r.stderr.decode(errors='replace')[-400:]}")
    return os.path.join(folder, preset + ".ply")


def run(out_dir: str, quick: bool = False) -> dict:
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = {**os.environ, "PYTHONPATH": root + os.pathsep + os.environ.get("PYTHONPATH", "")}
    result = {"load_start": list(os.getloadavg()), "series": {}}
    with tempfile.TemporaryDirectory() as tmp:
        for name, (preset, noise, method, sizes) in SERIES.items():
            if quick:
                sizes = QUICK_SIZES
            rows = []
            for n in sizes:
                folder = os.path.join(tmp, f"{name}_{n}")
                scan = _synth(preset, noise, n, folder, env)
                r = _convert_rss(scan, os.path.join(folder, "out"), method, env)
                r["target_points"] = n
                log.info("%s %d: %.1f s wall, %.1f s CPU, %.0f MB", name, n, r["wall_s"], r["cpu_s"],
                         r.get("peak_rss_mb", 0))
                rows.append(r)
                os.remove(scan)
            ok = [r for r in rows if r["rc"] == 0]
            ratio = (ok[-1]["wall_s"] / ok[0]["wall_s"]) if len(ok) == len(rows) and ok[0]["wall_s"] > 0 else None
            result["series"][name] = {"preset": preset, "noise": noise, "method": method, "runs": rows,
                                      "time_ratio_10x_1x": round(ratio, 2) if ratio else None,
                                      "points_ratio": round(sizes[-1] / sizes[0], 1)}
    result["load_end"] = list(os.getloadavg())
    return result


def table(result: dict) -> str:
    """Markdown table of a :func:`run` result."""
    lines = ["| series | points | wall s | CPU s | peak MB | read | recon | IFC | IFC share | "
             "spaces/walls/doors/windows |", "|---|---|---|---|---|---|---|---|---|---|"]
    for name, s in result["series"].items():
        for r in s["runs"]:
            rs = r.get("report_s", {})
            f = r.get("found", {})
            lines.append(f"| {name} | {r.get('points', r['target_points']):,} | {r['wall_s']} | {r['cpu_s']} | "
                         f"{r.get('peak_rss_mb')} | {rs.get('read')} | {rs.get('reconstruct')} | {rs.get('ifc')} | "
                         f"{r.get('write_share')} | "
                         f"{f.get('spaces')}/{f.get('walls')}/{f.get('doors')}/{f.get('windows')} |")
        lines.append(f"| {name} ratio 10x/1x | | {s['time_ratio_10x_1x']} | | | | | | | |")
    return "\n".join(lines)


if __name__ == "__main__":  # python -m bench.bench_scaling [--quick] [--out DIR]
    import argparse

    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=os.path.join("out", "bench"))
    ap.add_argument("--series", nargs="*", choices=list(SERIES))
    a = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    if a.series:
        SERIES = {k: v for k, v in SERIES.items() if k in a.series}
    res = run(a.out, a.quick)
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "scaling.json"), "w") as fh:
        json.dump(res, fh, indent=1)
    print(table(res))

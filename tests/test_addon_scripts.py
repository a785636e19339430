"""The headless scripts (demo, batch) end to end, each in a fresh bpy process."""
import json
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _run(script, args, timeout=300):
    bpy = pytest.importorskip("bpy")
    if bpy.app.binary_path:
        cmd = [bpy.app.binary_path, "-b", "--factory-startup", "-P", script, "--", *args]
    else:
        cmd = [sys.executable, script, *args]
    return subprocess.run(cmd, cwd=ROOT, stdin=subprocess.DEVNULL, capture_output=True, text=True,
                          timeout=timeout)


def test_demo_writes_blend_summary_and_preview(tmp_path):
    out = tmp_path / "demo"
    proc = _run(os.path.join(ROOT, "scripts", "demo.py"),
                ["--out", str(out), "--resolution", "120", "--engine", "workbench"])
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert sorted(os.listdir(out)) == ["model.ifc", "preview.png", "scan.blend", "summary.json"]
    summary = json.loads((out / "summary.json").read_text())
    imp = summary["stages"]["import"]
    assert imp["vertices"] == imp["cloud"]["points"] == 112586
    assert imp["cloud"]["source"] == os.path.join("tests", "data", "room_scan1.pcd")
    assert set(summary["timings_s"]) >= {"setup", "import", "reconstruct", "ifc", "render", "save_blend",
                                         "total"}
    rec = summary["stages"]["reconstruct"]
    assert rec["collections"]["Spaces"] == rec["report"]["summary"]["spaces"] >= 1
    with open(out / "model.ifc", encoding="utf-8", errors="replace") as f:
        assert f.read(13) == "ISO-10303-21;"
    with open(out / "preview.png", "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    with open(out / "scan.blend", "rb") as f:
        head = f.read(7)
    assert head in (b"BLENDER", b"\x28\xb5\x2f\xfd" + head[4:])  # plain or zstd-compressed


def test_batch_reports_a_bad_file_and_exits_non_zero(tmp_path):
    bad = tmp_path / "broken.ply"
    bad.write_bytes(b"not a ply at all")
    out = tmp_path / "out"
    proc = _run(os.path.join(ROOT, "scripts", "batch.py"), [str(bad), "--out", str(out)])
    assert proc.returncode == 1, proc.stderr[-3000:]
    report = json.loads((out / "batch.json").read_text())
    assert report["done"] == []
    assert [f["scan"] for f in report["failed"]] == [str(bad)]
    assert "broken.ply" in report["failed"][0]["error"]
    assert sorted(os.listdir(out)) == ["batch.json"]  # nothing half-written

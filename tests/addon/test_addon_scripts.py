"""The headless scripts (demo, batch) end to end, each in a fresh bpy process."""
import json
import os
import subprocess
import sys

import pytest
from scenes import DATA, ROOT


pytestmark = [pytest.mark.slow, pytest.mark.blender]  # each starts Blender, runs a whole pipeline (5-10 s)


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
                ["--out", str(out), "--resolution", "80", "--engine", "workbench",
                 "--synthetic-points", "40000"])
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert sorted(os.listdir(out)) == ["changes", "model.ifc", "office_mw", "preview.png", "scan.blend",
                                       "summary.json"]
    assert sorted(os.listdir(out / "office_mw")) == ["evaluation", "model.ifc", "preview.png", "scan.blend",
                                                     "scan.ply", "summary.json", "truth.json"]
    assert "curves.png" in os.listdir(out / "office_mw" / "evaluation")
    assert sorted(os.listdir(out / "changes")) == ["preview.png", "scan.blend", "scan.ply", "summary.json"]
    office = json.loads((out / "office_mw" / "summary.json").read_text())["stages"]
    assert office["synthetic_scan"]["truth"]["spaces"] == 8  # 7 rooms and the corridor
    rec = office["reconstruct"]
    assert rec["collections"]["Spaces"] == rec["report"]["summary"]["spaces"]
    assert office["reconstruct"]["collections"]["Spaces"] >= 6
    ev = office["evaluate"]  # the reconstruction against the true model, at the localisation buffer
    assert ev["completeness"] > 0.95 and ev["correctness"] > 0.95  # measured 0.999 / 0.999
    changes = json.loads((out / "changes" / "summary.json").read_text())["stages"]["changes"]
    assert changes["true_new_found"] > 0.8 and changes["true_existing_kept"] > 0.9
    assert changes["new"] > 0 and len(changes["redundant"]) >= 1
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
    good = os.path.join(DATA, "room_scan2.pcd")
    out = tmp_path / "out"
    proc = _run(os.path.join(ROOT, "scripts", "batch.py"),
                [str(bad), good, "--out", str(out), "--resolution", "60"])
    assert proc.returncode == 1, proc.stderr[-3000:]
    report = json.loads((out / "batch.json").read_text())
    assert [d["input"] for d in report["done"]] == [good]  # the batch went on past the bad file
    assert [f["file"] for f in report["failed"]] == [str(bad)]
    assert "broken.ply" in report["failed"][0]["error"] and report["failed"][0]["kind"] == "input"
    assert "Traceback" not in proc.stderr
    # nothing half-written for the bad file; IFC + JSON + .blend + PNG for the good one
    assert sorted(os.listdir(out)) == ["batch.json", "room_scan2.blend", "room_scan2.ifc", "room_scan2.json",
                                       "room_scan2.png"]
    with open(out / "room_scan2.png", "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    import ifcopenshell

    assert len(ifcopenshell.open(str(out / "room_scan2.ifc")).by_type("IfcSpace")) >= 1

"""scripts/batch.py --workers: each scan's IFC, JSON, .blend and PNG made on a Dask worker."""
import json
import os
import subprocess
import sys

import pytest
from scenes import ROOT

pytestmark = [pytest.mark.slow, pytest.mark.blender]


def test_batch_on_two_workers(tmp_path, synthetic_scan_file):
    bpy = pytest.importorskip("bpy")
    if bpy.app.binary_path:
        pytest.skip("the workers are Python processes with the bpy module, not a Blender binary")
    pytest.importorskip("distributed")
    good = str(synthetic_scan_file("office_mw", 1, 15_000, "office.ply"))
    bad = tmp_path / "broken.ply"
    bad.write_bytes(b"not a ply at all")
    out = tmp_path / "out"
    proc = subprocess.run([sys.executable, os.path.join(ROOT, "scripts", "batch.py"), good, str(bad),
                           "--out", str(out), "--resolution", "60", "--workers", "2", "--method", "manhattan"],
                          cwd=ROOT, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 1, proc.stderr[-3000:]
    record = json.loads((out / "batch.json").read_text())
    assert [d["input"] for d in record["done"]] == [good]
    assert [f["file"] for f in record["failed"]] == [str(bad)] and record["failed"][0]["kind"] == "input"
    for entry in record["done"] + record["failed"]:
        assert entry["worker"].startswith("tcp://127.0.0.1:")
    assert sorted(os.listdir(out)) == ["batch.json", "office.blend", "office.ifc", "office.json", "office.png"]
    with open(out / "office.blend", "rb") as f:
        head = f.read(7)
    assert head in (b"BLENDER", b"\x28\xb5\x2f\xfd" + head[4:])  # plain or zstd-compressed

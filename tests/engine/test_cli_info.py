"""`indoor info`: exit codes, JSON output, and a batch that goes on past a bad file."""
import json
import os

import numpy as np
import pytest

from engine.cli import main
from engine.io import write_ply
from engine.pointcloud import PointCloud
from scenes import DATA

SCAN1 = os.path.join(DATA, "room_scan1.pcd")


@pytest.fixture
def grid_ply(tmp_path):
    """A 20 x 20 grid with 0.1 m spacing, with colours, 2 scans."""
    g = np.stack(np.meshgrid(np.arange(20) * 0.1, np.arange(20) * 0.1), -1).reshape(-1, 2)
    xyz = np.column_stack([g, np.zeros(len(g))])
    cloud = PointCloud(xyz=xyz, colors=np.zeros((400, 3), np.uint8), scan_index=np.arange(400) % 2,
                       scanner_positions=[[0, 0, 1.5], [1, 1, 1.5]])
    path = tmp_path / "grid.ply"
    write_ply(path, cloud)
    return str(path)


def test_info_json_single_file(capsys, grid_ply):
    code = main(["info", "--json", grid_ply])
    out = capsys.readouterr().out
    assert code == 0
    payload = json.loads(out)
    assert payload["failed"] == []
    (r,) = payload["files"]
    assert r["source"] == grid_ply and r["points"] == 400 and r["scans"] == 2
    assert r["bounds_min"] == [0.0, 0.0, 0.0]
    assert r["bounds_max"] == pytest.approx([1.9, 1.9, 0.0])
    assert r["mean_spacing_m"] == pytest.approx(0.1)
    assert r["fields"] == ["xyz", "colors", "scan_index"]


def test_info_text_output_on_the_real_scan(capsys):
    code = main(["info", SCAN1])
    out = capsys.readouterr().out
    assert code == 0
    assert "112,586" in out and "room_scan1.pcd" in out and "scans         1" in out
    # the PCL scan holds every point twice: the spacing is that of the distinct points
    # (single-position scan, 1-13 m ranges: about 3 cm), not 0
    spacing = float(out.split("mean spacing")[1].split("mm")[0])
    assert 10.0 < spacing < 60.0, out


def test_mean_spacing_skips_exact_duplicates():
    g = np.stack(np.meshgrid(np.arange(30) * 0.05, np.arange(30) * 0.05), -1).reshape(-1, 2)
    xyz = np.column_stack([g, np.zeros(len(g))])
    once = PointCloud(xyz=xyz).mean_spacing()
    twice = PointCloud(xyz=np.vstack([xyz, xyz, xyz])).mean_spacing()
    assert once == pytest.approx(0.05) and twice == pytest.approx(0.05)
    assert PointCloud(xyz=np.zeros((5, 3))).mean_spacing() == 0.0


def test_batch_with_a_bad_file_goes_on_and_fails(capsys, grid_ply, tmp_path):
    bad = tmp_path / "broken.ply"
    bad.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000\nproperty float x\n"
                    b"property float y\nproperty float z\nend_header\n" + b"\x00" * 120)
    missing = str(tmp_path / "missing.las")
    code = main(["info", "--json", str(bad), grid_ply, missing, SCAN1])
    cap = capsys.readouterr()
    assert code == 1
    payload = json.loads(cap.out)
    assert [r["points"] for r in payload["files"]] == [400, 112_586]
    failed = {f["file"]: f["error"] for f in payload["failed"]}
    assert set(failed) == {str(bad), missing}
    assert "truncated" in failed[str(bad)] and "not found" in failed[missing]
    assert str(bad) in cap.err and missing in cap.err and sum(ln.startswith("error:") for ln in cap.err.splitlines()) == 2


def test_all_files_bad_returns_non_zero(capsys, tmp_path):
    p = tmp_path / "scan.obj"
    p.write_text("v 1 2 3\n")
    assert main(["info", "--quiet", str(p)]) == 1
    cap = capsys.readouterr()
    assert cap.out == "" and "unknown file extension" in cap.err and str(p) in cap.err


def test_info_reports_dropped_rows(capsys, tmp_path):
    p = tmp_path / "holes.xyz"
    rows = [f"{i * 0.1} {i % 5 * 0.1} 0" for i in range(30)] + ["nan 0 0", "0 inf 0"]
    p.write_text("\n".join(rows) + "\n")
    assert main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert "points        30" in out and "dropped       2 non-finite rows" in out


def test_info_needs_a_scan_argument(capsys):
    with pytest.raises(SystemExit) as e:
        main(["info"])
    assert e.value.code == 2

"""The `indoor` command line: wiring, convert end to end, errors per file in a batch."""
import json
import os

import pytest

from engine import BuildingModel, __version__
from engine.cli import build_parser, main
from scenes import DATA


def test_help_lists_every_command(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    for cmd in ("info", "convert", "evaluate", "changes", "synth", "segment", "params"):
        assert cmd in out


def test_version(capsys):
    with pytest.raises(SystemExit):
        main(["--version"])
    assert __version__ in capsys.readouterr().out


def test_unknown_method_is_rejected():
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(["convert", "x.ply", "-o", "out", "--method", "magic"])
    assert e.value.code == 2


@pytest.fixture(scope="module")
def small_scan(synthetic_scene, synthetic_scan_file):
    return str(synthetic_scan_file("office_mw", 3, 120_000, "office.ply")), \
        synthetic_scene("office_mw", 3, "tls", 120_000)


def test_convert_batch_writes_outputs_and_names_the_bad_file(small_scan, tmp_path, capsys):
    scan, scene = small_scan
    bad = tmp_path / "broken.ply"
    bad.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000\n"
                    b"property float x\nproperty float y\nproperty float z\nend_header\n" + b"\0" * 12)
    out = tmp_path / "out"
    code = main(["convert", scan, str(bad), "-o", str(out), "--method", "manhattan", "--json"])
    captured = capsys.readouterr()
    assert code == 1  # one file failed
    result = json.loads(captured.out)
    assert [f["file"] for f in result["failed"]] == [str(bad)]
    assert "broken.ply" in captured.err
    # nothing for the bad file; batch.json records both
    assert sorted(os.listdir(out)) == ["batch.json", "office.ifc", "office.json"]
    record = json.loads((out / "batch.json").read_text())
    assert [d["input"] for d in record["done"]] == [scan]
    assert [f["file"] for f in record["failed"]] == [str(bad)]
    model = BuildingModel.from_json(out / "office.json")
    assert model.spaces and model.walls  # quality is the grammar tests' business
    report = json.loads((out / "office.json").read_text())["report"]
    assert report["summary"] == model.summary()
    assert report["provenance"]["method"] == "manhattan"
    assert {"id", "floor_area_m2", "height_m"} <= set(report["spaces"][0])
    assert (out / "office.ifc").read_text()[:20].startswith("ISO-10303-21")


def test_convert_missing_file_exit_code(tmp_path, capsys):
    code = main(["convert", str(tmp_path / "nope.ply"), "-o", str(tmp_path / "o")])
    assert code == 1
    assert "nope.ply" in capsys.readouterr().err
    assert not (tmp_path / "o" / "nope.json").exists()


def test_segment_writes_ply_and_json_and_names_the_bad_file(tmp_path, capsys):
    from engine.io import read_point_cloud

    out = tmp_path / "seg"
    code = main(["segment", os.path.join(DATA, "room_scan1.pcd"), str(tmp_path / "missing.ply"), "-o", str(out),
                 "--set", "generic.cells.min_wall_area=0.7", "--quiet"])
    assert code == 1  # the missing file fails, the scan is still written
    assert "missing.ply" in capsys.readouterr().err
    rep = json.loads((out / "room_scan1_segmentation.json").read_text())
    assert {"points", "working_points", "transform_aligned_to_input", "alignment", "storeys", "planes",
            "timings_s", "cells", "source"} <= set(rep)
    assert len(rep["storeys"]) == 1 and any(p["kind"] == "wall" for p in rep["planes"])
    assert [c["storey"] for c in rep["cells"]] == [s["index"] for s in rep["storeys"]]
    cells = rep["cells"][0]["cells"]
    assert cells and all(c["area"] > 0 and c["z1"] > c["z0"] and len(c["polygon"]) >= 3 for c in cells)
    assert len(rep["transform_aligned_to_input"]) == 4
    back = read_point_cloud(str(out / "room_scan1_segmented.ply"))
    assert len(back) == rep["working_points"]
    assert set(back.fields) >= {"segment_class", "plane"}


def test_segment_voxel_and_bad_key(tmp_path, capsys):
    scan = os.path.join(DATA, "room_scan1.pcd")
    assert main(["segment", scan, "-o", str(tmp_path / "a"), "--set", "preprocess.nope=1"]) == 2
    assert "preprocess.nope" in capsys.readouterr().err
    working = []
    for voxel in ("0.03", "0.06"):
        assert main(["segment", scan, "-o", str(tmp_path / voxel), "--voxel", voxel, "--json"]) == 0
        done = json.loads(capsys.readouterr().out)["segmented"]
        assert [d["file"] for d in done] == [scan] and done[0]["cells"] >= 1
        working.append(json.loads(open(done[0]["json"]).read())["working_points"])
    assert working[1] < working[0]  # --voxel sets the working cloud's voxel


def test_convert_writes_one_ifcspace_per_room_unless_asked_for_the_parts(small_scan, tmp_path, capsys):
    import ifcopenshell

    scan, _ = small_scan
    counts = {}
    for flag in ([], ["--ifc-parts"]):
        out = tmp_path / ("parts" if flag else "rooms")
        assert main(["convert", scan, "-o", str(out), "--method", "manhattan", "--quiet", *flag]) == 0
        model = BuildingModel.from_json(out / "office.json")
        f = ifcopenshell.open(str(out / "office.ifc"))
        counts[bool(flag)] = (len(f.by_type("IfcSpace")), len(model.spaces),
                              sum(s.CompositionType == "PARTIAL" for s in f.by_type("IfcSpace")))
    n_ifc, n_rooms, partial = counts[False]
    assert n_ifc == n_rooms and partial == 0  # every space of the model, none of its parts
    assert counts[True][0] > n_rooms and counts[True][2] > 0  # the grammar's cuboids as PARTIAL


def test_help_imports_no_subcommand_and_no_heavy_library():
    import subprocess
    import sys

    code = ("import sys\nfrom engine.cli import main\ntry:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
            "print(sorted(m for m in sys.modules if m.startswith('engine.cli.') or m.split('.')[0] in "
            "('open3d', 'ifcopenshell', 'scipy', 'networkx', 'trimesh') or m == 'engine.reconstruct'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip().splitlines()[-1] == "['engine.cli.console']"  # the error line helpers only


def test_listed_help_is_each_subcommands_own():
    from engine.cli import COMMANDS

    full = build_parser()
    sub = next(a for a in full._actions if a.dest == "command")
    listed = {c.dest: c.help for c in sub._choices_actions}
    assert listed == COMMANDS

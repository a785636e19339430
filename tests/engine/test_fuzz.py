"""Bad inputs of every kind through the command line: each gives its exit code, one line
naming the file and the kind of error, no traceback, and nothing in the output folder.

Every bad file is generated here (none is stored). A batch with a bad file in the middle
goes on, and two inputs that share a name never overwrite each other.
"""
import json
import os
import struct
import subprocess
import sys
import time

import numpy as np
import pytest

from engine.cli import main
from scenes import ROOT


PLY_XYZ = b"property float x\nproperty float y\nproperty float z\n"


def _ply(body: bytes, count="1000", fmt="binary_little_endian", props=PLY_XYZ, end=True) -> bytes:
    head = f"ply\nformat {fmt} 1.0\nelement vertex {count}\n".encode() + props
    return head + (b"end_header\n" if end else b"") + body


def _xyz_rows(xyz) -> bytes:
    return ("\n".join(f"{x:.4f} {y:.4f} {z:.4f}" for x, y, z in xyz) + "\n").encode()


def _pcd(data: str, body: bytes, points="1000", fields="x y z", size="4 4 4", type_="F F F",
         count="1 1 1") -> bytes:
    head = (f"# .PCD v0.7\nVERSION 0.7\nFIELDS {fields}\nSIZE {size}\nTYPE {type_}\nCOUNT {count}\n"
            f"WIDTH {points}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {points}\nDATA {data}\n")
    return head.encode() + body


def _las_bytes(scale=(0.001, 0.001, 0.001), n=2000, seed=0) -> bytes:
    import io

    import laspy

    rng = np.random.default_rng(seed)
    header = laspy.LasHeader(point_format=3, version="1.2")
    header.offsets = [0.0, 0.0, 0.0]
    header.scales = [0.001, 0.001, 0.001]
    las = laspy.LasData(header)
    xyz = rng.uniform(0, 5, (n, 3))
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    buf = io.BytesIO()
    las.write(buf)
    data = bytearray(buf.getvalue())
    struct.pack_into("<3d", data, 131, *scale)  # the scale factors of a LAS 1.2 header
    return bytes(data)


def _box_points(rng, n=3000):
    """A plausible room's points (floor, ceiling, four walls): used to build degenerate variants."""
    return rng.uniform([0, 0, 0], [5, 4, 2.8], (n, 3))


def _cases():
    rng = np.random.default_rng(7)
    room = _box_points(rng)
    flat = np.column_stack([rng.uniform(0, 6, (4000, 2)), np.zeros(4000)])
    line = np.column_stack([np.linspace(0, 10, 4000), np.zeros(4000), np.zeros(4000)])
    same = np.tile([[1.0, 2.0, 3.0]], (4000, 1))
    tilted = rng.uniform(0, 6, (4000, 2))
    tilted_plane = np.column_stack([tilted, 0.3 * tilted[:, 0] + 0.1 * tilted[:, 1]])
    noise = rng.uniform([0, 0, 0], [8, 6, 3], (20000, 3))
    binary_body = np.zeros((10, 3), "<f4").tobytes()
    c = {
        # --- PLY headers and bodies
        "ply_negative_count.ply": _ply(binary_body, count="-5"),
        "ply_huge_count.ply": _ply(binary_body, count="99999999999"),
        "ply_count_not_a_number.ply": _ply(binary_body, count="lots"),
        "ply_no_end_header.ply": _ply(binary_body, end=False),
        "ply_unknown_format.ply": _ply(binary_body, fmt="binary_middle_endian"),
        "ply_unknown_type.ply": _ply(binary_body, props=b"property float128 x\nproperty float y\n"
                                                         b"property float z\n"),
        "ply_no_xyz.ply": _ply(binary_body, count="10", props=b"property float a\nproperty float b\n"
                                                            b"property float c\n"),
        "ply_truncated.ply": _ply(binary_body, count="1000"),
        "ply_ascii_short_rows.ply": _ply(b"1 2\n3 4\n" * 10, count="20", fmt="ascii"),
        "ply_ascii_words.ply": _ply(b"a b c\n" * 20, count="20", fmt="ascii"),
        "ply_zero_points.ply": _ply(b"", count="0"),
        "ply_magic_only.ply": b"ply\n",
        "ply_garbage.ply": rng.integers(0, 256, 4096, dtype=np.uint8).tobytes(),
        "ply_nul_bytes.ply": b"\0" * 4096,
        "ply_list_xyz.ply": _ply(b"\x03" + b"\0" * 12, count="1",
                                 props=b"property list uchar float x\nproperty float y\nproperty float z\n"),
        "ply_duplicate_property.ply": _ply(binary_body, count="10",
                                           props=b"property float x\nproperty float x\nproperty float z\n"),
        "ply_all_nan.ply": _ply(np.full((50, 3), np.nan, "<f4").tobytes(), count="50"),
        "ply_too_few_points.ply": _ply(np.ones((3, 3), "<f4").tobytes(), count="3"),
        # --- PCD
        "pcd_truncated.pcd": _pcd("binary", b"\0" * 100),
        "pcd_lzf_huge.pcd": _pcd("binary_compressed", struct.pack("<II", 64, 4_000_000_000) + b"\0" * 64),
        "pcd_negative_points.pcd": _pcd("ascii", b"1 2 3\n", points="-4"),
        "pcd_no_data_line.pcd": _pcd("ascii", b"")[:-len(b"DATA ascii\n")],
        "pcd_size_mismatch.pcd": _pcd("binary", b"\0" * 120, points="10", size="4 4"),
        "pcd_ascii_words.pcd": _pcd("ascii", b"a b c\n" * 10, points="10"),
        "pcd_unknown_data.pcd": _pcd("zipped", b"\0" * 120, points="10"),
        # --- LAS / LAZ / E57
        "las_random.las": rng.integers(0, 256, 2048, dtype=np.uint8).tobytes(),
        "las_truncated_header.las": _las_bytes()[:60],
        "las_scale_zero.las": _las_bytes(scale=(0.0, 0.001, 0.001)),
        "laz_random.laz": b"LASF" + rng.integers(0, 256, 2048, dtype=np.uint8).tobytes(),
        "e57_random.e57": rng.integers(0, 256, 4096, dtype=np.uint8).tobytes(),
        "e57_text.e57": b"ASTM-E57 this is not a scan\n" * 50,
        # --- text formats
        "xyz_two_columns.xyz": b"1 2\n3 4\n5 6\n" * 20,
        "xyz_words.xyz": b"one two three\n" * 20,
        "xyz_utf16.xyz": "1.0 2.0 3.0\n".encode("utf-16") * 20,
        "csv_header_only.csv": b"x,y,z\n",
        "xyz_all_nan.xyz": b"nan nan nan\n" * 40,
        "txt_binary_junk.txt": rng.integers(0, 256, 2048, dtype=np.uint8).tobytes(),
        # --- files that are no scan at all
        "empty.ply": b"",
        "wrong_extension.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        "no_extension": _xyz_rows(room),
        # --- readable files whose points can give no model
        "flat.xyz": _xyz_rows(flat),
        "line.xyz": _xyz_rows(line),
        "identical.xyz": _xyz_rows(same),
        "tilted_plane.xyz": _xyz_rows(tilted_plane),
        "noise.xyz": _xyz_rows(noise),
    }
    return c


CASES = _cases()


def _error_lines(err: str):
    return [ln for ln in err.splitlines() if ln.startswith("error:")]


def _assert_clean_failure(code, cap, name, out, want_code=1):
    assert code == want_code, (name, code, cap.err[-2000:])
    assert "Traceback" not in cap.err, cap.err[-2000:]
    lines = _error_lines(cap.err)
    assert len(lines) == 1, cap.err[-2000:]
    assert name in lines[0], lines[0]
    kind = lines[0].split(": ")
    assert any(f"{k} error" in lines[0] for k in ("input", "reconstruction", "output")), lines[0]
    assert "internal error" not in lines[0], lines[0]
    assert len(kind) >= 2
    assert not os.path.exists(out) or os.listdir(out) == [], os.listdir(out)


def test_at_least_forty_bad_inputs():
    assert len(CASES) >= 40


@pytest.mark.parametrize("name", sorted(CASES))
def test_bad_input_gives_one_typed_line_and_writes_nothing(name, tmp_path, capsys):
    path = tmp_path / name
    path.write_bytes(CASES[name])
    out = tmp_path / "out"
    t0 = time.perf_counter()
    code = main(["convert", str(path), "-o", str(out), "--quiet"])
    seconds = time.perf_counter() - t0
    _assert_clean_failure(code, capsys.readouterr(), name, out)
    assert seconds < 60, seconds  # degenerate clouds fail fast (the goal is < 10 s; margin for busy CI)


@pytest.mark.parametrize("name", ["ply_negative_count.ply", "ply_garbage.ply", "las_scale_zero.las",
                                  "xyz_words.xyz"])
def test_info_on_bad_input_gives_one_line(name, tmp_path, capsys):
    path = tmp_path / name
    path.write_bytes(CASES[name])
    code = main(["info", str(path)])
    cap = capsys.readouterr()
    assert code == 1 and "Traceback" not in cap.err
    lines = _error_lines(cap.err)
    assert len(lines) == 1 and name in lines[0] and "input error" in lines[0], cap.err


def test_missing_file_and_folder_as_input(tmp_path, capsys):
    out = tmp_path / "out"
    for target in (tmp_path / "nope.ply", tmp_path):
        code = main(["convert", str(target), "-o", str(out), "--quiet"])
        _assert_clean_failure(code, capsys.readouterr(), str(target), out)


def test_undecodable_file_name_is_named_in_the_error(tmp_path, capsys):
    raw = os.fsencode(str(tmp_path)) + b"/scan_\xff\xfe.xyz"
    with open(raw, "wb") as f:
        f.write(b"one two three\n" * 20)
    out = tmp_path / "out"
    code = main(["convert", os.fsdecode(raw), "-o", str(out), "--quiet"])
    cap = capsys.readouterr()
    assert code == 1 and "Traceback" not in cap.err
    lines = _error_lines(cap.err)
    assert len(lines) == 1 and "scan_\\xff\\xfe.xyz" in lines[0], cap.err
    assert not out.exists() or os.listdir(out) == []


@pytest.mark.parametrize("argv_tail", [["--seed", "-1"], ["--seed", "1.5"], ["--method", "magic"],
                                       ["--units", "furlong"], ["--up", "sideways"]])
def test_bad_options_are_usage_errors(argv_tail, tmp_path, capsys):
    path = tmp_path / "scan.xyz"
    path.write_bytes(b"0 0 0\n" * 20)
    with pytest.raises(SystemExit) as e:
        main(["convert", str(path), "-o", str(tmp_path / "out"), *argv_tail])
    assert e.value.code == 2
    assert "Traceback" not in capsys.readouterr().err


def test_output_folder_checked_before_any_work(tmp_path, capsys, monkeypatch):
    """A file as -o, or a folder below a file, fails at once: the scan is never read."""
    import engine.io

    def never(*a, **k):  # pragma: no cover - reaching it is the failure
        raise AssertionError("the scan was read before the output folder was checked")

    monkeypatch.setattr(engine.io, "read_point_cloud", never)
    scan = tmp_path / "scan.xyz"
    scan.write_bytes(b"0 0 0\n" * 20)
    blocker = tmp_path / "f"
    blocker.write_text("x")
    for out in (blocker, blocker / "sub"):
        t0 = time.perf_counter()
        code = main(["convert", str(scan), "-o", str(out), "--quiet"])
        cap = capsys.readouterr()
        assert time.perf_counter() - t0 < 5  # no work was done (margin for a busy machine)
        assert code == 1 and "Traceback" not in cap.err
        lines = _error_lines(cap.err)
        assert len(lines) == 1 and "output error" in lines[0] and str(out) in lines[0], cap.err
    assert blocker.read_text() == "x"


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into read-only folders")
def test_read_only_output_folder(tmp_path, capsys):
    scan = tmp_path / "scan.xyz"
    scan.write_bytes(b"0 0 0\n" * 20)
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o555)
    try:
        code = main(["convert", str(scan), "-o", str(ro / "out"), "--quiet"])
    finally:
        ro.chmod(0o755)
    assert code == 1 and "output error" in capsys.readouterr().err


def test_internal_errors_become_one_line_and_the_batch_goes_on(tmp_path, capsys, monkeypatch):
    """A bug (any exception that is not the engine's own) is an 'internal error' line asking for
    a bug report; --debug adds the traceback."""
    import engine.reconstruct

    def boom(*a, **k):
        raise ZeroDivisionError("float division by zero")

    monkeypatch.setattr(engine.reconstruct, "convert_file", boom)
    a, b = tmp_path / "a.xyz", tmp_path / "b.xyz"
    for p in (a, b):
        p.write_bytes(b"0 0 0\n")
    code = main(["convert", str(a), str(b), "-o", str(tmp_path / "out"), "--quiet"])
    cap = capsys.readouterr()
    lines = _error_lines(cap.err)
    assert code == 1 and len(lines) == 2 and "Traceback" not in cap.err
    assert all("internal error: ZeroDivisionError" in ln and "bug" in ln for ln in lines)
    code = main(["convert", str(a), "-o", str(tmp_path / "out"), "--quiet", "--debug"])
    assert code == 1 and "Traceback" in capsys.readouterr().err


# --------------------------------------------------------------------------- batches
@pytest.fixture(scope="module")
def good_scan(synthetic_scan_file):
    return synthetic_scan_file("office_mw", 1, 60_000, "good.ply")


def test_batch_with_a_bad_file_in_the_middle_and_two_inputs_of_one_name(good_scan, tmp_path, capsys):
    import shutil

    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    shutil.copy(good_scan, a / "good.ply")
    shutil.copy(good_scan, b / "good.ply")
    bad = tmp_path / "bad.ply"
    bad.write_bytes(CASES["ply_negative_count.ply"])
    out = tmp_path / "out"
    code = main(["convert", str(a / "good.ply"), str(bad), str(b / "good.ply"), "-o", str(out),
                 "--method", "manhattan", "--json"])
    cap = capsys.readouterr()
    assert code == 1
    assert "Traceback" not in cap.err and len(_error_lines(cap.err)) == 1
    payload = json.loads(cap.out)
    assert [f["file"] for f in payload["failed"]] == [str(bad)]
    assert sorted(os.listdir(out)) == ["batch.json", "good.ifc", "good.json", "good_2.ifc", "good_2.json"]
    record = json.loads((out / "batch.json").read_text())
    assert [d["input"] for d in record["done"]] == [str(a / "good.ply"), str(b / "good.ply")]
    assert [os.path.basename(d["json"]) for d in record["done"]] == ["good.json", "good_2.json"]
    assert record["failed"] == [{"file": str(bad), "kind": "input",
                                 "error": payload["failed"][0]["error"]}]
    first = json.loads((out / "good.json").read_text())["report"]["source"]["path"]
    second = json.loads((out / "good_2.json").read_text())["report"]["source"]["path"]
    assert (first, second) == (str(a / "good.ply"), str(b / "good.ply"))


def test_sigterm_leaves_no_temporary_file(good_scan, tmp_path):
    """SIGTERM (what `timeout` and schedulers send) stops like Ctrl-C: exit 130, no temporary
    file of ours or of ifcopenshell's, and the files finished before it intact."""
    import shutil
    import signal

    scans = []
    for i in range(4):
        p = tmp_path / f"s{i}.ply"
        shutil.copy(good_scan, p)
        scans.append(str(p))
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=ROOT)
    proc = subprocess.Popen([sys.executable, "-m", "engine", "convert", *scans, "-o", str(out),
                             "--method", "manhattan", "--quiet"], cwd=ROOT, env=env,
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    deadline = time.time() + 240
    while time.time() < deadline and proc.poll() is None:  # stop it after the first model
        if out.exists() and any(n.endswith(".json") for n in os.listdir(out)):
            break
        time.sleep(0.05)
    running = proc.poll() is None
    if running:
        proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=120)
    err = err.decode("utf-8", "replace")
    if not running:  # the machine converted all four before we looked: nothing to interrupt
        pytest.skip("the batch finished before it could be interrupted")
    assert proc.returncode == 130, err[-2000:]
    assert "Traceback" not in err
    left = sorted(os.listdir(out))
    assert not [n for n in left if ".part" in n or n.endswith(".tmp") or n.startswith(".")], left
    for n in left:
        if n.endswith(".json"):
            json.loads((out / n).read_text())  # complete, not half-written
    stems = {os.path.splitext(n)[0] for n in left if n != "batch.json"}
    assert all((out / f"{s}.ifc").exists() and (out / f"{s}.json").exists() for s in stems)
    shutil.rmtree(out)

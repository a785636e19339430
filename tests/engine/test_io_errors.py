"""Bad input, one case at a time: each gives a typed error naming the file and the problem
(or, for non-finite values and millimetre units, a count / a warning flag)."""
import logging
import os
import struct

import numpy as np
import pytest

from engine.errors import EmptyCloudError, FormatError, IndoorError, InputError
from engine.io import ReadParams, read_point_cloud, units_warning, write_ply
from engine.pointcloud import MIN_POINTS, PointCloud


def _cloud(n=100, seed=0, scale=1.0, shift=0.0):
    rng = np.random.default_rng(seed)
    return PointCloud(xyz=rng.uniform(0, 8, (n, 3)) * scale + shift)


def _raises(exc, path, *words):
    """Read ``path`` expecting ``exc``; the message must name the file and contain ``words``."""
    with pytest.raises(exc) as info:
        read_point_cloud(path)
    msg = str(info.value)
    assert str(path) in msg, msg
    for w in words:
        assert w in msg.lower(), msg
    return info.value


def test_missing_file(tmp_path):
    e = _raises(InputError, tmp_path / "nope.ply", "not found")
    assert e.path == str(tmp_path / "nope.ply")


def test_directory(tmp_path):
    d = tmp_path / "scan.ply"
    d.mkdir()
    _raises(InputError, d, "directory")


@pytest.mark.parametrize("ext", [".ply", ".pcd", ".xyz", ".las", ".e57"])
def test_empty_file(tmp_path, ext):
    p = tmp_path / f"empty{ext}"
    p.write_bytes(b"")
    _raises(EmptyCloudError, p, "empty")


def test_unknown_extension(tmp_path):
    p = tmp_path / "scan.obj"
    p.write_text("v 0 0 0\n")
    _raises(InputError, p, "unknown file extension", ".obj", ".ply")


def test_truncated_binary_ply(tmp_path):
    p = tmp_path / "t.ply"
    write_ply(p, _cloud(200))
    data = p.read_bytes()
    p.write_bytes(data[:-100])
    e = _raises(FormatError, p, "truncated", "200")
    assert "only 195" in str(e)  # complete vertices left: (200*24-100)//24 = 195
    p.write_bytes(data[: len(data) - 200 * 24 + 5])  # header + 5 bytes
    _raises(FormatError, p, "truncated")


def test_ply_header_count_larger_than_data_ascii(tmp_path):
    p = tmp_path / "a.ply"
    rows = "".join(f"{i} {i} {i}\n" for i in range(20))
    p.write_text("ply\nformat ascii 1.0\nelement vertex 25\nproperty float x\nproperty float y\n"
                 "property float z\nend_header\n" + rows)
    _raises(FormatError, p, "25", "20")


def test_not_a_ply(tmp_path):
    p = tmp_path / "x.ply"
    p.write_bytes(b"solid cube\nfacet normal 0 0 1\n")
    _raises(FormatError, p, "not a ply")


def test_truncated_pcd_binary_and_compressed(tmp_path):
    head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 50\nHEIGHT 1\nPOINTS 50\n"
    p = tmp_path / "b.pcd"
    p.write_bytes((head + "DATA binary\n").encode() + np.zeros(40 * 3, "<f4").tobytes())
    _raises(FormatError, p, "truncated", "50")
    q = tmp_path / "c.pcd"
    q.write_bytes((head + "DATA binary_compressed\n").encode() + struct.pack("<II", 1000, 600) + b"\x00" * 10)
    _raises(FormatError, q, "truncated")
    r = tmp_path / "d.pcd"  # a stream that decodes to less than POINTS needs
    r.write_bytes((head + "DATA binary_compressed\n").encode() + struct.pack("<II", 2, 1) + b"\x00\x01")
    _raises(FormatError, r, "50")


def test_pcd_ascii_header_count_larger_than_data(tmp_path):
    p = tmp_path / "a.pcd"
    rows = "".join(f"{i} {i} {i}\n" for i in range(30))
    p.write_text("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 40\nHEIGHT 1\n"
                 "POINTS 40\nDATA ascii\n" + rows)
    _raises(FormatError, p, "40", "30")


def test_pts_count_larger_than_data(tmp_path):
    p = tmp_path / "a.pts"
    p.write_text("100\n" + "".join(f"{i} 1 2 5 10 20 30\n" for i in range(60)))
    _raises(FormatError, p, "100", "60", "larger")


def test_wrong_column_count_names_the_line(tmp_path):
    p = tmp_path / "a.xyz"
    lines = [f"{i} {i} {i}" for i in range(30)]
    lines[17] = "17 17"
    p.write_text("\n".join(lines) + "\n")
    _raises(FormatError, p, "line 18", "wrong column count", "2 values", "expected 3")


def test_not_a_number_names_the_line(tmp_path):
    p = tmp_path / "a.csv"
    lines = [f"{i},{i},{i}" for i in range(30)]
    lines[4] = "4,four,4"
    p.write_text("\n".join(lines) + "\n")
    _raises(FormatError, p, "line 5", "not a number")


def test_too_few_columns(tmp_path):
    p = tmp_path / "a.txt"
    p.write_text("".join(f"{i} {i}\n" for i in range(30)))
    _raises(FormatError, p, "at least 3")


def test_non_finite_rows_are_dropped_and_counted(tmp_path, caplog):
    p = tmp_path / "a.xyz"
    lines = [f"{i} {i % 7} 1.5" for i in range(40)]
    lines[3] = "nan 1 2"
    lines[9] = "1 inf 2"
    lines[20] = "1 2 -inf"
    p.write_text("\n".join(lines) + "\n")
    with caplog.at_level(logging.WARNING, logger="engine.io"):
        c = read_point_cloud(p)
    assert len(c) == 37 and c.dropped_nonfinite == 3
    assert np.isfinite(c.xyz).all()
    assert "dropped 3 of 40" in caplog.text
    np.testing.assert_array_equal(c.xyz[:5, 0], [0, 1, 2, 4, 5])


def test_all_non_finite_is_an_error(tmp_path):
    cloud = PointCloud(xyz=np.full((30, 3), np.nan))
    p = tmp_path / "nan.ply"
    write_ply(p, cloud)
    _raises(EmptyCloudError, p, "all 30 points", "non-finite")


def test_fewer_points_than_min_points(tmp_path):
    p = tmp_path / "few.xyz"
    p.write_text("".join(f"{i} {i} {i}\n" for i in range(MIN_POINTS - 1)))
    _raises(EmptyCloudError, p, f"only {MIN_POINTS - 1}", str(MIN_POINTS))
    p.write_text("".join(f"{i} {i} {i}\n" for i in range(MIN_POINTS)))
    assert len(read_point_cloud(p)) == MIN_POINTS


def test_ply_with_zero_vertices(tmp_path):
    p = tmp_path / "zero.ply"
    p.write_text("ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\n"
                 "property float y\nproperty float z\nend_header\n")
    _raises(EmptyCloudError, p, "no points")


def test_millimetre_coordinates_warn_and_flag_but_are_not_rescaled(tmp_path, caplog):
    mm = _cloud(500, seed=4, scale=1000.0)  # an 8 m room written in millimetres
    p = tmp_path / "mm.ply"
    write_ply(p, mm)
    with caplog.at_level(logging.WARNING, logger="engine.io"):
        c = read_point_cloud(p)
    assert "millimetres" in caplog.text and str(p) in caplog.text
    assert "millimetres" in units_warning(c)
    np.testing.assert_array_equal(c.xyz + c.offset, mm.xyz)  # not rescaled
    ok = _cloud(500, seed=4)
    write_ply(p, ok)
    assert units_warning(read_point_cloud(p)) is None


def test_georeferenced_offset_is_removed_not_flagged(tmp_path):
    geo = _cloud(500, seed=5, shift=np.array([651_234.567, 5_801_987.654, 312.5]))
    p = tmp_path / "geo.ply"
    write_ply(p, geo)
    c = read_point_cloud(p)
    np.testing.assert_array_equal(c.offset, [651_200.0, 5_802_000.0, 0.0])  # z (< 1e4 m) kept
    assert np.abs(c.xyz[:, :2]).max() < 100 and units_warning(c) is None
    back = c.xyz.astype(np.float32).astype(np.float64) + c.offset
    assert np.abs(back - geo.xyz).max() < 1e-4  # float32 keeps 0.1 mm
    assert np.abs(geo.xyz.astype(np.float32) - geo.xyz).max() > 0.01  # without the offset: cm lost
    small = _cloud(100, seed=6)
    write_ply(p, small)
    np.testing.assert_array_equal(read_point_cloud(p).offset, [0, 0, 0])


def test_offset_threshold_is_a_parameter(tmp_path):
    p = tmp_path / "p.ply"
    write_ply(p, _cloud(100, shift=5000.0))
    assert np.all(read_point_cloud(p).offset == 0)
    c = read_point_cloud(p, params=ReadParams(offset_threshold_m=1000.0))
    np.testing.assert_array_equal(c.offset, [5000.0, 5000.0, 5000.0])


@pytest.mark.parametrize("ext", [".las", ".laz", ".e57"])
def test_unreadable_las_and_e57(tmp_path, ext):
    p = tmp_path / f"junk{ext}"
    p.write_bytes(os.urandom(4096))
    e = _raises(FormatError, p)
    assert isinstance(e, IndoorError)
    assert "las" in str(e).lower() or "e57" in str(e).lower()
    # one short line: libE57's debug trail (file names, checksums, C++ source lines) left out
    assert "\n" not in str(e) and "****" not in str(e) and len(str(e)) < 200, str(e)


def test_truncated_las(tmp_path):
    laspy = pytest.importorskip("laspy")
    las = laspy.LasData(laspy.LasHeader(point_format=0, version="1.2"))
    las.x = np.linspace(0, 10, 1000)
    las.y = np.linspace(0, 5, 1000)
    las.z = np.zeros(1000)
    p = tmp_path / "cut.las"
    las.write(str(p))
    data = p.read_bytes()
    p.write_bytes(data[: len(data) - 5000])
    _raises(FormatError, p, "truncated", "1,000 points", "only 750")
    z = tmp_path / "cut.laz"
    las.write(str(z))
    data = z.read_bytes()
    z.write_bytes(data[: len(data) // 2])
    _raises(FormatError, z, "truncated")


def test_e57_without_scans(tmp_path):
    pye57 = pytest.importorskip("pye57")
    p = tmp_path / "none.e57"
    e = pye57.E57(str(p), mode="w")
    e.close()
    _raises(FormatError, p, "no scans")


def test_every_error_is_an_indoor_error(tmp_path):
    for name, content in [("a.ply", b"ply\nformat weird 1.0\nend_header\n"), ("b.pcd", b"hello\n"),
                          ("c.xyz", b"a b c\n")]:
        p = tmp_path / name
        p.write_bytes(content)
        with pytest.raises(IndoorError) as info:
            read_point_cloud(p)
        assert str(p) in str(info.value)


def test_laz_without_backend_names_the_package(tmp_path, monkeypatch):
    laspy = pytest.importorskip("laspy")
    from engine.errors import MissingDependencyError

    p = tmp_path / "s.laz"
    p.write_bytes(b"LASF" + bytes(400))
    monkeypatch.setattr(laspy.LazBackend, "detect_available", staticmethod(lambda: ()))
    with pytest.raises(MissingDependencyError) as info:
        read_point_cloud(p)
    assert "lazrs" in str(info.value) and str(p) in str(info.value)


def test_ply_duplicate_property_and_missing_z(tmp_path):
    p = tmp_path / "dup.ply"
    p.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
                  b"property float x\nproperty float z\nend_header\n" + bytes(12))
    _raises(FormatError, p, "twice")
    p.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\n"
                  b"property float y\nend_header\n" + bytes(8))
    _raises(FormatError, p, "lacks x, y or z")

"""Scan readers check header counts and sizes before they allocate, and never misread.

Every bad file is generated here, in tmp_path. Each case gives a typed error naming the file
(FormatError / EmptyCloudError / InputError), a correct read, or a correct read with a warning.
Checks "before allocating" measure the peak of traced memory (numpy reports its buffers to
tracemalloc): a reader that allocated from a corrupt count would peak at hundreds of MB.
"""
import logging
import os
import struct
import tracemalloc

import numpy as np
import pytest

from engine.errors import FormatError, IndoorError
from engine.io import ReadParams, lzf_decompress, read_point_cloud, write_ply
from engine.pointcloud import PointCloud
from scenes import ROOT

XYZ = "property float x\nproperty float y\nproperty float z\n"
PEAK_LIMIT = 32 << 20
"""Traced memory a rejected small file may use (bytes): the files are < 1 MB, a reader that
allocated from their corrupt counts would need 240 MB or more."""


def _ply(count, body: bytes, fmt="binary_little_endian", props=XYZ, before="", after="") -> bytes:
    head = f"ply\nformat {fmt} 1.0\n{before}element vertex {count}\n{props}{after}end_header\n"
    return head.encode() + body


def _rows(n, start=0) -> bytes:
    return "".join(f"{i}.5 {2 * i}.25 {i % 7}\n" for i in range(start, start + n)).encode()


def _bin(n) -> bytes:
    return np.arange(3 * n, dtype="<f4").tobytes()


def _raises(exc, path, *words, params=None):
    """Read ``path`` expecting ``exc`` naming the file and holding ``words`` (lower case);
    returns the error and the peak traced memory in bytes."""
    tracemalloc.start()
    try:
        with pytest.raises(exc) as info:
            read_point_cloud(path, params=params)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    msg = str(info.value)
    assert str(path) in msg, msg
    for w in words:
        assert w in msg.lower(), msg
    return info.value, peak


def _write(tmp_path, name, data: bytes):
    p = tmp_path / name
    p.write_bytes(data)
    return p


# --------------------------------------------------------------------------- PLY counts
@pytest.mark.parametrize("fmt", ["binary_little_endian", "ascii"])
def test_ply_negative_count(tmp_path, fmt):
    p = _write(tmp_path, "neg.ply", _ply(-5, _bin(20) if fmt != "ascii" else _rows(20), fmt))
    _raises(FormatError, p, "negative", "-5", "vertex")


@pytest.mark.parametrize("count", ["2e1", "20.0", "lots", "1_000", "0x14"])
def test_ply_count_not_a_whole_number(tmp_path, count):
    p = _write(tmp_path, "nan.ply", _ply(count, _bin(20)))
    _raises(FormatError, p, "not a whole number", count.lower())


def test_ply_count_with_plus_sign_reads(tmp_path):
    p = _write(tmp_path, "plus.ply", _ply("+20", _bin(20)))
    c = read_point_cloud(p)
    assert len(c) == 20 and c.warnings == ()
    np.testing.assert_array_equal(c.xyz.ravel(), np.arange(60))


@pytest.mark.parametrize("fmt", ["binary_little_endian", "ascii"])
@pytest.mark.parametrize("count", [50_000_000, 99_999_999_999])
def test_ply_huge_count_is_refused_before_allocating(tmp_path, fmt, count):
    body = _bin(20) if fmt != "ascii" else _rows(20)
    p = _write(tmp_path, "huge.ply", _ply(count, body, fmt))
    _, peak = _raises(FormatError, p, f"{count:,}")
    assert peak < PEAK_LIMIT, peak  # 50M vertices would be 1.2 GB of float64 xyz


@pytest.mark.parametrize("fmt", ["binary_little_endian", "ascii"])
def test_ply_huge_element_before_the_vertices(tmp_path, fmt):
    body = _bin(20) if fmt != "ascii" else _rows(20)
    p = _write(tmp_path, "face_first.ply", _ply(20, body, fmt, before="element face 99999999999\n"
                                                                   "property int a\n"))
    _, peak = _raises(FormatError, p, "99,999,999,999", "'face'")
    assert peak < PEAK_LIMIT, peak


def test_ply_ascii_element_before_the_vertices_is_skipped(tmp_path):
    p = _write(tmp_path, "cam.ply", _ply(15, b"7 8\n\n9 10\n" + _rows(15), "ascii",
                                         before="element camera 2\nproperty int a\nproperty int b\n"))
    c = read_point_cloud(p)  # the blank line among the camera rows is not a row
    assert len(c) == 15 and c.warnings == ()
    np.testing.assert_array_equal(c.xyz[:, 0], np.arange(15) + 0.5)


@pytest.mark.parametrize("fmt", ["binary_little_endian", "ascii"])
def test_ply_huge_face_count_after_the_vertices_warns(tmp_path, fmt, caplog):
    body = _bin(20) if fmt != "ascii" else _rows(20)
    p = _write(tmp_path, "faces.ply", _ply(20, body + (b"3 0 1 2\n" if fmt == "ascii" else b""), fmt,
                                           after="element face 99999999999\n"
                                                 "property list uchar int vertex_indices\n"))
    with caplog.at_level(logging.WARNING, logger="engine.io"):
        c = read_point_cloud(p)
    assert len(c) == 20
    assert len(c.warnings) == 1 and "99,999,999,999 'face'" in c.warnings[0], c.warnings
    assert "99,999,999,999 'face'" in caplog.text and str(p) in caplog.text


def test_ply_binary_trailing_data_warns(tmp_path, caplog):
    p = _write(tmp_path, "under.ply", _ply(15, _bin(20)))
    with caplog.at_level(logging.WARNING, logger="engine.io"):
        c = read_point_cloud(p)
    assert len(c) == 15  # the declared vertices
    np.testing.assert_array_equal(c.xyz.ravel(), np.arange(45))
    assert len(c.warnings) == 1 and "60 bytes" in c.warnings[0] and "5 more vertices" in c.warnings[0]
    assert "60 bytes" in caplog.text and str(p) in caplog.text
    p = _write(tmp_path, "exact.ply", _ply(20, _bin(20)))  # the control: no warning
    assert read_point_cloud(p).warnings == ()
    p = _write(tmp_path, "newline.ply", _ply(20, _bin(20) + b"\n"))  # less than one record: no warning
    assert read_point_cloud(p).warnings == ()


def test_ply_ascii_extra_lines_warn(tmp_path, caplog):
    p = _write(tmp_path, "under.ply", _ply(15, _rows(20) + b"\n", "ascii"))
    with caplog.at_level(logging.WARNING, logger="engine.io"):
        c = read_point_cloud(p)
    assert len(c) == 15
    np.testing.assert_array_equal(c.xyz[:, 1], 2 * np.arange(15) + 0.25)
    assert len(c.warnings) == 1 and "5 more lines" in c.warnings[0], c.warnings
    assert "5 more lines" in caplog.text
    faces = b"3 0 1 2\n3 1 2 3\n"  # faces declared after the vertices are not extra lines
    p = _write(tmp_path, "faces.ply", _ply(20, _rows(20) + faces + b"\n", "ascii",
                                           after="element face 2\nproperty list uchar int vertex_indices\n"))
    assert read_point_cloud(p).warnings == ()
    p = _write(tmp_path, "faces3.ply", _ply(20, _rows(20) + faces + b"3 2 3 4\n", "ascii",
                                            after="element face 2\nproperty list uchar int vertex_indices\n"))
    assert "1 more lines" in read_point_cloud(p).warnings[0]


def test_ply_ascii_blank_lines_inside_the_vertices_chunked(tmp_path, monkeypatch):
    import engine.io.ply as ply

    rows = _rows(300).split(b"\n")
    rows.insert(150, b"")  # a blank line inside the vertex block
    rows.insert(299, b"   ")
    body = b"\n".join(rows) + b"3 0 1 2\n"
    p = _write(tmp_path, "blank.ply", _ply(300, body, "ascii",
                                           after="element face 1\nproperty list uchar int vertex_indices\n"))
    monkeypatch.setattr(ply, "_ASCII_CHUNK_BYTES", 700)
    c = read_point_cloud(p)
    assert len(c) == 300 and c.warnings == ()
    np.testing.assert_array_equal(c.xyz[:, 0], np.arange(300) + 0.5)


@pytest.mark.parametrize("header, words", [
    (_ply(20, b"", props=XYZ.replace("float z", "float128 z")), ["unknown ply property type", "float128"]),
    (_ply(20, b"", props=XYZ + "property list float int idx\n"), ["count type", "integer"]),
    (b"ply\nformat binary_little_endian 1.0\nelement vertex 20\n" + XYZ.encode() + b"end_header junk\n",
     ["no 'end_header' line"]),
    (b"ply\nformat binary_little_endian 1.0\nelement vertex 20\n" + XYZ.encode()[:20], ["no 'end_header'"]),
    (b"ply\nformat binary_little_endian 1.0\nelement\n" + XYZ.encode() + b"end_header\n", ["malformed"]),
])
def test_ply_bad_headers(tmp_path, header, words):
    p = _write(tmp_path, "h.ply", header + _bin(20))
    _raises(FormatError, p, *words)


def test_ply_end_header_inside_a_comment_is_not_the_end(tmp_path):
    p = _write(tmp_path, "c.ply", b"ply\nformat binary_little_endian 1.0\ncomment no end_header here\n"
                                  b"element vertex 20\n" + XYZ.encode() + b"end_header\n" + _bin(20))
    c = read_point_cloud(p)
    assert len(c) == 20 and c.warnings == ()


# --------------------------------------------------------------------------- PCD
def _pcd(data, body: bytes, points=20, width=None, height=1, count="1 1 1") -> bytes:
    width = points if width is None else width
    return (f"VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT {count}\nWIDTH {width}\n"
            f"HEIGHT {height}\nPOINTS {points}\nDATA {data}\n").encode() + body


@pytest.mark.parametrize("csize, usize, words", [
    (64, 4_000_000_000, ["4,000,000,000 uncompressed", "240 bytes"]),  # declares 4 GB
    (4_000_000_000, 240, ["truncated", "4,000,000,000 compressed"]),
    (1, 240, ["at most 88"]),  # 1 LZF byte cannot decode to 240
])
def test_pcd_compressed_sizes_checked_before_allocating(tmp_path, csize, usize, words):
    p = _write(tmp_path, "lzf.pcd", _pcd("binary_compressed", struct.pack("<II", csize, usize) + b"\0" * 64))
    _, peak = _raises(FormatError, p, *words)
    assert peak < PEAK_LIMIT, peak


def test_pcd_lzf_stream_cut_in_a_back_reference(tmp_path):
    with pytest.raises(ValueError, match="cut"):
        lzf_decompress(b"\x02abc\xe0", 20)  # 3 literals, then a long back reference with no bytes
    p = _write(tmp_path, "cut.pcd", _pcd("binary_compressed", struct.pack("<II", 5, 12) + b"\x02abc\xe0",
                                         points=1))
    _raises(FormatError, p, "corrupt", "cut")


@pytest.mark.parametrize("data", ["binary", "ascii"])
@pytest.mark.parametrize("points", [50_000_000, 99_999_999_999])
def test_pcd_huge_points_refused_before_allocating(tmp_path, data, points):
    body = _bin(20) if data == "binary" else _rows(20)
    p = _write(tmp_path, "huge.pcd", _pcd(data, body, points=points))
    _, peak = _raises(FormatError, p, f"{points:,}")
    assert peak < PEAK_LIMIT, peak


@pytest.mark.parametrize("kw, words", [
    (dict(points=-4), ["negative", "-4"]),
    (dict(points=20, width=10), ["width 10", "points 20"]),
    (dict(points=20, width=5, height=3), ["height 3", "points 20"]),
    (dict(count="1 1 0"), ["count 0"]),
    (dict(count="1 1 x"), ["count", "not a whole number"]),
])
def test_pcd_bad_header_counts(tmp_path, kw, words):
    p = _write(tmp_path, "bad.pcd", _pcd("binary", _bin(20), **kw))
    _raises(FormatError, p, *words)


def test_pcd_binary_trailing_data_warns(tmp_path):
    p = _write(tmp_path, "under.pcd", _pcd("binary", _bin(20), points=15))
    c = read_point_cloud(p)
    assert len(c) == 15 and len(c.warnings) == 1 and "5 more" in c.warnings[0]
    np.testing.assert_array_equal(c.xyz.ravel(), np.arange(45))
    assert read_point_cloud(_write(tmp_path, "ok.pcd", _pcd("binary", _bin(20)))).warnings == ()


def test_pcd_organised_width_times_height(tmp_path):
    p = _write(tmp_path, "org.pcd", _pcd("binary", _bin(20), points=20, width=5, height=4))
    assert len(read_point_cloud(p)) == 20


# --------------------------------------------------------------------------- LAS
def _las_file(tmp_path, name="s.las", n=1000):
    laspy = pytest.importorskip("laspy")
    las = laspy.LasData(laspy.LasHeader(point_format=0, version="1.2"))
    rng = np.random.default_rng(3)
    las.x, las.y, las.z = rng.uniform(0, 10, n), rng.uniform(0, 5, n), rng.uniform(0, 3, n)
    p = tmp_path / name
    las.write(str(p))
    return p


def _patch(p, offset, fmt, *values):
    data = bytearray(p.read_bytes())
    struct.pack_into(fmt, data, offset, *values)
    p.write_bytes(bytes(data))


_SCALES = 131  # LAS 1.2 header: x, y, z scale factors (3 doubles), then x, y, z offsets
_OFFSETS = 155
_POINT_COUNT = 107  # legacy number of point records (uint32)


@pytest.mark.parametrize("ext", ["las", "laz"])
@pytest.mark.parametrize("axis", [0, 1, 2])
def test_las_zero_scale_is_refused_naming_the_axis(tmp_path, ext, axis):
    p = _las_file(tmp_path, f"s.{ext}")
    assert len(read_point_cloud(p)) == 1000  # the file is good before the patch
    _patch(p, _SCALES + 8 * axis, "<d", 0.0)
    _raises(FormatError, p, f"{'xyz'[axis]} scale factor is 0")


@pytest.mark.parametrize("where, value, words", [
    (_SCALES + 8, float("nan"), ["y scale factor is nan"]),
    (_SCALES + 16, float("inf"), ["z scale factor is inf"]),
    (_OFFSETS, float("-inf"), ["x offset is -inf"]),
])
def test_las_non_finite_scale_or_offset(tmp_path, where, value, words):
    p = _las_file(tmp_path)
    _patch(p, where, "<d", value)
    _raises(FormatError, p, *words)


@pytest.mark.parametrize("ext", ["las", "laz"])
def test_las_huge_point_count_allocates_nothing_big(tmp_path, ext):
    p = _las_file(tmp_path, f"s.{ext}")
    _patch(p, _POINT_COUNT, "<I", 4_000_000_000)
    _, peak = _raises(FormatError, p, "4,000,000,000", params=ReadParams(chunk_points=10_000))
    assert peak < PEAK_LIMIT, peak  # 4e9 points would be 96 GB of xyz


def test_laz_arrays_grow_to_the_points_read(tmp_path, monkeypatch):
    import engine.io.las as las

    p = _las_file(tmp_path, "s.laz", n=5000)
    whole = read_point_cloud(p)
    monkeypatch.setattr(las, "_LAZ_FIRST_RATIO", 0)  # start at one point: every chunk grows the arrays
    grown = read_point_cloud(p, params=ReadParams(chunk_points=700))
    np.testing.assert_array_equal(whole.xyz, grown.xyz)
    np.testing.assert_array_equal(whole.intensity, grown.intensity)
    np.testing.assert_array_equal(whole.fields["classification"], grown.fields["classification"])


_ISOLATED = """
import json, resource, sys
resource.setrlimit(resource.RLIMIT_AS, (4 << 30, 4 << 30))
from engine.errors import IndoorError
from engine.io import read_point_cloud
try:
    c = read_point_cloud(sys.argv[1])
    print(json.dumps(["read", len(c)]))
except IndoorError as e:
    print(json.dumps([type(e).__name__, str(e)]))
"""


def _read_isolated(path):
    """Read in a fresh Python limited to 4 GB of address space and 120 s: before the checks
    these files made laspy loop for hours, or the LAZ decoder abort the process."""
    import subprocess
    import sys

    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    proc = subprocess.run([sys.executable, "-c", _ISOLATED, str(path)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=120, stdin=subprocess.DEVNULL, check=False)
    assert proc.returncode == 0, (proc.returncode, proc.stderr[-2000:])
    import json

    return json.loads(proc.stdout.strip().splitlines()[-1])


def _laszip_data(data: bytes) -> int:
    """Offset of the laszip VLR's data in a LAZ file."""
    i = data.find(b"laszip encoded")
    assert i > 0
    return i - 2 + 54


@pytest.mark.parametrize("case", ["vlr_count", "evlr_count", "evlr_length", "chunk_size", "chunk_count",
                                  "chunk_entries"])
def test_las_layout_counts_are_checked_before_laspy_reads_them(tmp_path, case):
    laspy = pytest.importorskip("laspy")
    from laspy.vlrs.vlrlist import VLRList

    version = "1.4" if case.startswith("evlr") else "1.2"
    las = laspy.LasData(laspy.LasHeader(point_format=3, version=version))
    rng = np.random.default_rng(4)
    las.x, las.y, las.z = rng.uniform(0, 10, 2000), rng.uniform(0, 5, 2000), rng.uniform(0, 3, 2000)
    if version == "1.4":
        las.evlrs = VLRList([laspy.VLR("indoor", 1, "test", b"x" * 100)])
    p = tmp_path / ("s.las" if version == "1.4" else "s.laz")
    las.write(str(p))
    assert _read_isolated(p) == ["read", 2000]  # the control: the file is good before the patch
    data = bytearray(p.read_bytes())
    offset = struct.unpack_from("<I", data, 96)[0]
    if case == "vlr_count":
        struct.pack_into("<I", data, 100, 0xFFFFFFF0)
        words = ["4,294,967,280 variable-length records"]
    elif case == "evlr_count":
        struct.pack_into("<I", data, 243, 0xFFFFFFF0)
        words = ["4,294,967,280 extended variable-length records"]
    elif case == "evlr_length":
        struct.pack_into("<Q", data, struct.unpack_from("<Q", data, 235)[0] + 20, 1 << 40)
        words = ["extended variable-length record 1", "beyond the end"]
    elif case == "chunk_size":
        struct.pack_into("<I", data, _laszip_data(data) + 12, 0xFFFFFFF0)
        words = ["chunk size 4,294,967,280"]
    else:
        table = struct.unpack_from("<q", data, offset)[0]
        if case == "chunk_count":
            struct.pack_into("<I", data, table + 4, 0xFFFFFFF0)
            words = ["4,294,967,280 chunks"]
        else:  # the encoded entries: a chunk of an impossible number of bytes
            data[table + 8:] = b"\xff" * (len(data) - table - 8)
            words = ["chunk table"]
    p.write_bytes(bytes(data))
    kind, msg = _read_isolated(p)
    assert kind == "FormatError" and str(p) in msg, msg
    for w in words:
        assert w in msg, msg


# --------------------------------------------------------------------------- text: decimal commas
def _xyz_grid(n=40, seed=1):
    rng = np.random.default_rng(seed)
    return np.round(rng.uniform(-20, 20, (n, 3)), 4)


def _fmt(v):
    return f"{v:.4f}".replace(".", ",")


@pytest.mark.parametrize("sep", [";", "; ", "\t", " "])
def test_decimal_comma_text_reads_correctly(tmp_path, sep):
    xyz = _xyz_grid()
    p = tmp_path / "eu.txt"
    p.write_text("".join(sep.join(_fmt(v) for v in row) + "\n" for row in xyz))
    c = read_point_cloud(p)
    assert len(c) == len(xyz) and c.colors is None and c.fields == {}
    np.testing.assert_allclose(c.xyz, xyz, rtol=0, atol=1e-12)


def test_decimal_comma_the_reported_case(tmp_path):
    p = tmp_path / "eu.csv"
    rows = "".join(f"{i},5;-0,25;1E+01\n" for i in range(10))
    p.write_text("X;Y;Z\n" + "8,7751;0,1627;1,2500\n" * 5 + rows)
    c = read_point_cloud(p)
    assert len(c) == 15 and c.colors is None
    np.testing.assert_allclose(c.xyz[0], [8.7751, 0.1627, 1.25], rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.xyz[5:, 0], np.arange(10) + 0.5, rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.xyz[5:, 1:], [[-0.25, 10.0]] * 10, rtol=0, atol=1e-12)


def test_decimal_comma_with_colour_columns_and_count_line(tmp_path):
    xyz = _xyz_grid(30)
    rgb = np.random.default_rng(2).integers(0, 256, (30, 3))
    p = tmp_path / "eu.pts"
    p.write_text("30\n" + "".join(" ".join(_fmt(v) for v in xyz[i]) + " " + " ".join(map(str, rgb[i])) + "\n"
                                  for i in range(30)))
    c = read_point_cloud(p)
    np.testing.assert_allclose(c.xyz, xyz, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(c.colors, rgb)


def test_semicolon_integers_first_then_decimal_commas_in_a_later_chunk(tmp_path, monkeypatch):
    import engine.io.text as text

    lines = [f"{i};{i};{i}" for i in range(400)] + [f"{i},5;{i},25;1,75" for i in range(400)]
    p = tmp_path / "late.csv"
    p.write_text("\n".join(lines) + "\n")
    monkeypatch.setattr(text, "_CHUNK_BYTES", 2000)
    monkeypatch.setattr(text, "_SAMPLE_LINES", 50)  # the sample sees integers only
    c = read_point_cloud(p)
    np.testing.assert_allclose(c.xyz[400:, 0], np.arange(400) + 0.5, rtol=0, atol=1e-12)
    np.testing.assert_allclose(c.xyz[400:, 2], 1.75, rtol=0, atol=1e-12)


@pytest.mark.parametrize("body", [
    "1.5,2.5,3.5\n", "1.5, 2.5, 3.5\n", "1.5 , 2.5 , 3.5\n", "1,2,3\n", "1, 2, 3\n", "1.5 2.5 3.5\n",
    "1.5\t2.5\t3.5\n", "1.5;2.5;3.5\n", "1;2;3\n",
])
def test_ordinary_separators_keep_working(tmp_path, body):
    p = tmp_path / "ok.csv"
    p.write_text(body * 20)
    c = read_point_cloud(p)
    want = [1.5, 2.5, 3.5] if "." in body else [1.0, 2.0, 3.0]
    np.testing.assert_array_equal(c.xyz, [want] * 20)


@pytest.mark.parametrize("body, words", [
    ("1,5, 2,5, 3,5\n" * 20, ["cannot tell"]),                           # separator or decimal?
    ("1.234,5;2,5;3,5\n" * 20, ["both ',' and '.'"]),                    # a thousands separator?
    ("1,2,3;4;5\n" * 20, ["not one number"]),
    ("1,5 2,5 3,5\n" * 10 + "1,5,2 2 3\n" * 10, ["cannot tell"]),
    ("1,5;2,5;3,5\n" * 10 + "1.5;2.5;3.5\n" * 10, ["mixes"]),
])
def test_ambiguous_decimal_marks_are_refused(tmp_path, body, words):
    p = tmp_path / "amb.txt"
    p.write_text(body)
    _raises(FormatError, p, *words)


def test_mixed_decimal_marks_across_chunks_are_refused(tmp_path, monkeypatch):
    import engine.io.text as text

    lines = [f"{i},5;{i},25;1,75" for i in range(300)] + [f"{i}.5;{i}.25;1.75" for i in range(300)]
    p = tmp_path / "mixed.csv"
    p.write_text("\n".join(lines) + "\n")
    monkeypatch.setattr(text, "_CHUNK_BYTES", 2000)
    e, _ = _raises(FormatError, p, "decimal mark")
    assert "line 301" in str(e)  # the first line with a dot is named


# --------------------------------------------------------------------------- other corruptions
def _good_files(tmp_path):
    rng = np.random.default_rng(11)
    cloud = PointCloud(xyz=rng.uniform(0, 6, (300, 3)), colors=rng.integers(0, 255, (300, 3), dtype=np.uint8))
    out = {}
    for name, binary in (("b.ply", True), ("a.ply", False)):
        write_ply(tmp_path / name, cloud, binary=binary)
        out[name] = (tmp_path / name).read_bytes()
    out["p.pcd"] = _pcd("binary", cloud.xyz.astype("<f4").tobytes(), points=300)
    rows = ("\n".join(" ".join(f"{v:.4f}" for v in r) for r in cloud.xyz) + "\n").encode()
    out["q.pcd"] = _pcd("ascii", rows, points=300)
    out["t.xyz"] = rows
    return out


def test_random_corruptions_give_a_cloud_or_a_typed_error(tmp_path):
    """Truncations, flipped bytes and garbage in valid files: never an untyped exception."""
    rng = np.random.default_rng(12)
    outcomes = {"read": 0, "error": 0}
    for name, data in _good_files(tmp_path).items():
        for trial in range(40):
            d = bytearray(data)
            kind = trial % 4
            if kind == 0:
                d = d[: int(rng.integers(1, len(d)))]
            elif kind == 1:
                for i in rng.integers(0, len(d), 8):
                    d[i] = int(rng.integers(0, 256))
            elif kind == 2:
                i = int(rng.integers(0, min(len(d), 400)))  # the header region
                d[i:i + 8] = rng.integers(0, 256, 8, dtype=np.uint8).tobytes()
            else:
                d += rng.integers(0, 256, int(rng.integers(1, 500)), dtype=np.uint8).tobytes()
            p = tmp_path / f"x{trial}_{name}"
            p.write_bytes(bytes(d))
            try:
                read_point_cloud(p)
                outcomes["read"] += 1
            except IndoorError as e:
                assert str(p) in str(e), e
                outcomes["error"] += 1
    assert outcomes["read"] > 0 and outcomes["error"] > 0, outcomes


@pytest.mark.parametrize("name, data, words", [
    ("nul.ply", b"\0" * 4096, ["not a ply"]),
    ("nul.pcd", b"\0" * 4096, ["not a pcd"]),
    ("nul.xyz", b"\0" * 4096, ["nul bytes"]),
    ("nul.las", b"\0" * 4096, ["las"]),
    ("nul.e57", b"\0" * 4096, ["e57"]),
    ("utf16.xyz", "".join(f"{i}.0 {i}.5 1.0\n" for i in range(20)).encode("utf-16"), ["utf-16"]),
    ("utf16.csv", "1.0,2.0,3.0\n".encode("utf-16-be") * 20, ["nul bytes"]),
    ("two.xyz", b"1 2\n3 4\n" * 20, ["at least 3"]),
    ("long.xyz", b"x" * (2 << 20), ["longer than"]),
    ("garbage.ply", _ply(20, os.urandom(300), "ascii"), []),
    ("longline.pcd", b"VERSION " + b"7" * (1 << 17), ["not a pcd"]),
])
def test_other_corruptions_are_typed(tmp_path, name, data, words):
    p = _write(tmp_path, name, data)
    _raises(IndoorError, p, *words)


def test_unexpected_parse_exception_becomes_a_format_error(tmp_path, monkeypatch):
    import engine.io.ply as ply

    p = _write(tmp_path, "ok.ply", _ply(20, _bin(20)))

    def broken(*a, **k):
        raise struct.error("unpack requires a buffer of 8 bytes")

    monkeypatch.setattr(ply, "_comment_values", broken)
    e, _ = _raises(FormatError, p, "cannot parse this ply file", "struct.error", "unpack requires")
    assert isinstance(e.__cause__, struct.error)
    monkeypatch.setattr(ply, "_comment_values", lambda *a: (_ for _ in ()).throw(KeyError("bug")))
    with pytest.raises(KeyError):  # not a parsing exception: a bug stays a bug
        read_point_cloud(p)


# --------------------------------------------------------------------------- summary: strays
def _room(rng, n=40_000, size=(10.0, 8.0, 3.0), noise=0.005):
    """Points on the six faces of a box room (area-weighted), with Gaussian noise (m)."""
    sx, sy, sz = size
    areas = np.array([sx * sy, sx * sy, sx * sz, sx * sz, sy * sz, sy * sz])
    face = rng.choice(6, n, p=areas / areas.sum())
    u, v = rng.random(n), rng.random(n)
    pts = np.empty((n, 3))
    for f, (a, b, c) in enumerate([(0, 1, 2)] * 2 + [(0, 2, 1)] * 2 + [(1, 2, 0)] * 2):
        m = face == f
        pts[m, a] = u[m] * size[a]
        pts[m, b] = v[m] * size[b]
        pts[m, c] = 0.0 if f % 2 == 0 else size[c]
    return pts + rng.normal(0, noise, pts.shape)


def test_summary_core_bounds_ignore_far_strays(tmp_path):
    rng = np.random.default_rng(21)
    room = _room(rng)
    strays = np.array([[590.0, 4.0, 1.5], [589.5, 3.0, 1.0], [-575.0, 2.0, 2.0], [5.0, 585.0, 1.0],
                       [3.0, 3.0, 581.0], [590.5, 7.0, 0.5]])
    offset = np.array([651_200.0, 5_802_000.0, 0.0])
    s = PointCloud(xyz=np.vstack([room, strays]), offset=offset).summary()
    lo, hi = np.array(s["core_bounds_min"]) - offset, np.array(s["core_bounds_max"]) - offset
    # noise sigma 5 mm: every point lies within 3 cm of the box faces (6 sigma)
    np.testing.assert_allclose(lo, [0, 0, 0], atol=0.03)
    np.testing.assert_allclose(hi, [10, 8, 3], atol=0.03)
    assert s["bounds_max"][0] - offset[0] == pytest.approx(590.5)  # the existing keys are unchanged
    assert s["bounds_min"][0] - offset[0] == pytest.approx(-575.0)
    assert s["strays"] == 6
    far = max(np.linalg.norm(np.maximum(np.maximum(lo - q, q - hi), 0)) for q in strays)
    assert s["stray_max_distance_m"] == pytest.approx(far, abs=1e-9)
    assert 580.0 < s["stray_max_distance_m"] < 581.0
    for key in ("source", "points", "offset", "fields", "mean_spacing_m", "scans", "warnings"):
        assert key in s


def test_summary_clean_room_and_near_points_have_no_strays():
    rng = np.random.default_rng(22)
    room = _room(rng, n=20_000)
    s = PointCloud(xyz=room).summary()
    assert s["strays"] == 0 and s["stray_max_distance_m"] == 0.0
    np.testing.assert_array_equal(s["core_bounds_min"], s["bounds_min"])  # no gap: the full bounds
    np.testing.assert_array_equal(s["core_bounds_max"], s["bounds_max"])
    near = np.array([[13.0, 4.0, 1.5], [-3.5, 2.0, 1.0]])  # 3-3.5 m outside: beyond a window, not strays
    s = PointCloud(xyz=np.vstack([room, near])).summary()
    assert s["strays"] == 0
    assert s["core_bounds_max"][0] == pytest.approx(10.0, abs=0.03)  # a 3 m gap still ends the core


def test_summary_strays_on_a_big_cloud_use_a_sample(monkeypatch):
    import engine.pointcloud as pc

    rng = np.random.default_rng(23)
    room = _room(rng, n=30_000)
    xyz = np.vstack([room, [[600.0, 4.0, 1.5]] * 3])
    monkeypatch.setattr(pc, "_STRAY_BLOCK", 4096)  # blocks: same answer
    core = pc.core_bounds(xyz, sample=5000)
    count, far = pc._strays(xyz, core)
    assert count == 3 and 589.0 < far < 591.0
    np.testing.assert_allclose(core[1], [10, 8, 3], atol=0.03)

"""Point-cloud readers and the PLY writer: round trips for every format and attribute,
the two real PCL scans (LZF-compressed PCD), offsets, streaming and progress."""
import os
import struct

import numpy as np
import pytest

from engine.errors import Cancelled, FormatError
from engine.io import (SUPPORTED_EXTENSIONS, ReadParams, lzf_decompress, read_point_cloud,
                       units_warning, write_ply)
from engine.pointcloud import PointCloud


# --------------------------------------------------------------------------- helpers
def lzf_compress(data: bytes) -> bytes:
    """A small greedy LZF compressor (liblzf format) with back references, overlapping ones
    included, to test the decoder independently of PCL."""
    out = bytearray()
    lit = bytearray()
    table = {}
    i, n = 0, len(data)

    def flush():
        for s in range(0, len(lit), 32):
            part = lit[s:s + 32]
            out.append(len(part) - 1)
            out.extend(part)
        lit.clear()

    while i < n:
        ref = table.get(data[i:i + 3]) if i + 3 <= n else None
        if i + 3 <= n:
            table[data[i:i + 3]] = i
        if ref is not None and 0 < i - ref <= 8192:
            ln = 0
            while i + ln < n and ln < 264 and data[ref + ln] == data[i + ln]:
                ln += 1
            if ln >= 3:
                flush()
                off = i - ref - 1
                l2 = ln - 2
                if l2 < 7:
                    out.append((l2 << 5) | (off >> 8))
                else:
                    out.append((7 << 5) | (off >> 8))
                    out.append(l2 - 7)
                out.append(off & 0xFF)
                for k in range(i + 1, min(i + ln, n - 2)):
                    table[data[k:k + 3]] = k
                i += ln
                continue
        lit.append(data[i])
        i += 1
    flush()
    return bytes(out)


def make_cloud(n=2000, seed=0, offset=(0.0, 0.0, 0.0)):
    rng = np.random.default_rng(seed)
    return PointCloud(
        xyz=rng.uniform([-5, -4, -1.3], [5, 4, 1.6], (n, 3)),
        colors=rng.integers(0, 256, (n, 3), dtype=np.uint8),
        intensity=rng.random(n, dtype=np.float32) * 1000,
        normals=rng.normal(size=(n, 3)).astype(np.float32),
        scan_index=rng.integers(0, 3, n).astype(np.int32),
        scanner_positions=rng.normal(size=(3, 3)),
        offset=np.asarray(offset),
        fields={
            "label": rng.integers(0, 4, n).astype(np.int32),
            "distance": rng.normal(size=n),
            "uv": rng.random((n, 2)).astype(np.float32),
            "flag": rng.random(n) > 0.5,
        },
    )


def assert_same(a: PointCloud, b: PointCloud, exact=True):
    np.testing.assert_array_equal(a.xyz, b.xyz)
    for name in ("colors", "intensity", "normals", "scan_index", "scanner_positions"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    np.testing.assert_array_equal(a.offset, b.offset)
    assert sorted(a.fields) == sorted(b.fields)
    for k in a.fields:
        np.testing.assert_array_equal(np.asarray(a.fields[k]), np.asarray(b.fields[k]), err_msg=k)


# --------------------------------------------------------------------------- PLY
@pytest.mark.parametrize("binary", [True, False])
def test_write_ply_round_trip_every_attribute(tmp_path, binary):
    cloud = make_cloud(offset=(500_000.0, 4_200_000.0, 10.0))
    path = tmp_path / "c.ply"
    write_ply(path, cloud, binary=binary)
    back = read_point_cloud(path)
    assert back.source == str(path)
    assert_same(cloud, back)
    assert back.fields["flag"].dtype == np.uint8  # bool is stored as uchar
    assert back.fields["uv"].shape == (len(cloud), 2) and back.fields["uv"].dtype == np.float32
    assert back.dropped_nonfinite == 0
    assert not [p for p in os.listdir(tmp_path) if p != "c.ply"]  # no temporary left


def test_write_ply_float32_and_chunked_read_reports_progress(tmp_path):
    cloud = make_cloud(n=5000, seed=1)
    path = tmp_path / "f.ply"
    write_ply(path, cloud, dtype="f4")
    calls = []
    back = read_point_cloud(path, progress=lambda f, m: calls.append(f), params=ReadParams(chunk_points=1000))
    np.testing.assert_array_equal(back.xyz, cloud.xyz.astype(np.float32).astype(np.float64))
    assert len(calls) >= 5 and calls == sorted(calls) and calls[-1] == pytest.approx(1.0)
    np.testing.assert_array_equal(back.colors, cloud.colors)


def test_write_ply_is_atomic_on_error(tmp_path):
    path = tmp_path / "keep.ply"
    path.write_bytes(b"old")
    bad = PointCloud(xyz=np.zeros((20, 3)), fields={"s": np.array(["a"] * 20)})
    with pytest.raises(ValueError):
        write_ply(path, bad)
    assert path.read_bytes() == b"old" and os.listdir(tmp_path) == ["keep.ply"]


def test_read_ply_cancel(tmp_path):
    path = tmp_path / "c.ply"
    write_ply(path, make_cloud(n=3000))
    with pytest.raises(Cancelled):
        read_point_cloud(path, should_stop=lambda: True, params=ReadParams(chunk_points=500))


ASCII_PLY = """ply
format ascii 1.0
comment hand written
element vertex 12
property float x
property float y
property float z
property uchar red
property uchar green
property uchar blue
property float scalar_intensity
property float quality
element face 1
property list uchar int vertex_indices
end_header
{rows}3 0 1 2
"""


def test_hand_written_ascii_ply(tmp_path):
    rows = "".join(f"{k * 0.5} {-k} {k * 0.25 + 1} {k * 10} {255 - k} 7 {k * 1.5} {k % 3}\n"
                   for k in range(12))
    path = tmp_path / "a.ply"
    path.write_text(ASCII_PLY.format(rows=rows))
    c = read_point_cloud(path)
    k = np.arange(12)
    np.testing.assert_allclose(c.xyz, np.stack([k * 0.5, -k, k * 0.25 + 1], axis=1))
    np.testing.assert_array_equal(c.colors, np.stack([k * 10, 255 - k, np.full(12, 7)], axis=1))
    np.testing.assert_allclose(c.intensity, k * 1.5)
    np.testing.assert_array_equal(c.fields["quality"], k % 3)
    assert c.normals is None and c.scan_index is None


def test_hand_written_big_endian_ply_double_with_16bit_colour(tmp_path):
    n = 15
    rng = np.random.default_rng(3)
    xyz = rng.uniform(-3, 3, (n, 3))
    rgb16 = rng.integers(0, 65536, (n, 3)).astype(">u2")
    nrm = rng.normal(size=(n, 3)).astype(">f4")
    header = ("ply\nformat binary_big_endian 1.0\nelement vertex %d\n"
              "property double x\nproperty double y\nproperty double z\n"
              "property ushort red\nproperty ushort green\nproperty ushort blue\n"
              "property float nx\nproperty float ny\nproperty float nz\nproperty int label\nend_header\n" % n)
    body = b"".join(struct.pack(">3d3H3fi", *xyz[i], *rgb16[i], *nrm[i], i) for i in range(n))
    path = tmp_path / "be.ply"
    path.write_bytes(header.encode() + body)
    c = read_point_cloud(path)
    np.testing.assert_array_equal(c.xyz, xyz)
    np.testing.assert_array_equal(c.colors, np.round(rgb16.astype(float) / 257).astype(np.uint8))
    np.testing.assert_array_equal(c.normals, nrm.astype(np.float32))
    np.testing.assert_array_equal(c.fields["label"], np.arange(n))


# --------------------------------------------------------------------------- PCD
def test_real_pcl_scans_read_exactly(data_dir):

    expected = {"room_scan1.pcd": 112_586, "room_scan2.pcd": 112_624}
    for name, n in expected.items():
        c = read_point_cloud(os.path.join(data_dir, name))
        assert len(c) == n and c.dropped_nonfinite == 0
        z = c.xyz[:, 2]
        hist, edges = np.histogram(z, bins=np.arange(-2.0, 2.01, 0.05))
        dense = edges[:-1][hist > 0.02 * n]               # 5 cm layers with > 2 % of the points
        floor, ceiling = dense.min() + 0.025, dense.max() + 0.025
        assert -1.40 < floor < -1.25, (name, floor)       # floor near z = -1.35
        assert 1.60 < ceiling < 1.75, (name, ceiling)     # ceiling near z = +1.65
        assert edges[np.argmax(hist)] == pytest.approx(1.65)  # the ceiling is the densest layer
        assert np.percentile(z, 0.5) > -1.45 and np.percentile(z, 99.5) < 1.75
        np.testing.assert_array_equal(c.scanner_positions, [[0.0, 0.0, 0.0]])
        assert np.all(np.abs(c.xyz) < 20.0)


def test_lzf_decoder_handles_back_references_of_the_real_file(data_dir):
    """The real file's stream has many back references: decoding must give exactly the
    declared size and sane coordinates."""

    raw = open(os.path.join(data_dir, "room_scan1.pcd"), "rb").read()
    start = raw.index(b"DATA binary_compressed\n") + len(b"DATA binary_compressed\n")
    csize, usize = struct.unpack("<II", raw[start:start + 8])
    comp = raw[start + 8:start + 8 + csize]
    # count the back references by walking the control bytes
    ip, refs = 0, 0
    while ip < len(comp):
        c = comp[ip]
        if c < 32:
            ip += c + 2
        else:
            refs += 1
            ip += 3 if (c >> 5) == 7 else 2
    assert refs > 1000 and csize < usize
    out = lzf_decompress(comp, usize)
    assert len(out) == usize == 112_586 * 12
    x = np.frombuffer(out, "<f4", count=112_586)
    assert np.isfinite(x).all() and np.abs(x).max() < 20


def test_lzf_round_trip_with_overlapping_references(rng):
    data = (b"abcabcabcabc" * 50 + bytes(300) + rng.integers(0, 4, 5000, dtype=np.uint8).tobytes()
            + b"\x07" * 1000)
    comp = lzf_compress(data)
    assert len(comp) < len(data) // 2
    assert lzf_decompress(comp, len(data)) == data
    with pytest.raises(ValueError):
        lzf_decompress(comp, len(data) + 5)  # underrun detected
    with pytest.raises(ValueError):
        lzf_decompress(bytes([0x20, 0x05]), 10)  # reference before the start


def pcd_bytes(cloud: PointCloud, data: str, viewpoint=(0, 0, 0)) -> bytes:
    n = len(cloud)
    rgb = ((cloud.colors[:, 0].astype(np.uint32) << 16) | (cloud.colors[:, 1].astype(np.uint32) << 8)
           | cloud.colors[:, 2].astype(np.uint32)).view(np.float32)
    cols = [("x", "F", 4, cloud.xyz[:, 0].astype(np.float32)),
            ("y", "F", 4, cloud.xyz[:, 1].astype(np.float32)),
            ("z", "F", 4, cloud.xyz[:, 2].astype(np.float32)), ("rgb", "F", 4, rgb),
            ("intensity", "F", 4, cloud.intensity.astype(np.float32)),
            ("normal_x", "F", 4, cloud.normals[:, 0]), ("normal_y", "F", 4, cloud.normals[:, 1]),
            ("normal_z", "F", 4, cloud.normals[:, 2]),
            ("label", "I", 4, cloud.fields["label"].astype(np.int32))]
    head = ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
            f"FIELDS {' '.join(c[0] for c in cols)}\nSIZE {' '.join(str(c[2]) for c in cols)}\n"
            f"TYPE {' '.join(c[1] for c in cols)}\nCOUNT {' '.join('1' for _ in cols)}\n"
            f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT {viewpoint[0]} {viewpoint[1]} {viewpoint[2]} 1 0 0 0\n"
            f"POINTS {n}\nDATA {data}\n").encode()
    if data == "ascii":
        lines = []
        for i in range(n):
            vals = []
            for name, t, _, v in cols:
                vals.append(repr(int(v[i])) if t == "I" else
                            ("%.9g" % v[i] if name != "rgb" else "%.9g" % v[i]))
            lines.append(" ".join(vals))
        return head + ("\n".join(lines) + "\n").encode()
    if data == "binary":
        rec = np.empty(n, [(c[0], "<f4" if c[1] == "F" else "<i4") for c in cols])
        for c in cols:
            rec[c[0]] = c[3]
        return head + rec.tobytes()
    raw = b"".join(np.ascontiguousarray(c[3]).astype("<f4" if c[1] == "F" else "<i4").tobytes() for c in cols)
    comp = lzf_compress(raw)
    return head + struct.pack("<II", len(comp), len(raw)) + comp


@pytest.mark.parametrize("data", ["ascii", "binary", "binary_compressed"])
def test_pcd_round_trip(tmp_path, data):
    cloud = make_cloud(n=400, seed=5)
    cloud = cloud.with_(colors=np.where(cloud.colors == 0, 1, cloud.colors))  # avoid 0-bit float NaN
    path = tmp_path / f"c_{data}.pcd"
    path.write_bytes(pcd_bytes(cloud, data, viewpoint=(1.5, -2.0, 0.5)))
    c = read_point_cloud(path)
    assert len(c) == 400
    np.testing.assert_array_equal(c.xyz, cloud.xyz.astype(np.float32).astype(np.float64))
    np.testing.assert_array_equal(c.colors, cloud.colors)
    np.testing.assert_array_equal(c.intensity, cloud.intensity.astype(np.float32))
    np.testing.assert_array_equal(c.normals, cloud.normals)
    np.testing.assert_array_equal(c.fields["label"], cloud.fields["label"])
    np.testing.assert_array_equal(c.scanner_positions, [[1.5, -2.0, 0.5]])


def test_pcd_organised_cloud_nan_holes_are_dropped_and_counted(tmp_path):
    cloud = make_cloud(n=300, seed=6)
    xyz = cloud.xyz.copy()
    xyz[::10] = np.nan
    cloud = cloud.with_(xyz=xyz, colors=np.full((300, 3), 9, np.uint8))
    path = tmp_path / "holes.pcd"
    path.write_bytes(pcd_bytes(cloud, "binary_compressed"))
    c = read_point_cloud(path)
    assert len(c) == 270 and c.dropped_nonfinite == 30
    np.testing.assert_array_equal(c.fields["label"], cloud.fields["label"][np.isfinite(xyz[:, 0])])


# --------------------------------------------------------------------------- text
def test_xyz_three_columns(tmp_path):
    rng = np.random.default_rng(7)
    xyz = rng.uniform(-10, 10, (50, 3))
    path = tmp_path / "p.xyz"
    np.savetxt(path, xyz, fmt="%.6f")
    c = read_point_cloud(path)
    np.testing.assert_allclose(c.xyz, xyz, atol=5e-7)
    assert c.colors is None and c.intensity is None


def test_pts_count_line_intensity_and_rgb(tmp_path):
    rng = np.random.default_rng(8)
    xyz = rng.uniform(-10, 10, (40, 3))
    inten = rng.integers(-2048, 2048, 40)
    rgb = rng.integers(0, 256, (40, 3))
    path = tmp_path / "p.pts"
    with open(path, "w") as f:
        f.write("40\n")
        for i in range(40):
            f.write("%.5f %.5f %.5f %d %d %d %d\n" % (*xyz[i], inten[i], *rgb[i]))
    c = read_point_cloud(path)
    np.testing.assert_allclose(c.xyz, xyz, atol=6e-6)
    np.testing.assert_array_equal(c.intensity, inten)
    np.testing.assert_array_equal(c.colors, rgb)


def test_csv_with_named_header_columns(tmp_path):
    rng = np.random.default_rng(9)
    xyz = rng.uniform(0, 5, (30, 3))
    nrm = rng.normal(size=(30, 3))
    path = tmp_path / "p.csv"
    with open(path, "w") as f:
        f.write("//X,Y,Z,Nx,Ny,Nz,Classification,Intensity\n")
        for i in range(30):
            f.write("%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%d,%d\n" % (*xyz[i], *nrm[i], i % 5, i * 3))
    c = read_point_cloud(path)
    np.testing.assert_allclose(c.xyz, xyz, atol=6e-7)
    np.testing.assert_allclose(c.normals, nrm, atol=1e-6)
    np.testing.assert_array_equal(c.intensity, np.arange(30) * 3)
    np.testing.assert_array_equal(c.fields["classification"], np.arange(30) % 5)


def test_txt_six_columns_rgb_semicolons_and_header(tmp_path):
    path = tmp_path / "p.txt"
    rows = ["%d;%d;%d;%d;%d;%d" % (i, 2 * i, 3 * i, i * 20, 100, 255 - i) for i in range(12)]
    path.write_text("exported by some scanner\n" + "\n".join(rows) + "\n")
    c = read_point_cloud(path)
    np.testing.assert_array_equal(c.xyz[:, 2], 3 * np.arange(12))
    np.testing.assert_array_equal(c.colors[:, 0], np.arange(12) * 20)
    np.testing.assert_array_equal(c.colors[:, 2], 255 - np.arange(12))


def test_text_read_in_chunks_gives_same_result(tmp_path, monkeypatch):
    import engine.io.text as text

    rng = np.random.default_rng(10)
    xyz = rng.uniform(-1, 1, (3000, 4))
    path = tmp_path / "p.xyz"
    np.savetxt(path, xyz, fmt="%.6f")
    whole = read_point_cloud(path)
    monkeypatch.setattr(text, "_CHUNK_BYTES", 1000)
    calls = []
    chunked = read_point_cloud(path, progress=lambda f, m: calls.append(f))
    np.testing.assert_array_equal(whole.xyz, chunked.xyz)
    np.testing.assert_array_equal(whole.intensity, chunked.intensity)
    assert len(calls) > 50


# --------------------------------------------------------------------------- LAS / LAZ
@pytest.mark.parametrize("ext", ["las", "laz"])
def test_las_scales_offsets_and_16bit_colour(tmp_path, ext):
    laspy = pytest.importorskip("laspy")
    rng = np.random.default_rng(11)
    n = 3000
    hdr = laspy.LasHeader(point_format=3, version="1.2")
    hdr.scales = np.array([0.001, 0.001, 0.001])
    hdr.offsets = np.array([512_000.0, 5_403_000.0, 100.0])
    las = laspy.LasData(hdr)
    xyz = rng.uniform([512_010, 5_403_020, 100], [512_030, 5_403_035, 103], (n, 3))
    xyz = np.round(xyz, 3)
    las.x, las.y, las.z = xyz[:, 0], xyz[:, 1], xyz[:, 2]
    rgb16 = rng.integers(0, 65536, (n, 3))
    las.red, las.green, las.blue = rgb16[:, 0], rgb16[:, 1], rgb16[:, 2]
    las.intensity = rng.integers(0, 65536, n)
    las.classification = rng.integers(0, 10, n)
    path = tmp_path / f"s.{ext}"
    las.write(str(path))
    c = read_point_cloud(path)
    assert len(c) == n
    # georeferenced: offset removed, rounded, recorded; millimetres preserved in float32
    np.testing.assert_array_equal(c.offset, [512_000.0, 5_403_000.0, 0.0])  # z < 1e4 m kept
    np.testing.assert_allclose(c.xyz + c.offset, xyz, atol=1e-6)
    np.testing.assert_allclose(c.xyz.astype(np.float32) + c.offset, xyz, atol=1e-5)
    np.testing.assert_array_equal(c.colors, np.round(rgb16 / 257.0).astype(np.uint8))
    np.testing.assert_array_equal(c.intensity, np.asarray(las.intensity))
    np.testing.assert_array_equal(c.fields["classification"], np.asarray(las.classification))
    assert units_warning(c) is None


def test_las_chunked_progress(tmp_path):
    laspy = pytest.importorskip("laspy")
    las = laspy.LasData(laspy.LasHeader(point_format=0, version="1.2"))
    n = 2500
    las.x = np.linspace(0, 10, n)
    las.y = np.linspace(0, 5, n)
    las.z = np.zeros(n)
    path = tmp_path / "p.las"
    las.write(str(path))
    calls = []
    c = read_point_cloud(path, progress=lambda f, m: calls.append(f), params=ReadParams(chunk_points=500))
    assert len(c) == n and c.colors is None and len(calls) == 5


# --------------------------------------------------------------------------- E57
def _quat_z(angle):
    return np.array([np.cos(angle / 2), 0.0, 0.0, np.sin(angle / 2)])


def test_e57_two_scans_with_poses(tmp_path):
    pye57 = pytest.importorskip("pye57")
    rng = np.random.default_rng(12)
    path = str(tmp_path / "two.e57")
    poses = [(0.0, np.array([0.0, 0.0, 1.5])), (np.pi / 2, np.array([4.0, 2.0, 1.6]))]
    local, colours, inten = [], [], []
    e = pye57.E57(path, mode="w")
    for k, (ang, t) in enumerate(poses):
        n = 500 + 100 * k
        p = rng.uniform(-3, 3, (n, 3))
        col = rng.integers(0, 256, (n, 3)).astype(np.uint8)
        it = rng.random(n).astype(np.float32)
        e.write_scan_raw({"cartesianX": p[:, 0], "cartesianY": p[:, 1], "cartesianZ": p[:, 2],
                          "intensity": it, "colorRed": col[:, 0], "colorGreen": col[:, 1],
                          "colorBlue": col[:, 2]}, rotation=_quat_z(ang), translation=t)
        local.append(p.astype(np.float32).astype(np.float64))  # pye57 stores single precision
        colours.append(col)
        inten.append(it)
    e.close()
    c = read_point_cloud(path)
    assert len(c) == 1100 and c.scan_count == 2
    np.testing.assert_array_equal(np.bincount(c.scan_index), [500, 600])
    np.testing.assert_allclose(c.scanner_positions, [poses[0][1], poses[1][1]], atol=1e-12)
    rot90 = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])
    expected = np.concatenate([local[0] + poses[0][1], local[1] @ rot90.T + poses[1][1]])
    np.testing.assert_allclose(c.xyz, expected, atol=1e-9)
    np.testing.assert_array_equal(c.colors, np.concatenate(colours))
    np.testing.assert_allclose(c.intensity, np.concatenate(inten), rtol=1e-6)


def test_supported_extensions():
    assert set(SUPPORTED_EXTENSIONS) == {".ply", ".pcd", ".xyz", ".pts", ".txt", ".csv", ".las", ".laz",
                                         ".e57"}


def test_pcd_count_field_padding_and_uint_rgb(tmp_path):
    n = 25
    rng = np.random.default_rng(13)
    xyz = rng.uniform(-2, 2, (n, 3)).astype("<f4")
    hist = rng.random((n, 4)).astype("<f4")
    rgb = rng.integers(0, 1 << 24, n).astype("<u4")
    rec = np.empty(n, [("xyz", "<f4", (3,)), ("_", "u1", (4,)), ("rgb", "<u4"), ("h", "<f4", (4,))])
    rec["xyz"], rec["_"], rec["rgb"], rec["h"] = xyz, 0, rgb, hist
    head = ("VERSION 0.7\nFIELDS x y z _ rgb h\nSIZE 4 4 4 1 4 4\nTYPE F F F U U F\nCOUNT 1 1 1 4 1 4\n"
            f"WIDTH {n}\nHEIGHT 1\nPOINTS {n}\nDATA binary\n")
    p = tmp_path / "c.pcd"
    p.write_bytes(head.encode() + rec.tobytes())
    c = read_point_cloud(p)
    np.testing.assert_array_equal(c.xyz, xyz.astype(np.float64))
    np.testing.assert_array_equal(c.colors, np.stack([(rgb >> 16) & 255, (rgb >> 8) & 255, rgb & 255], 1))
    np.testing.assert_array_equal(c.fields["h"], hist)
    assert sorted(c.fields) == ["h"]


def test_las_with_8bit_values_in_16bit_colour_is_kept(tmp_path):
    laspy = pytest.importorskip("laspy")
    las = laspy.LasData(laspy.LasHeader(point_format=2, version="1.2"))
    n = 50
    las.x, las.y, las.z = np.arange(n) * 0.1, np.zeros(n), np.zeros(n)
    las.red = np.arange(n) * 5
    las.green = np.full(n, 255)
    las.blue = np.zeros(n)
    path = tmp_path / "c8.las"
    las.write(str(path))
    c = read_point_cloud(path)
    np.testing.assert_array_equal(c.colors[:, 0], np.arange(n) * 5)
    np.testing.assert_array_equal(c.colors[:, 1], 255)


def test_ascii_ply_streamed_in_chunks_with_faces_after(tmp_path, monkeypatch):
    import engine.io.ply as ply

    cloud = make_cloud(n=700, seed=14)
    path = tmp_path / "a.ply"
    write_ply(path, cloud, binary=False)
    text = path.read_text().replace("end_header\n", "element face 2\nproperty list uchar int vertex_indices\n"
                                    "end_header\n")
    path.write_text(text + "3 0 1 2\n4 0 1 2 3\n")
    monkeypatch.setattr(ply, "_ASCII_CHUNK_BYTES", 4096)
    calls = []
    back = read_point_cloud(path, progress=lambda f, m: calls.append(f))
    assert_same(cloud, back)
    assert len(calls) > 10


def test_e57_streamed_in_chunks_with_invalid_points_and_no_pose(tmp_path):
    pye57 = pytest.importorskip("pye57")
    rng = np.random.default_rng(15)
    n = 1200
    p = rng.uniform(-3, 3, (n, 3)).astype(np.float32).astype(np.float64)
    bad = np.zeros(n, np.int8)
    bad[::7] = 2
    path = str(tmp_path / "one.e57")
    e = pye57.E57(path, mode="w")
    e.write_scan_raw({"cartesianX": p[:, 0], "cartesianY": p[:, 1], "cartesianZ": p[:, 2],
                      "cartesianInvalidState": bad})
    e.close()
    calls = []
    c = read_point_cloud(path, progress=lambda f, m: calls.append(f), params=ReadParams(chunk_points=100))
    assert len(c) == n - len(bad[::7]) and c.colors is None and c.intensity is None
    np.testing.assert_allclose(c.xyz, p[bad == 0], atol=1e-12)
    np.testing.assert_array_equal(c.scanner_positions, [[0.0, 0.0, 0.0]])
    assert len(calls) >= 12
    with pytest.raises(Cancelled):
        read_point_cloud(path, should_stop=lambda: True, params=ReadParams(chunk_points=100))


def test_pts_with_two_scan_blocks(tmp_path, monkeypatch):
    import engine.io.text as text

    rng = np.random.default_rng(16)
    a, b = rng.uniform(-5, 5, (300, 3)), rng.uniform(-5, 5, (200, 3))
    path = tmp_path / "two.pts"
    with open(path, "w") as f:
        for block in (a, b):
            f.write(f"{len(block)}\n")
            f.writelines("%.6f %.6f %.6f -100 10 20 30\n" % tuple(r) for r in block)
    monkeypatch.setattr(text, "_CHUNK_BYTES", 2000)  # count lines fall inside chunks
    c = read_point_cloud(path)
    np.testing.assert_allclose(c.xyz, np.concatenate([a, b]), atol=6e-7)
    np.testing.assert_array_equal(np.bincount(c.scan_index), [300, 200])
    np.testing.assert_array_equal(c.intensity, -100)
    path.write_text(path.read_text().replace("\n200\n", "\n250\n"))
    with pytest.raises(FormatError) as info:
        read_point_cloud(path)
    assert "block 2" in str(info.value) and "250" in str(info.value) and "200" in str(info.value)


def test_bench_discovers_bench_io_and_writes_json(tmp_path, monkeypatch):
    import json

    import bench.__main__ as runner
    import bench.bench_io as bench_io

    assert runner.discover()["io"] == "bench.bench_io"
    monkeypatch.setattr(bench_io, "QUICK_SIZES", (20_000,))
    assert runner.main(["--out", str(tmp_path), "--only", "io", "--quick"]) == 0
    payload = json.loads((tmp_path / "io.json").read_text())
    assert payload["status"] == "ok" and payload["quick"] is True
    read = payload["results"]["read"]
    assert set(read) == {"ply_f8_20000", "ply_f4_20000", "las_20000", "laz_20000"}
    assert all(r["points"] == 20_000 and r["points_per_s"] > 0 for r in read.values())
    mem = payload["results"]["memory"]["ply_f8_20000"]
    assert mem["peak_rss_mb"] >= mem["baseline_rss_mb"] > 0
    with pytest.raises(SystemExit):
        runner.main(["--out", str(tmp_path), "--only", "nosuch"])


def test_text_with_byte_order_mark_and_crlf(tmp_path):
    path = tmp_path / "bom.txt"
    path.write_bytes(("\ufeff" + "".join(f"{i} {i * 2} {i * 3}\r\n" for i in range(15))).encode("utf-8"))
    c = read_point_cloud(path)
    assert len(c) == 15
    np.testing.assert_array_equal(c.xyz[:, 1], 2 * np.arange(15))

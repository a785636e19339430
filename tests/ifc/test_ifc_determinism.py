"""Reproducible IFC output (GlobalIds from seed, name and identity; SOURCE_DATE_EPOCH; the real
file name in the header; names with undecodable bytes), write failures that leave nothing
behind, and truncated or wrong-shaped model files (IFC, JSON) that give a FormatError."""
import errno
import json
import os
import re
import subprocess
import sys
import textwrap

import numpy as np
import pytest

pytest.importorskip("ifcopenshell")
import ifcopenshell.guid  # noqa: E402
import ifcopenshell.util.element  # noqa: E402

from engine import BuildingModel, FormatError, InputError, Provenance  # noqa: E402
from engine.errors import OutputError  # noqa: E402
from engine.evaluation import load_model  # noqa: E402
from engine.fileutil import atomic_path  # noqa: E402
from engine.ifc import build_ifc, read_ifc, write_ifc  # noqa: E402
from engine.ifc.common import global_id  # noqa: E402
from scenes import ROOT  # noqa: E402
from scenes.ifc import small_model  # noqa: E402

TESTS = os.path.join(ROOT, "tests")  # on the path of the subprocesses, for scenes.ifc
EPOCH = 1_600_000_000  # SOURCE_DATE_EPOCH of the reproducible writes (2020-09-13)


def _mask_time_stamp(text: str) -> str:
    return re.sub(r"(FILE_NAME\('[^']*',)'[^']*'", r"\1'T'", text)


def _roots(path):
    f = ifcopenshell.open(str(path))
    return f, f.by_type("IfcRoot")


# --------------------------------------------------------------------------- 1. GlobalIds
_SUBPROCESS_WRITE = textwrap.dedent("""
    import sys
    sys.path[:0] = [{root!r}, {tests!r}]
    import ifcopenshell
    noise = ifcopenshell.file()  # shifts ifcopenshell's instance counter (entity hashes)
    for i in range({n}):
        noise.createIfcWall(ifcopenshell.guid.new())
    from scenes.ifc import small_model
    from engine.ifc import write_ifc
    write_ifc(small_model(), sys.argv[1])
""")


def test_two_processes_write_byte_identical_files(tmp_path):
    """Different hash seeds and different earlier ifcopenshell work (entity hashes order the
    sets ifcopenshell.api iterates) must not change a byte when SOURCE_DATE_EPOCH is set."""
    env = dict(os.environ, SOURCE_DATE_EPOCH=str(EPOCH))
    data = []
    for k, (hash_seed, n) in enumerate((("1", 0), ("2", 777))):
        (tmp_path / str(k)).mkdir()
        out = tmp_path / str(k) / "run.ifc"
        proc = subprocess.run([sys.executable, "-c", _SUBPROCESS_WRITE.format(root=ROOT, tests=TESTS, n=n),
                               str(out)], env=dict(env, PYTHONHASHSEED=hash_seed), cwd=str(tmp_path),
                              stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=300)
        assert proc.returncode == 0, proc.stderr[-3000:]
        data.append(out.read_bytes())
    assert data[0] == data[1]
    assert b"FILE_NAME('run.ifc','2020-09-13T12:26:40+00:00'" in data[0]


def test_same_seed_same_global_ids_in_process_and_time_stamp_only_differs(tmp_path, monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    a = write_ifc(small_model(), tmp_path / "a" / "m.ifc")
    b = write_ifc(small_model(), tmp_path / "b" / "m.ifc")
    ta, tb = (open(p).read() for p in (a, b))
    assert _mask_time_stamp(ta) == _mask_time_stamp(tb)
    fa, roots = _roots(a)
    gids = [e.GlobalId for e in roots]
    assert len(gids) == len(set(gids)) and len(gids) > 50
    assert all(ifcopenshell.guid.expand(g) for g in gids)  # valid compressed GUIDs


def test_run_times_in_the_trace_do_not_change_the_file(tmp_path, monkeypatch):
    """The rjMCMC trace records its seconds; two runs of one scan and seed differ only there,
    and their IFC must not (the timings stay in the JSON report)."""
    monkeypatch.setenv("SOURCE_DATE_EPOCH", str(EPOCH))
    m = small_model()
    texts = []
    for k, sec in enumerate((0.129, 0.132)):
        pv = m.provenance
        trace = {"accepted": {"add": 3}, "seconds": sec, "chains": [{"seconds": sec, "moves": 9}],
                 "timings": {"cells": sec}}
        mk = m.with_(provenance=Provenance(pv.method, pv.parameters, pv.seed, pv.timings, trace, pv.source,
                                           pv.software))
        texts.append(open(write_ifc(mk, tmp_path / str(k) / "m.ifc")).read())
    assert texts[0] == texts[1]
    assert '"moves":9' in texts[0] and '"add":3' in texts[0]  # the rest of the trace is kept


def test_every_root_entity_gets_its_key_derived_id(tmp_path):
    """GlobalIds are name-based on (seed, model name, identity): a wall, its door's opening, a
    pset and a relationship have the ids their keys give; every IfcRoot entity has one."""
    m = small_model(seed=11, name="keys")
    f = build_ifc(m)
    ue = ifcopenshell.util.element
    by_shape = {ue.get_psets(e)["Indoor_Shape"]["ShapeId"]: e for e in f.by_type("IfcProduct")
                if "Indoor_Shape" in ue.get_psets(e)}
    wall, door = by_shape["w1"], by_shape["d1"]
    assert wall.GlobalId == global_id(11, "keys", ("shape", "w1"))
    opening = door.FillsVoids[0].RelatingOpeningElement
    assert opening.GlobalId == global_id(11, "keys", ("opening", "d1"))
    assert door.FillsVoids[0].GlobalId == global_id(11, "keys", (("opening", "d1"), "fills"))
    pset = next(r.RelatingPropertyDefinition for r in wall.IsDefinedBy
                if r.RelatingPropertyDefinition.Name == "Indoor_Shape")
    assert pset.GlobalId == global_id(11, "keys", (("shape", "w1"), "pset", "Indoor_Shape"))
    project = f.by_type("IfcProject")[0]
    assert project.GlobalId == global_id(11, "keys", ("project",))
    gids = [e.GlobalId for e in f.by_type("IfcRoot")]
    assert len(gids) == len(set(gids))
    # the two sides of the wall between r1 and r2 are two boundaries with their own ids
    sides = [b for b in f.by_type("IfcRelSpaceBoundary") if b.RelatedBuildingElement == wall
             and b.CorrespondingBoundary is not None]
    assert len(sides) == 2 and sides[0].GlobalId != sides[1].GlobalId


def test_other_seed_or_name_gives_other_ids_and_a_shape_keeps_its_id_when_others_change(tmp_path):
    def ids(m):
        return {e.GlobalId for e in build_ifc(m).by_type("IfcRoot")}

    def wall_id(m):
        f = build_ifc(m)
        return next(e.GlobalId for e in f.by_type("IfcWall") if e.Name == "Wall 1")

    base = ids(small_model())
    assert not base & ids(small_model(seed=4))
    assert not base & ids(small_model(name="other"))
    assert not base & ids(small_model().with_(provenance=Provenance("test")))  # no seed
    # an element's id does not depend on the rest of the model (shape order, other shapes)
    assert wall_id(small_model()) == wall_id(small_model(with_corridor=False))
    m = small_model()
    assert wall_id(m) == wall_id(m.with_(shapes=tuple(reversed(m.shapes))))


def test_source_date_epoch_fixes_owner_history_dates(tmp_path, monkeypatch):
    """An application that configures owners (Bonsai does) makes ifcopenshell.api give every
    entity an IfcOwnerHistory stamped with the clock: SOURCE_DATE_EPOCH fixes those dates too."""
    import ifcopenshell.api.owner.settings as settings

    def user(f):
        return next(iter(f.by_type("IfcPersonAndOrganization")), None) or f.createIfcPersonAndOrganization(
            f.createIfcPerson(None, "Doe"), f.createIfcOrganization(None, "Org"))

    def app(f):
        return next(iter(f.by_type("IfcApplication")), None) or f.createIfcApplication(
            user(f).TheOrganization, "1", "Test app", "test")

    monkeypatch.setattr(settings, "get_user", user)
    monkeypatch.setattr(settings, "get_application", app)
    monkeypatch.setenv("SOURCE_DATE_EPOCH", str(EPOCH))
    f = build_ifc(small_model())
    histories = f.by_type("IfcOwnerHistory")
    assert histories
    assert {h.CreationDate for h in histories} == {EPOCH}
    assert {h.LastModifiedDate for h in histories} <= {EPOCH, None}
    assert all(e.OwnerHistory is not None for e in f.by_type("IfcRoot"))
    assert f.header.file_name.time_stamp == "2020-09-13T12:26:40+00:00"


def test_malformed_source_date_epoch_is_ignored_with_a_warning(monkeypatch, caplog):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "yesterday")
    f = build_ifc(small_model())
    assert "SOURCE_DATE_EPOCH" in caplog.text
    assert f.header.file_name.time_stamp[:2] == "20"  # the clock


# --------------------------------------------------------------------------- 2. and 3. names
def test_header_names_the_real_file(tmp_path):
    path = write_ifc(small_model(), tmp_path / "sub" / "My model.ifc")
    f = ifcopenshell.open(path)
    assert f.header.file_name.name == "My model.ifc"
    assert "/dev/null" not in open(path).read(2000)


def test_undecodable_file_name_is_escaped_and_written_at_the_requested_path(tmp_path):
    stem = b"caf\xff scan".decode("utf-8", "surrogateescape")  # what Python gives on Linux
    m = small_model(name=stem)
    m = m.replace_shapes(m["r1"].with_(name=stem), m["w1"].with_(log=(f"from {stem}.ply",)))
    m = m.with_(provenance=Provenance("test", {}, 3, source=f"/scans/{stem}.ply"))
    path = os.path.join(str(tmp_path), stem + ".ifc")
    assert write_ifc(m, path) == path
    assert os.listdir(os.fsencode(str(tmp_path))) == [b"caf\xff scan.ifc"]
    back = read_ifc(path)  # the reader opens names with undecodable bytes too
    assert back.name == "caf\\xff scan"
    assert back["r1"].name == "caf\\xff scan"
    with open(path, "rb") as fh:
        head = fh.read(600).decode("ascii")
    assert "FILE_NAME('caf\\\\xff scan.ifc'" in head  # a backslash is doubled in STEP strings


# --------------------------------------------------------------------------- 4. failed writes
_SUBPROCESS_FULL = textwrap.dedent("""
    import json, os, resource, signal, sys
    sys.path[:0] = [{root!r}, {tests!r}]
    from scenes.ifc import small_model
    from engine.ifc import build_ifc, write_ifc
    from engine.fileutil import atomic_path
    from engine.errors import OutputError
    out = {{}}
    folder = sys.argv[1]
    m = small_model()
    f = build_ifc(m)
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (8000, resource.RLIM_INFINITY))
    try:
        write_ifc(m, os.path.join(folder, "model.ifc"))
    except OutputError as e:
        out["write_ifc"] = [type(e).__name__, str(e)]
    out["after_write_ifc"] = sorted(os.listdir(folder))
    try:  # ifcopenshell's own writer makes <tmp>.<n>.tmp and leaves it on failure
        with atomic_path(os.path.join(folder, "lib.ifc"), suffix=".ifc") as tmp:
            f.write(tmp)
    except Exception as e:
        out["library"] = [type(e).__name__, str(e)]
    out["after_library"] = sorted(os.listdir(folder))
    print(json.dumps(out))
""")


def test_full_disk_leaves_nothing_and_names_the_file_and_the_os_problem(tmp_path):
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / "old.txt").write_text("keep")
    proc = subprocess.run([sys.executable, "-c", _SUBPROCESS_FULL.format(root=ROOT, tests=TESTS), str(folder)],
                          cwd=str(tmp_path), stdin=subprocess.DEVNULL, capture_output=True, text=True,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    kind, msg = out["write_ifc"]
    assert kind == "OutputError"
    assert "model.ifc" in msg and "File too large" in msg
    assert out["after_write_ifc"] == ["old.txt"]
    assert "library" in out  # ifcopenshell's write failed too ...
    assert out["after_library"] == ["old.txt"]  # ... and its temporary went with ours


def test_no_space_left_keeps_the_old_file(tmp_path, monkeypatch):
    import engine.ifc.writer as writer

    path = tmp_path / "model.ifc"
    path.write_text("old")
    real_open = open

    class Full:
        def __init__(self, p, mode):
            self.fh = real_open(p, mode)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            self.fh.close()

        def write(self, data):
            self.fh.write(data[:100])
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(writer, "open", Full, raising=False)
    with pytest.raises(OutputError, match=r"model\.ifc: cannot write the IFC file: No space left on device"):
        write_ifc(small_model(), path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.ifc"]
    assert path.read_text() == "old"


@pytest.mark.parametrize("exc", [RuntimeError("library failed"), KeyboardInterrupt()])
def test_atomic_path_removes_library_temporaries(tmp_path, exc):
    target = tmp_path / "x.ifc"
    with pytest.raises(type(exc)), atomic_path(target, suffix=".ifc") as tmp:
        for extra in (".1234.tmp", "~"):
            with open(tmp + extra, "w") as fh:
                fh.write("partial")
        raise exc
    assert list(tmp_path.iterdir()) == []
    with atomic_path(target) as tmp:  # success: the library renamed its file onto ours; strays go
        with open(tmp, "w") as fh:
            fh.write("done")
        with open(tmp + ".99.tmp", "w") as fh:
            fh.write("stray")
    assert [p.name for p in tmp_path.iterdir()] == ["x.ifc"]
    assert target.read_text() == "done"


# --------------------------------------------------------------------------- 5. bad IFC
@pytest.fixture(scope="module")
def ifc_text(tmp_path_factory):
    path = write_ifc(small_model(), tmp_path_factory.mktemp("ifc") / "good.ifc")
    with open(path, "rb") as fh:
        return fh.read()


def _both_raise(path, match):
    with pytest.raises(FormatError, match=match) as e1:
        read_ifc(path)
    with pytest.raises(FormatError, match=match) as e2:
        load_model(path)
    for e in (e1, e2):
        assert e.value.path == str(path)


@pytest.mark.parametrize("fraction", [0.25, 0.6, 0.999])
def test_truncated_ifc(tmp_path, ifc_text, fraction):
    p = tmp_path / "cut.ifc"
    p.write_bytes(ifc_text[:int(len(ifc_text) * fraction)])
    _both_raise(p, r"cut\.ifc: truncated: no END-ISO-10303-21")


def test_ifc_with_syntax_error(tmp_path, ifc_text):
    lines = ifc_text.decode("ascii").splitlines(keepends=True)
    i = next(k for k in range(len(lines) // 2, len(lines)) if "IFCCARTESIANPOINT" in lines[k])
    lines[i] = lines[i][:12] + "((,;;\n"  # a cut-off entity, the file still ends properly
    p = tmp_path / "syntax.ifc"
    p.write_text("".join(lines))
    _both_raise(p, r"syntax\.ifc: syntax error in the IFC file")
    lines[i] = "#99999=IFCNOSUCHENTITY($);\n"
    p.write_text("".join(lines))
    _both_raise(p, r"syntax\.ifc: syntax error in the IFC file: .*IFCNOSUCHENTITY")


@pytest.mark.parametrize("content, match", [
    (b"", "the file is empty"),
    (b"\n  \n", "the file is empty"),
    (b'{"schema": "indoor-building-model"}', "not an IFC file"),
    (b"PK\x03\x04zipped", "is a ZIP archive"),
    (bytes(range(256)) * 4, "not an IFC file"),
])
def test_empty_or_not_ifc(tmp_path, content, match):
    p = tmp_path / "bad.ifc"
    p.write_bytes(content)
    _both_raise(p, "bad.ifc: " + match)


def test_good_ifc_still_loads(tmp_path, ifc_text):
    p = tmp_path / "ok.ifc"
    p.write_bytes(ifc_text + b"\n\n")  # trailing blank lines after the terminator are fine
    m = load_model(p)
    assert {s.id for s in m.shapes} >= {"r1", "r2", "w1", "d1"}


# --------------------------------------------------------------------------- 6. bad JSON
def _model_dict():
    return small_model().to_dict()


def _with(path, value):
    """The model dict with the value at ``path`` (keys and indices) replaced (or deleted: ...)."""
    d = _model_dict()
    node = d
    for k in path[:-1]:
        node = node[k]
    if value is ...:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return json.dumps(d)


_BAD_JSON = [
    ("[1, 2, 3]", "the top level is an array"),
    ("3", "the top level is a number"),
    ('"model"', "the top level is a string"),
    ("null", "the top level is null"),
    ("true", "the top level is a boolean"),
    ("{}", "not a building-model JSON"),
    ('{"schema": "indoor-building-model"}', "unsupported schema version"),
    ('{"schema": "indoor-building-model", "schema_version": "1"}', "unsupported schema version"),
    ('{"schema": "indoor-building-model", "schema_version": 1, "shapes": 5}', r"shapes must be an array"),
    ('{"schema": "indoor-building-model", "schema_version": 1, "shapes": ["w1"]}',
     r"shapes\[0\] must be an object, not a string"),
    (_with(("shapes", 0, "id"), ...), r"shapes\[0\] has no 'id'"),
    (_with(("shapes", 0, "type"), ...), r"shapes\[0\] \('r1'\) has no 'type'"),
    (_with(("shapes", 0, "type"), "kitchen"), "unknown shape type 'kitchen'"),
    (_with(("shapes", 0, "id"), 7), r"shapes\[0\]\.id must be a string, not a number"),
    (_with(("shapes", 0, "name"), ["a"]), r"\.name must be a string, not an array"),
    (_with(("shapes", 0, "storey"), "0"), r"\.storey must be a whole number"),
    (_with(("shapes", 0, "active"), "no"), r"\.active must be true or false"),
    (_with(("shapes", 0, "children"), "abc"), r"\.children must be an array"),
    (_with(("shapes", 0, "log"), "rule"), r"\.log must be an array"),
    (_with(("shapes", 0, "support"), [1]), r"\.support must be an object"),
    (_with(("shapes", 0, "support"), {"coverage": "high"}), r"support\['coverage'\] must be a number"),
    (_with(("shapes", 0, "attributes"), 5), r"\.attributes must be an object"),
    (_with(("shapes", 0, "scope"), {"origin": [0, 0]}), r"scope\.origin must be an array of shape \(3\)"),
    (_with(("shapes", 0, "geometry"), ...), "has no 'geometry'"),
    (_with(("shapes", 0, "geometry"), "box"), r"geometry must be an object, not a string"),
    (_with(("shapes", 0, "geometry", "vertices"), [[0, 0], [1, 1]]),
     r"geometry\.vertices must be an array of shape \(n, 3\), not \(2, 2\)"),
    (_with(("shapes", 0, "geometry", "vertices"), [[0, 0, 0], [1, 1]]), r"geometry\.vertices"),
    (_with(("shapes", 0, "geometry", "vertices"), [["a", "b", "c"]]), "must hold numbers only"),
    (_with(("shapes", 0, "geometry", "vertices", 0), [0, float("nan"), 0]), "non-finite"),
    (_with(("shapes", 0, "geometry", "faces", 2), [0, 1, 99]),
     r"geometry\.faces\[2\] has vertex index 99, out of range for 8 vertices"),
    (_with(("shapes", 0, "geometry", "faces", 2), [0, -1, 2]), "vertex index -1, out of range"),
    (_with(("shapes", 0, "geometry", "faces", 0), [0, 1]), r"faces\[0\] has 2 vertices"),
    (_with(("shapes", 0, "geometry", "faces", 0), [0, 1.5, 2]), "vertex indices"),
    (_with(("shapes", 0, "geometry", "faces"), {"a": 1}), r"geometry\.faces must be an array"),
    (_with(("storeys", 0), [0, 1]), r"storeys\[0\] must be an object"),
    (_with(("storeys", 0, "floor_z"), "low"), r"storeys\[0\]\.floor_z must be a number"),
    (_with(("storeys", 0, "index"), ...), r"storeys\[0\] has no 'index'"),
    (_with(("relations", 0, "kind"), "nearby"), r"relations\[0\]\.kind is 'nearby'"),
    (_with(("relations", 0, "a"), 1), r"relations\[0\]\.a must be a string"),
    (_with(("relations",), {"a": 1}), "relations must be an array"),
    (_with(("transform",), "identity"), "transform must be an array"),
    (_with(("transform",), [[1, 0], [0, 1]]), r"transform must be an array of shape \(4, 4\)"),
    (_with(("offset",), [1, 2]), r"offset must be an array of shape \(3\)"),
    (_with(("provenance",), 5), "provenance must be an object"),
    (_with(("provenance", "seed"), "seven"), r"provenance\.seed must be a whole number"),
    (_with(("name",), 5), "name must be a string"),
    (_with(("shapes", 1, "id"), "r1"), "duplicate shape ids"),
]


@pytest.mark.parametrize("text, match", _BAD_JSON)
def test_json_that_is_not_a_model(tmp_path, text, match):
    p = tmp_path / "bad.json"
    p.write_text(text)
    for load in (BuildingModel.from_json, load_model):
        with pytest.raises(FormatError, match=match) as e:
            load(p)
        assert e.value.path == str(p)
    with pytest.raises(FormatError, match=match) as e:
        BuildingModel.from_dict(json.loads(text), path=str(p))
    assert e.value.path == str(p)


def test_the_unchanged_dict_loads():
    """The mutations above start from a valid model (so each test fails for its own reason)."""
    m = BuildingModel.from_json(json.dumps(_model_dict()))
    assert m.to_dict() == _model_dict()


@pytest.mark.parametrize("content, match", [
    (b'{"schema": "indoor-building-model", "name": "caf\xe9"}', r"not UTF-8 text \(byte 0xe9 at offset 48\)"),
    (b"\xff\xfe{\x00}\x00", "not UTF-8 text"),
    (b"", "the file is empty"),
    (b"{'schema': 1}", "not readable as JSON"),
    (b'{"a": 1} trailing', "not readable as JSON: Extra data"),
])
def test_json_not_utf8_or_not_json(tmp_path, content, match):
    p = tmp_path / "bad.json"
    p.write_bytes(content)
    for load in (BuildingModel.from_json, load_model):
        with pytest.raises(FormatError, match="bad.json: " + match):
            load(p)


@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.9])
def test_truncated_json(tmp_path, fraction):
    text = json.dumps(_model_dict(), indent=1)
    p = tmp_path / "cut.json"
    p.write_text(text[:int(len(text) * fraction)])
    for load in (BuildingModel.from_json, load_model):
        with pytest.raises(FormatError, match=r"cut\.json: truncated JSON"):
            load(p)


def test_json_text_and_folder(tmp_path):
    with pytest.raises(FormatError, match="truncated JSON"):
        BuildingModel.from_json('{"schema": "indoor-building-model", "shapes": [')
    with pytest.raises(FormatError, match="the top level is an array"):
        BuildingModel.from_dict([1, 2, 3])
    d = tmp_path / "m.json"
    d.mkdir()
    for load in (BuildingModel.from_json, load_model):
        with pytest.raises(InputError, match="m.json: is a folder"):
            load(d)


def test_model_with_array_vertices_round_trips():
    m = small_model()
    back = BuildingModel.from_dict(m.to_dict())
    assert back.to_dict() == m.to_dict()
    assert np.array_equal(back["w1"].geometry.vertices, m["w1"].geometry.vertices)

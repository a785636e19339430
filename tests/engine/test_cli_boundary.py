"""The command line's guarantees beyond single bad files: the same input and seed give the
same IFC (SOURCE_DATE_EPOCH fixes the time stamp), names are unique, the pieces of the
error boundary behave."""
import json
import os
import signal

import pytest

from engine.cli import main
from engine.errors import (InputError, OutputError, ReconstructionError, error_kind, error_line)
from engine.jobs import check_output_dir, guarded, output_stems, terminate_as_interrupt


@pytest.fixture(scope="module")
def scan(synthetic_scan_file):
    return synthetic_scan_file("office_mw", 2, 50_000, "office.ply")


def _without_timestamp(text: str) -> str:
    # FILE_NAME('name', 'time stamp', ...): the only field allowed to differ between runs
    head, _, rest = text.partition("FILE_NAME(")
    name, _, after = rest.partition(",")
    _, _, after = after.partition(",")
    return head + "FILE_NAME(" + name + "," + after


@pytest.mark.slow  # four whole conversions
def test_same_input_and_seed_give_the_same_ifc(scan, tmp_path, monkeypatch, capsys):
    outs = [tmp_path / "a", tmp_path / "b"]
    for out in outs:
        assert main(["convert", str(scan), "-o", str(out), "--method", "manhattan", "--quiet"]) == 0
    a, b = ((o / "office.ifc").read_text() for o in outs)
    assert _without_timestamp(a) == _without_timestamp(b)
    assert "office.ifc" in a.split("FILE_NAME(", 1)[1].split(",", 1)[0]  # the real file, not /dev/null
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    for out in outs:
        assert main(["convert", str(scan), "-o", str(out), "--method", "manhattan", "--quiet"]) == 0
    a, b = ((o / "office.ifc").read_bytes() for o in outs)
    assert a == b
    assert b"2023-11-14T22:13:20" in a
    # another seed is another model identity: its GlobalIds differ
    assert main(["convert", str(scan), "-o", str(tmp_path / "c"), "--method", "manhattan", "--seed", "5",
                 "--quiet"]) == 0
    import ifcopenshell

    ids = {e.GlobalId for e in ifcopenshell.open(str(outs[0] / "office.ifc")).by_type("IfcRoot")}
    other = {e.GlobalId for e in ifcopenshell.open(str(tmp_path / "c" / "office.ifc")).by_type("IfcRoot")}
    assert not ids & other


def test_report_floor_area_of_every_space(scan, tmp_path):
    assert main(["convert", str(scan), "-o", str(tmp_path), "--method", "generic", "--quiet",
                 "--no-ifc"]) == 0
    report = json.loads((tmp_path / "office.json").read_text())["report"]
    areas = [s["floor_area_m2"] for s in report["spaces"]]
    assert all(a is not None and a > 1.0 for a in areas), areas
    assert report["source"]["frame"]["units"] == "m" and report["source"]["frame"]["up"] == "z"


def test_output_stems_never_clash():
    got = output_stems(["a/scan.ply", "b/scan.ply", "scan_2.las", "c/Scan.e57", "x/other.pcd", "scan.xyz"])
    assert len({g.lower() for g in got}) == len(got)
    assert got[0] == "scan" and got[2] == "scan_2" and got[4] == "other"


def test_check_output_dir_leaves_nothing_behind(tmp_path):
    target = tmp_path / "new" / "deeper"
    assert check_output_dir(target) == str(target)
    assert not (tmp_path / "new").exists()  # created for the check only
    f = tmp_path / "file"
    f.write_text("x")
    for bad in (f, f / "sub"):
        with pytest.raises(OutputError) as e:
            check_output_dir(bad)
        assert str(bad) in str(e.value) and error_kind(e.value) == "output"


def test_checks_of_one_new_folder_at_once_all_pass(tmp_path):
    """The workers of a cluster batch each check the output folder before their file, at
    the same moment on a new folder: one check's folder must not fail another ("File
    exists" when both create it, "No such file" when one removes it under the other; a
    2-worker batch lost two of its three scans so, 1 run in 5). 40 rounds of 4 threads."""
    import threading

    errors = []

    def check(target, barrier):
        barrier.wait()
        try:
            check_output_dir(target)
        except OutputError as e:
            errors.append(str(e))

    for k in range(40):
        target = tmp_path / f"out{k}" / "deeper"
        barrier = threading.Barrier(4)
        threads = [threading.Thread(target=check, args=(target, barrier)) for _ in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    assert errors == []
    # nothing written; a folder one check made may stay where another made one in it
    assert not [p for p in tmp_path.rglob("*") if not p.is_dir()]


def test_error_lines_name_the_file_once_and_say_the_kind():
    assert error_line(InputError("bad count", "a.ply"), "a.ply") == "a.ply: input error: bad count"
    assert error_line(ReconstructionError("no storey", "a.ply")) == "a.ply: reconstruction error: no storey"
    line = error_line(KeyError("k"), "b.ply")
    assert line.startswith("b.ply: internal error: KeyError") and "bug" in line
    assert "\n" not in error_line(RuntimeError("two\nlines"), "c.ply")
    assert error_line(OSError(28, "No space left on device", "/o/x.ifc"), "s.ply") == \
        "s.ply: output error: No space left on device: /o/x.ifc"


def test_guarded_keeps_interrupts_and_catches_the_rest():
    res, fail = guarded("s.ply", lambda: 1 / 0)
    assert res is None and fail.kind == "internal" and "ZeroDivisionError" in fail.message
    with pytest.raises(KeyboardInterrupt):
        guarded("s.ply", lambda: (_ for _ in ()).throw(KeyboardInterrupt()))


def test_sigterm_becomes_an_interrupt_and_cleans_the_temporary(tmp_path):
    from engine.fileutil import atomic_path

    target = tmp_path / "model.ifc"
    before = signal.getsignal(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt):
        with terminate_as_interrupt():
            with atomic_path(target) as tmp:
                with open(tmp, "w") as f:
                    f.write("half")
                os.kill(os.getpid(), signal.SIGTERM)  # the handler runs at the next bytecode
                for _ in range(1000):
                    pass
    assert os.listdir(tmp_path) == []
    assert signal.getsignal(signal.SIGTERM) == before  # the previous handler is back

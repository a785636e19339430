"""Parameters on the command line: ``indoor params`` (table and TOML), ``--params FILE`` and
``--set stage.key=value`` on ``convert``, and bad files or keys as usage errors."""
import json

import pytest

from engine import BuildingModel
from engine.cli import main
from engine.jobs import EXIT_USAGE
from engine.params import Params, load_params, params_table, with_settings


def _error_lines(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.startswith("error:")]


def test_params_prints_every_key_with_its_value_and_unit(capsys):
    assert main(["params"]) == 0
    lines = capsys.readouterr().out.splitlines()
    header = lines[0].split()
    assert header[:3] == ["parameter", "value", "unit"]
    unit_col = lines[0].index("unit")
    rows = params_table(Params())
    by_key = {ln.split()[0]: ln for ln in lines[1:]}
    assert len(lines) == len(rows) + 1
    for row in rows:
        line = by_key[row.key]  # every key, once
        assert line[unit_col:].split()[0] == (row.unit.split()[0] if row.unit else "-"), line


def test_params_set_changes_the_listed_value(capsys):
    assert main(["params", "--set", "generic.cells.min_wall_area=0.7", "--json"]) == 0
    rows = {r["key"]: r for r in json.loads(capsys.readouterr().out)}
    assert rows["generic.cells.min_wall_area"]["value"] == 0.7
    assert rows["generic.cells.min_wall_area"]["unit"]


def test_params_toml_loads_back_to_equal_params(tmp_path, capsys):
    changed = with_settings(Params(), ["generic.cells.min_wall_area=0.7"])
    assert main(["params", "--toml", "--set", "generic.cells.min_wall_area=0.7"]) == 0
    printed = tmp_path / "printed.toml"
    printed.write_text(capsys.readouterr().out, encoding="utf-8")
    assert load_params(printed) == changed
    written = tmp_path / "written.toml"
    assert main(["params", "--toml", "-o", str(written), "--quiet"]) == 0
    assert capsys.readouterr().out == ""
    assert load_params(written) == Params()
    # the written file is read back by --params, and --set applies after it
    assert main(["params", "--params", str(printed), "--toml", "-o", str(written), "--quiet"]) == 0
    assert load_params(written) == changed


@pytest.mark.parametrize("argv, named", [
    (["--set", "generic.cells.no_such_key=1"], "generic.cells.no_such_key"),
    (["--set", "nostage.key=1"], "nostage"),
    (["--set", "generic.cells.min_wall_area=lots"], "generic.cells.min_wall_area"),
    (["--set", "generic.cells.min_wall_area"], "generic.cells.min_wall_area"),
])
def test_bad_key_or_value_is_a_one_line_usage_error(argv, named, tmp_path, capsys):
    for cmd in (["params"], ["convert", str(tmp_path / "scan.ply"), "-o", str(tmp_path / "out")]):
        assert main([*cmd, *argv]) == EXIT_USAGE
        err = capsys.readouterr().err
        lines = _error_lines(err)
        assert len(lines) == 1 and named in lines[0] and "Traceback" not in err, err
    assert not (tmp_path / "out").exists()  # no work was done


@pytest.mark.parametrize("content, says", [
    ("[generic.cells\nmin_wall_area = 0.7\n", "TOML"),
    ("[generic.cells]\nno_such_key = 1\n", "no_such_key"),
    ("[generic.cells]\nmin_wall_area = \"big\"\n", "min_wall_area"),
])
def test_bad_params_file_is_a_one_line_usage_error(content, says, tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(content, encoding="utf-8")
    for cmd in (["params"], ["convert", str(tmp_path / "scan.ply"), "-o", str(tmp_path / "out")]):
        assert main([*cmd, "--params", str(bad)]) == EXIT_USAGE
        err = capsys.readouterr().err
        lines = _error_lines(err)
        assert len(lines) == 1 and str(bad) in lines[0] and says in lines[0] and "Traceback" not in err, err
    missing = tmp_path / "missing.toml"
    assert main(["params", "--params", str(missing)]) == EXIT_USAGE
    lines = _error_lines(capsys.readouterr().err)
    assert len(lines) == 1 and str(missing) in lines[0]


def _find(d, *keys):
    """The value at ``keys`` in the first nested dict of ``d`` (depth first) that has them."""
    if not isinstance(d, dict):
        return None
    v = d
    for k in keys:
        v = v.get(k) if isinstance(v, dict) else None
    if v is not None:
        return v
    for sub in d.values():
        found = _find(sub, *keys)
        if found is not None:
            return found
    return None


@pytest.fixture(scope="module")
def scan(synthetic_scan_file):
    return synthetic_scan_file("office_mw", 2, 50_000, "office.ply")


def test_convert_set_is_recorded_in_the_provenance(scan, tmp_path, capsys):
    assert Params().generic.cells.min_wall_area != 0.7  # a value that is not the default
    out = tmp_path / "out"
    assert main(["convert", str(scan), "-o", str(out), "--method", "generic", "--no-ifc", "--quiet",
                 "--set", "generic.cells.min_wall_area=0.7"]) == 0
    model = BuildingModel.from_json(out / "office.json")
    assert model.provenance.method == "generic"
    assert _find(model.provenance.parameters, "cells", "min_wall_area") == 0.7


def test_eta_extrapolates_the_elapsed_time_once_there_is_enough_to_go_on():
    from engine.cli.console import eta_text

    assert eta_text(1.0, 0.5) == ""  # too early to say
    assert eta_text(10.0, 0.02) == ""
    assert eta_text(10.0, 0.25) == "~30 s left"
    assert eta_text(60.0, 0.25) == "~3 min left"
    assert eta_text(60.0, 1.0) == ""

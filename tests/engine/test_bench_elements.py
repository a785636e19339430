"""The element benchmark's rows (bench/bench_elements.py): a scan reconstructed without its
scanner positions, as a merged export, is scored against the same truth and marked so."""
import pytest


@pytest.mark.slow
def test_a_row_without_scanner_positions_is_reconstructed_from_the_points_alone():
    from bench.bench_elements import COLUMNS, one, table_row

    r = one("office_mw", "tls", 0, 40_000, positions=False)
    assert "error" not in r, r.get("error")
    assert r["positions"] is False and r["points"] > 30_000
    e = r["elements"]
    assert e["doors"]["true"] == 9 and e["spaces"]["truth"] == 8
    assert e["spaces"]["matched"] >= 7  # the rooms are found from the points alone
    assert "0 (no positions)" in table_row(r)
    assert "(no positions)" not in table_row({**r, "positions": True})
    cells = table_row(r).strip("| ").split(" | ")
    assert len(cells) == len(COLUMNS)
    # the windows' width error (cm, mean/max) is reported beside the doors'
    w = e["windows"]
    assert w["matched"] and cells[-1] == f"{100 * w['width_error_mean']:.1f}/{100 * w['width_error_max']:.1f}"

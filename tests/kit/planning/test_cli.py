"""``kit plan``: one CSV row per scenario, header first; clear errors for bad input."""

import csv

import pytest

from kit import cli

MAP = "type octile\nheight 4\nwidth 5\nmap\n.....\n.@@@.\n.@...\n.....\n"
SCEN = ("version 1\n"
        "0\ttiny.map\t5\t4\t0\t0\t4\t0\t4\n"          # along the top
        "1\ttiny.map\t5\t4\t0\t0\t2\t2\t6\n"          # down and round the block's corners
        "0\ttiny.map\t5\t4\t2\t2\t0\t3\t3\n")


def run_plan(tmp_path, *extra):
    (tmp_path / "tiny.map").write_text(MAP)
    (tmp_path / "tiny.map.scen").write_text(SCEN)
    out = tmp_path / "out.csv"
    code = cli.main(["plan", str(tmp_path / "tiny.map"), "--scen",
                     str(tmp_path / "tiny.map.scen"), "--out", str(out), *extra])
    return code, list(csv.reader(out.open())) if out.exists() else None


def test_plan_writes_one_row_per_scenario_with_the_optimal_lengths(tmp_path, capsys):
    code, rows = run_plan(tmp_path)
    assert code == 0
    assert rows[0] == ["index", "length", "optimal", "expanded", "seconds"]
    assert [r[0] for r in rows[1:]] == ["0", "1", "2"]
    for _, length, optimal, expanded, seconds in rows[1:]:
        assert abs(float(length) - float(optimal)) < 1e-5
        assert int(expanded) > 0 and float(seconds) >= 0
    assert "3 at the published optimum, 0 shorter" in capsys.readouterr().out


def test_corner_cutting_makes_the_way_around_the_block_shorter(tmp_path, capsys):
    code, rows = run_plan(tmp_path, "--corner-cutting")
    assert code == 0
    assert float(rows[2][1]) == pytest.approx(2 + 2 * 2 ** 0.5)   # two diagonals past corners
    assert float(rows[3][1]) == pytest.approx(1 + 2 ** 0.5)
    assert "(corner cutting): 1 at the published optimum, 2 shorter" in capsys.readouterr().out


def test_plan_with_dijkstra_and_theta_star(tmp_path):
    for algorithm in ("dijkstra", "theta_star"):
        code, rows = run_plan(tmp_path, "--algorithm", algorithm)
        assert code == 0 and len(rows) == 4


def test_plan_errors_name_the_problem(tmp_path, capsys):
    (tmp_path / "tiny.map").write_text(MAP)
    (tmp_path / "other.scen").write_text("version 1\n0\tx.map\t9\t9\t0\t0\t1\t1\t1.41421\n")
    assert cli.main(["plan", str(tmp_path / "tiny.map"), "--scen", str(tmp_path / "other.scen"),
                     "--out", str(tmp_path / "o.csv")]) == 2
    assert "is for a 9 x 9 map" in capsys.readouterr().err
    assert cli.main(["plan", str(tmp_path / "none.map"), "--scen", str(tmp_path / "other.scen"),
                     "--out", str(tmp_path / "o.csv")]) == 2
    assert "no such map file" in capsys.readouterr().err
    (tmp_path / "tiny.map.scen").write_text(SCEN)
    assert cli.main(["plan", str(tmp_path / "tiny.map"), "--scen",
                     str(tmp_path / "tiny.map.scen"), "--out",
                     str(tmp_path / "missing" / "o.csv")]) == 2
    assert "cannot write" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        cli.main(["plan", str(tmp_path / "tiny.map")])          # --scen and --out required


@pytest.mark.dataset
def test_plan_on_the_arena_benchmark(shared_data, tmp_path, capsys):
    folder = shared_data / "movingai-grid"
    out = tmp_path / "arena.csv"
    assert cli.main(["plan", str(folder / "maps/dao/arena.map"), "--scen",
                     str(folder / "scenarios/dao/arena.map.scen"), "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert len(rows) == 160
    assert "160 at the published optimum" in capsys.readouterr().out


def test_plan_out_is_a_folder_with_plan_csv_in_it(tmp_path, capsys):
    (tmp_path / "tiny.map").write_text(MAP)
    (tmp_path / "tiny.map.scen").write_text(SCEN)
    assert cli.main(["plan", str(tmp_path / "tiny.map"), "--scen",
                     str(tmp_path / "tiny.map.scen"), "--out", str(tmp_path / "results"),
                     "--quiet"]) == 0
    rows = list(csv.reader((tmp_path / "results" / "plan.csv").open()))
    assert len(rows) == 4
    assert f"-> {tmp_path / 'results' / 'plan.csv'}" in capsys.readouterr().out

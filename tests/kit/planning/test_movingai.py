"""Moving AI ``.map``/``.scen`` readers: the benchmark's format, and clear errors for files
that break it."""

import numpy as np
import pytest

from kit.planning import MovingAIError, read_grid_map, read_scenarios

MAP = "type octile\nheight 3\nwidth 4\nmap\n.@..\n.TG.\nS..W\n"


def test_map_rows_are_y_and_columns_x(tmp_path):
    (tmp_path / "m.map").write_text(MAP)
    grid = read_grid_map(tmp_path / "m.map")
    assert (grid.height, grid.width, grid.name) == (3, 4, "m")
    np.testing.assert_array_equal(grid.passable, [[1, 0, 1, 1], [1, 0, 1, 1], [1, 1, 1, 0]])
    np.testing.assert_array_equal(grid.costs()[0], [0, 254, 0, 0])
    assert not grid.passable.flags.writeable


def test_scenarios_give_start_and_goal_as_row_col_and_their_printed_precision(tmp_path):
    (tmp_path / "m.scen").write_text(
        "version 1\n0\tm.map\t4\t3\t0\t2\t3\t0\t3.41421\n1\tm.map\t4\t3\t2\t0\t2\t2\t2\n")
    first, second = read_scenarios(tmp_path / "m.scen")
    assert (first.start, first.goal, first.optimal_length) == ((2, 0), (0, 3), 3.41421)
    assert first.decimals == 5 and first.tolerance == pytest.approx(5e-6 + 3.41421e-6)
    assert (second.index, second.bucket, second.decimals) == (1, 1, 0)


@pytest.mark.parametrize(("text", "message"), [
    ("type tile\nheight 3\nwidth 4\nmap\n", r"line 1 must be 'type octile'"),
    ("height 3\nwidth 4\nmap\n", r"line 1 must be 'type <value>'"),
    ("type octile\nheight three\nwidth 4\nmap\n", "height and width must be integers"),
    ("type octile\nheight 3\nwidth 4\n", "ends before the header line 4|line 4 must be 'map'"),
    ("type octile\nheight 3\nwidth 4\nmap\n....\n....\n", "2 map rows, the header says 3"),
    ("type octile\nheight 2\nwidth 4\nmap\n....\n...\n", "line 6 has 3 characters"),
    ("type octile\nheight 1\nwidth 4\nmap\n..x.\n", "line 5, column 3: 'x' is not a terrain"),
    ("type octile\nheight 0\nwidth 4\nmap\n", "must be positive"),
])
def test_a_map_with_a_wrong_header_or_body_names_the_problem(tmp_path, text, message):
    (tmp_path / "bad.map").write_text(text)
    with pytest.raises(MovingAIError, match=message):
        read_grid_map(tmp_path / "bad.map")


@pytest.mark.parametrize(("text", "message"), [
    ("0\tm.map\t4\t3\t0\t2\t3\t0\t3.41421\n", "first line must be 'version 1'"),
    ("version 1\n0\tm.map\t4\t3\t0\t2\t3\n", r"line 2: 9 tab-separated fields expected"),
    ("version 1\n0\tm.map\t4\t3\t0\t2\t3\t0\tfar\n", "line 2: not a scenario line"),
    ("version 1\n0\tm.map\t4\t3\t4\t2\t3\t0\t3\n", r"start_x = 4 is off the 4 x 3 map"),
])
def test_a_bad_scenario_file_names_the_line(tmp_path, text, message):
    (tmp_path / "bad.scen").write_text(text)
    with pytest.raises(MovingAIError, match=message):
        read_scenarios(tmp_path / "bad.scen")


def test_missing_files_are_errors(tmp_path):
    with pytest.raises(MovingAIError, match="no such map file"):
        read_grid_map(tmp_path / "none.map")
    with pytest.raises(MovingAIError, match="no such scenario file"):
        read_scenarios(tmp_path / "none.scen")

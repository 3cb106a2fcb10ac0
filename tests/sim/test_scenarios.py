"""`python -m sim navigate` as a user runs it: the table's columns, the glass room met as the
real Uiabot met it and then kept out, navigation while mapping with the kit's SLAM, and bad
arguments refused before anything runs."""

from __future__ import annotations

import csv
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from kit import geometry, msgs
from kit.mapping import OccupancyGridMap
from sim import scenarios
from sim.__main__ import main


def read_rows(path):
    with open(path, newline="") as f:
        return list(csv.reader(f))


@pytest.mark.slow
def test_the_glass_room_is_driven_into_without_a_mask_and_avoided_with_one(tmp_path, capsys):
    """The lidar's map has no glass, so the planner goes straight through the meeting room
    and the robot touches the glass (Fig. 4.15 of the Uiabot paper); with the keep-out mask
    it goes round by the corridor without a contact."""
    without, with_mask = tmp_path / "no_mask.csv", tmp_path / "mask.csv"
    assert main(["navigate", "--world", "office", "--route", "glass", "--episodes", "1",
                 "--no-keepout", "--out", str(without)]) == 0
    assert main(["navigate", "--world", "office", "--route", "glass", "--episodes", "1",
                 "--keepout", "--out", str(with_mask)]) == 0
    header, row = read_rows(without)
    assert tuple(header) == scenarios.COLUMNS == (
        "episode", "goal", "reached", "seconds", "path_length", "shortest_length",
        "collisions_static", "collisions_people", "min_person_distance", "reason")
    assert int(row[header.index("collisions_static")]) > 0
    header, row = read_rows(with_mask)
    got = dict(zip(header, row, strict=True))
    assert got["reached"] == "1" and got["collisions_static"] == "0", got
    # round by the corridor: longer than the straight line, near the footprint's shortest
    straight = math.dist((6.0, 9.5), (15.0, 9.5))
    assert float(got["path_length"]) > straight + 2.0
    assert float(got["path_length"]) < 1.3 * float(got["shortest_length"])
    assert "1 goals reached" in capsys.readouterr().out.replace("100% of ", "")


@pytest.mark.slow
def test_navigation_while_mapping_reaches_the_goal_on_the_map_it_builds():
    """--localization slam: the navigator starts with nothing but unknown space, SLAM's map
    reaches it every 5 s, and the estimate stays on the truth all the way."""
    s = scenarios.setup("office", "uiabot", "glass", keepout=True)
    loc = scenarios.SlamLocalization(s.nav_grid)
    node = scenarios.run_episode(s, 0, 0, loc)
    (row,) = node.results
    assert row.reached and row.collisions_static == 0, row
    assert loc.maps >= 5 and len(loc.slam.nodes) > 10
    assert max(node.pose_errors) < 0.25, max(node.pose_errors)
    # the navigator's map is SLAM's: walls where the world has them, and still unknown
    # (free to plan through) beyond what the lidar reached
    static = node.navigator.global_costmap.static
    assert np.count_nonzero(static == 254) > 500


def test_the_igv_drives_the_papers_aisle_test_past_every_box_and_round_the_corner():
    """The IGV's aisle route is the Uiabot paper's one-way test (it cannot turn round in
    1.5 m); with nobody in the aisle it threads all four boxes (0.84 m of body in 1.2 m gaps)
    and turns the corner round its inner edge without touching anything, near cruise speed."""
    assert scenarios.default_route("aisle", "igv") == "waypoints"
    assert scenarios.default_route("aisle", "uiabot") == "tour"
    s = scenarios.setup("aisle", "igv")
    assert s.route is scenarios.ROUTES["aisle", "waypoints"]
    s.route = dataclasses.replace(s.route, people=0)
    node = scenarios.run_episode(s, 0, 0, scenarios.TruthLocalization())
    assert [r.reached for r in node.results] == [True, True], node.results
    assert sum(r.collisions_static for r in node.results) == 0
    cruise = 0.8                 # hardware/robots/igv.toml [navigation]
    for r in node.results:
        assert r.seconds < 1.5 * r.shortest_length / cruise, r


def test_the_igv_passes_four_people_in_the_aisle_who_step_into_its_doors():
    """Nobody can pass the IGV in the 1.5 m aisle (a person and 0.84 m of robot need more);
    the people step into the aisle's doors as it comes and walk on behind it. Seeded: it
    reaches both waypoints at close to cruise speed without touching anyone, passing within
    half a metre of people standing in doors."""
    s = scenarios.setup("aisle", "igv")
    assert s.route.people == 4 and len(s.world.alcoves) == 16
    node = scenarios.run_episode(s, 0, 0, scenarios.TruthLocalization())
    assert [r.reached for r in node.results] == [True, True], node.results
    assert sum(r.collisions_static + r.collisions_people for r in node.results) == 0
    assert min(r.min_person_distance for r in node.results) < 0.5
    for r in node.results:
        assert r.seconds < 1.5 * r.shortest_length / 0.8, r


def test_a_map_is_drawn_on_the_canvas_cell_for_cell():
    canvas_cells = np.zeros((40, 60), dtype=np.int8)
    info = msgs.MapMetaData(resolution=0.05, width=60, height=40,
                            origin=msgs.Pose(msgs.Point(-1.0, -0.5, 0.0)))
    canvas = msgs.OccupancyGrid(msgs.Header(frame_id="map"), info, canvas_cells.ravel())
    blank = scenarios.unknown_canvas(canvas)
    assert np.all(np.asarray(blank.data) == -1) and blank.info == canvas.info
    grid = OccupancyGridMap(0.05, origin=(0.0, 0.0))
    for _ in range(10):    # p_free 0.4: a cell is drawn free after a few clear rays
        grid.insert_points([0.01, 0.01], [[1.02, 0.01]], [True])
    drawn = np.asarray(scenarios.on_canvas(grid, canvas).data).reshape(40, 60)
    # the return at (1.02, 0.01) lands in the canvas cell holding that point; the ray free
    row, col = math.floor((0.01 + 0.5) / 0.05), math.floor((1.02 + 1.0) / 0.05)
    assert drawn[row, col] == 100
    assert drawn[row, col - 10] == 0
    assert drawn[row + 10, col] == -1                 # never seen: unknown


@pytest.mark.parametrize(("args", "message"), [
    (["--episodes", "0"], "--episodes must be at least 1"),
    (["--world", "aisle", "--route", "glass"], "no route 'glass' in world 'aisle'"),
    (["--people", "-1"], "people must be a whole number of at least 0; got -1"),
])
def test_bad_arguments_are_refused_with_the_reason(tmp_path, capsys, args, message):
    out = tmp_path / "t.csv"
    assert main(["navigate", *args, "--out", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_unknown_localization_or_controller_is_refused_before_any_episode():
    with pytest.raises(ValueError, match="localization is one of truth, amcl, slam"):
        scenarios.navigate(localization="gps", episodes=1)
    with pytest.raises(ValueError, match="controller is 'rpp' or 'dwb'"):
        scenarios.navigate(controller="teb", episodes=1)


def test_the_person_gap_is_the_distance_to_the_footprints_outline():
    square = np.array([[0.5, 0.5], [-0.5, 0.5], [-0.5, -0.5], [0.5, -0.5]])
    points = np.array([[2.0, 0.0], [0.5, 1.5], [1.5, 1.5], [0.0, 0.0]])
    got = scenarios.polygon_distance(square, points)
    assert got[:3] == pytest.approx([1.5, 1.0, math.sqrt(2.0)])
    rotated = geometry.transform_points([0.0, 0.0, math.pi / 4], square)
    assert scenarios.polygon_distance(rotated, [[2.0, 0.0]])[0] == \
        pytest.approx(2.0 - math.sqrt(0.5))


def test_slam_drops_the_returns_of_a_person_in_seen_free_space_and_keeps_the_walls():
    """What a person adds to a scan ends in space the map has seen free; the walls' returns
    end on the map's walls. Ranges ray-cast in the office's own map (AMCL's caster), a person
    (a 0.25 m circle) put in the corridor in front of the scanner."""
    from kit.localization.likelihood_field import LikelihoodField, expected_ranges
    from sim.world import load_world

    grid = load_world("office").occupancy_grid(0.05, layer="lidar")
    laser = np.array([4.0, 6.0, 0.0])
    angles = np.radians(np.arange(-180.0, 180.0, 1.0))
    walls = expected_ranges(LikelihoodField.from_grid(grid), laser, angles, 12.0)
    centre, radius = np.array([5.5, 6.1]), 0.25
    d = np.column_stack([np.cos(angles), np.sin(angles)])
    along = d @ (centre - laser[:2])                       # the beam's closest approach
    gap2 = radius**2 - (np.sum((centre - laser[:2]) ** 2) - along**2)
    person = (gap2 > 0) & (along > 0)
    ranges = np.where(person, along - np.sqrt(np.maximum(gap2, 0.0)), walls)
    assert 10 <= person.sum() <= 25 and np.all(ranges[person] < walls[person])
    scan = msgs.LaserScan(angle_min=float(angles[0]), angle_increment=float(np.radians(1.0)),
                          range_min=0.1, range_max=12.0, ranges=ranges)
    mask = scenarios.seen_free(grid, 0.15)
    out, dropped = scenarios.drop_returns_in(scan, laser, mask, grid.info)
    gone = np.isnan(out.ranges)
    assert dropped == gone.sum() == person.sum()
    assert np.array_equal(gone, person)                    # the person's, and no wall's
    kept = ~person & np.isfinite(ranges) & (ranges < 12.0)
    assert np.array_equal(out.ranges[kept], scan.ranges[kept])
    # a map that has seen nothing free keeps everything; the scan given is not changed
    unknown = np.zeros_like(mask)
    same, none = scenarios.drop_returns_in(scan, laser, unknown, grid.info)
    assert none == 0 and same is scan and not np.isnan(scan.ranges).any()


NAV2_HUMBLE = Path(__file__).resolve().parents[1] / "data" / "nav2_params" / "nav2-humble" / \
    "nav2_params.yaml"


@pytest.mark.parametrize(("args", "message"), [
    (["--params", "missing.yaml"], "missing.yaml: no such parameter file"),
    (["--namespace", "robot1"], "--namespace needs --params"),
    (["--params", str(NAV2_HUMBLE), "--controller", "rpp"],
     "the controller asked for is 'rpp', but the file's FollowPath is "
     "dwb_core::DWBLocalPlanner"),
])
def test_a_parameter_file_that_cannot_be_used_is_refused_in_one_line(tmp_path, capsys, args,
                                                                     message):
    out = tmp_path / "t.csv"
    assert main(["navigate", "--episodes", "1", *args, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert not out.exists()


def test_a_file_with_a_bad_value_names_it(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(NAV2_HUMBLE.read_text().replace("max_vel_x: 0.26", "max_vel_x: fast"))
    assert main(["navigate", "--params", str(bad), "--out", str(tmp_path / "t.csv")]) == 2
    err = capsys.readouterr().err
    assert "controller_server.FollowPath.max_vel_x must be a number; got 'fast'" in err


@pytest.mark.slow
def test_navigate_runs_from_nav2s_humble_file_and_prints_what_became_of_each_key(tmp_path,
                                                                                  capsys):
    out = tmp_path / "humble.csv"
    assert main(["navigate", "--world", "office", "--route", "glass", "--episodes", "1",
                 "--params", str(NAV2_HUMBLE), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert printed.startswith(f"Nav2 parameters from {NAV2_HUMBLE}: ")
    assert "velocity_smoother — not used: the kit does not mirror velocity_smoother" in printed
    assert "amcl:deskew: true — the kit's own parameter" in printed
    assert "office/glass, uiabot, truth, dwb: " in printed
    header, row = read_rows(out)
    assert len(header) == len(row) == len(scenarios.COLUMNS)

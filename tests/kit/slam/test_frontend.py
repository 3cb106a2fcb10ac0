"""The SLAM front end and ``kit slam``: a synthetic CARMEN log of a known route through a known
room, and the real TurtleBot 4 bag against its building map."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from kit import geometry, maps
from kit.cli import main as kit_main
from kit.slam import carmen, correlative, frontend, loops, offline
from kit.slam.frontend import thin

ROOM = np.array([[0, 0], [12, 0], [12, 6], [7, 6], [7, 3.5], [5, 3.5], [5, 6], [0, 6]], float)


def cast(pose, beams=361, fov=np.pi):
    """Exact ranges from ``pose`` to the polygon ROOM's walls, a front half-circle."""
    return cast_at(pose, pose[2] + np.linspace(-fov / 2, fov / 2, beams))


def cast_at(pose, angles):
    """Exact ranges from ``pose`` to ROOM's walls along the beams at ``angles`` (map)."""
    d = np.column_stack([np.cos(angles), np.sin(angles)])
    best = np.full(len(angles), np.inf)
    for a, b in zip(ROOM, np.roll(ROOM, -1, axis=0), strict=True):
        e = b - a
        denom = d[:, 0] * e[1] - d[:, 1] * e[0]
        with np.errstate(divide="ignore", invalid="ignore"):
            t = ((a[0] - pose[0]) * e[1] - (a[1] - pose[1]) * e[0]) / denom
            u = ((a[0] - pose[0]) * d[:, 1] - (a[1] - pose[1]) * d[:, 0]) / denom
        ok = (t > 0) & (u >= 0) & (u <= 1)
        best = np.where(ok & (t < best), t, best)
    return best


def route(n=160):
    """Out along the room and back: a loop the front end must close."""
    s = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([6 + 4 * np.cos(s), 2 + 1.0 * np.sin(s), s + np.pi / 2])


def write_log(path, truth, rng, drift=(0.02, 0.004)):
    """A FLASER log: exact scans plus noise, odometry with a slowly growing error."""
    odo = truth[0].copy()
    lines = []
    for k, pose in enumerate(truth):
        if k:
            step = geometry.relative(truth[k - 1], pose)
            step = step * (1 + drift[0]) + np.array([0, 0, drift[1]])
            odo = geometry.compose(odo, step)
        r = cast(pose) + rng.normal(0, 0.005, 361)
        values = " ".join(f"{v:.4f}" for v in r)
        o = " ".join(f"{v:.6f}" for v in odo)
        lines.append(f"FLASER 361 {values} {o} {o} {100 + 0.2 * k:.3f} sim {0.2 * k:.3f}")
    path.write_text("\n".join(lines) + "\n")
    return 100 + 0.2 * np.arange(len(truth))


def test_slam_on_a_known_route_beats_odometry_and_closes_the_loop(tmp_path):
    rng = np.random.default_rng(0)
    truth = route()
    stamps = write_log(tmp_path / "room.log", truth, rng)
    log = carmen.read_carmen(tmp_path / "room.log")
    slam = offline.run_carmen(log)
    t, poses = slam.trajectory()
    assert np.allclose(t, stamps)
    aligned = geometry.compose(geometry.compose(truth[0], geometry.inverse(poses[0])), poses)
    err = np.hypot(*(aligned[:, :2] - truth[:, :2]).T)
    odo = np.array([r.robot_pose for r in log.lasers])
    odo_err = np.hypot(*(odo[:, :2] - truth[:, :2]).T)
    assert err.max() < 0.05 < odo_err.max()
    assert slam.loop_closures


def test_kit_slam_writes_map_trajectory_graph_and_errors(tmp_path, capsys):
    rng = np.random.default_rng(1)
    truth = route(120)
    stamps = write_log(tmp_path / "room.log", truth, rng)
    pairs = [(0, 5), (10, 12), (3, 100)]
    with (tmp_path / "room.relations").open("w") as f:
        for i, j in pairs:
            d = geometry.relative(truth[i], truth[j])
            f.write(f"{stamps[i]:.3f} {stamps[j]:.3f} {d[0]:.6f} {d[1]:.6f} 0 0 0 {d[2]:.6f}\n")
    out = tmp_path / "out"
    code = kit_main(["slam", str(tmp_path / "room.log"), "--relations",
                     str(tmp_path / "room.relations"), "--out", str(out), "--quiet"])
    assert code == 0
    printed = capsys.readouterr().out
    assert "120 scans" in printed and "3 of 3 evaluated" in printed
    for name in ("map.yaml", "map.pgm", "map.png", "trajectory.csv", "graph.g2o", "errors.csv"):
        assert (out / name).is_file(), name
    rows = list(csv.reader((out / "trajectory.csv").open()))
    assert rows[0] == ["stamp", "x", "y", "yaw"] and len(rows) == 121
    assert float(rows[1][0]) == pytest.approx(stamps[0])
    grid = maps.read_map(out / "map.yaml")
    assert (grid.data == 100).sum() > 100
    errors = list(csv.DictReader((out / "errors.csv").open()))
    assert max(float(e["translational_m"]) for e in errors) < 0.05
    closures = list(csv.DictReader((out / "closures.csv").open()))
    assert closures and set(closures[0]) >= {"node", "node_stamp", "candidate", "accepted",
                                             "reason", "response", "support", "chi2"}
    accepted = [c for c in closures if c["accepted"] == "1"]
    assert accepted and all(c["reason"] == "" and float(c["chi2"]) >= 0 for c in accepted)
    assert all(c["reason"] for c in closures if c["accepted"] == "0")
    assert f"{len(accepted)} loop closures of {len(closures)} candidates" in printed
    scans = list(csv.DictReader((out / "scans.csv").open()))
    assert len(scans) == 120 and scans[0]["matched"] == "first"
    assert {s["matched"] for s in scans[1:]} <= {"icp", "search", "odometry"}


def test_kit_slam_reports_bad_input(tmp_path, capsys):
    assert kit_main(["slam", str(tmp_path / "none.log"), "--out", str(tmp_path)]) == 2
    assert "no such log or bag" in capsys.readouterr().err
    (tmp_path / "x.log").write_text("PARAM a b\n")
    assert kit_main(["slam", str(tmp_path / "x.log"), "--out", str(tmp_path)]) == 2
    assert "no FLASER or ROBOTLASER1" in capsys.readouterr().err
    (tmp_path / "bag").mkdir()
    assert kit_main(["slam", str(tmp_path / "bag"), "--odometry-noise", "3", "--out",
                     str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--odometry-noise applies to CARMEN logs" in err and "Traceback" not in err


def test_perturbed_odometry_follows_its_error_model_and_bad_shapes_are_refused(tmp_path):
    """Without noise the perturbed steps are the true ones stretched by the distance and
    turning errors plus the drift per metre; the seed makes the noise repeatable."""
    from kit.slam import evaluate

    truth = route(120)
    quiet = evaluate.perturb_odometry(truth, 1, noise_xy=(0, 0), noise_theta=(0, 0, 0))
    step, bent = geometry.relative(truth[:-1], truth[1:]), geometry.relative(quiet[:-1],
                                                                            quiet[1:])
    d = np.hypot(step[:, 0], step[:, 1])
    assert np.allclose(bent[:, :2], 1.02 * step[:, :2])
    assert np.allclose(bent[:, 2], 1.01 * step[:, 2] + 0.01 * d)
    assert np.array_equal(evaluate.perturb_odometry(truth, 5), evaluate.perturb_odometry(truth, 5))
    assert not np.allclose(evaluate.perturb_odometry(truth, 5), evaluate.perturb_odometry(truth, 6))
    with pytest.raises(ValueError, match=r"\(N, 3\)"):
        evaluate.perturb_odometry(np.zeros(3), 0)
    write_log(tmp_path / "room.log", truth, np.random.default_rng(0))
    log = carmen.read_carmen(tmp_path / "room.log")
    with pytest.raises(ValueError, match="one pose per laser message"):
        offline.run_carmen(log, odometry=truth[:-1])


def cast_with_person(pose, person, radius=0.25, beams=720):
    """A 360° scan of ROOM with a round person standing in it."""
    angles = pose[2] + np.linspace(-np.pi, np.pi, beams, endpoint=False)
    ranges = cast_at(pose, angles)
    d = np.column_stack([np.cos(angles), np.sin(angles)])
    f = np.asarray(pose[:2]) - person
    b = d @ f
    disc = b**2 - (f @ f - radius**2)
    hit = (disc >= 0) & (-b - np.sqrt(np.maximum(disc, 0)) > 0)
    t = -b - np.sqrt(np.maximum(disc, 0))
    return np.where(hit & (t < ranges), t, ranges), angles - pose[2]


def test_a_person_walking_behind_the_robot_is_dropped_from_matching_and_the_map():
    """A 360° scanner driven out along the room and back with a person 1 m behind it the
    whole way: the returns on the person land where the scans have seen free space and are
    dropped as moving (the walls' returns are not), the trajectory stays on the truth, and
    the map shows no trail of the person."""
    from kit import msgs
    from kit.slam import frontend

    truth = route(160)
    slam = frontend.Slam()
    rng = np.random.default_rng(4)
    odo, people, fronts = truth[0].copy(), [], []
    for k, pose in enumerate(truth):
        if k:
            odo = geometry.compose(odo, geometry.relative(truth[k - 1], pose) *
                                   np.array([1.03, 1.03, 1.0]))
        heading = np.array([np.cos(pose[2]), np.sin(pose[2])])
        people.append(pose[:2] - 1.0 * heading if k > 10 else np.array([100.0, 100.0]))
        fronts.append(people[-1] + 0.25 * heading)    # the side the scanner sees
        ranges, angles = cast_with_person(pose, people[-1])
        scan = msgs.LaserScan(angle_min=float(angles[0]),
                              angle_increment=float(angles[1] - angles[0]), range_max=30.0,
                              ranges=ranges + rng.normal(0, 0.005, len(ranges)))
        slam.add_scan(scan, odo, 0.2 * k)
    slam.optimize()
    _, poses = slam.trajectory()
    assert np.hypot(*(poses[:, :2] - truth[:, :2]).T).max() < 0.05
    assert sum(r.moving for r in slam.records) > 5 * 150
    on_person = on_wall = 0
    for node in slam.nodes:
        ends, _, _ = node.beams
        dropped = geometry.transform_points(truth[node.scan_index], ends[node.moving])
        near = np.hypot(*(dropped - people[node.scan_index]).T) < 0.3
        on_person, on_wall = on_person + near.sum(), on_wall + (~near).sum()
    assert on_person > 20 * on_wall
    grid = slam.occupancy_map(0.05)
    assert not any(grid.probability_at(p) > 0.65 for p in fronts[20:])


def test_front_end_rejects_bad_settings_and_odometry():
    with pytest.raises(ValueError, match="min_travel"):
        frontend.SlamConfig(min_travel=0)
    slam = frontend.Slam()
    from kit import msgs

    scan = msgs.LaserScan(angle_increment=0.1, range_max=5.0, ranges=np.ones(10))
    with pytest.raises(ValueError, match="odometry"):
        slam.add_scan(scan, [0.0, 0.0])
    with pytest.raises(ValueError, match="one pose per beam"):
        frontend.scan_points(scan, beam_motion=np.zeros((3, 3)))


def test_de_skewing_undoes_the_motion_during_a_scan():
    """A scan taken while turning in place, beam by beam: with the per-beam motion the
    points land where an instantaneous scan would put them."""
    from kit import msgs

    pose = np.array([6.0, 2.0, 0.0])
    rate = 1.0  # rad/s while the 361 beams are taken over 0.2 s
    dt = 0.2 / 360
    turned = [pose + np.array([0, 0, rate * i * dt]) for i in range(361)]
    ranges = np.array([cast(p, beams=361)[i] for i, p in enumerate(turned)])
    scan = msgs.LaserScan(angle_min=-np.pi / 2, angle_increment=np.pi / 360, range_max=30.0,
                          ranges=ranges, time_increment=dt)
    motion = np.column_stack([np.zeros(361), np.zeros(361), rate * dt * np.arange(361)])
    straight = geometry.transform_points(pose, frontend.scan_points(scan, beam_motion=motion))
    skewed = geometry.transform_points(pose, frontend.scan_points(scan))
    assert wall_distance(straight).max() < 1e-4     # every point back on a wall
    assert wall_distance(skewed).max() > 0.1        # without it the far walls bend


def wall_distance(points):
    """Distance of each point to the nearest wall of ROOM."""
    best = np.full(len(points), np.inf)
    for a, b in zip(ROOM, np.roll(ROOM, -1, axis=0), strict=True):
        e = b - a
        t = np.clip(((points - a) @ e) / (e @ e), 0, 1)
        best = np.minimum(best, np.hypot(*(points - (a + t[:, None] * e)).T))
    return best


@pytest.mark.dataset
@pytest.mark.slow
def test_turtlebot4_map_agrees_with_the_building_map(shared_data, tmp_path):
    """The real TurtleBot 4 bag mapped by ``kit slam``: aligned to the building map (a rigid
    search), ≥ 80 % of its occupied cells lie within 0.1 m of the building's."""
    from kit.slam import evaluate

    bag = shared_data / "ros2-bags/turtlebot4-real-olin-mac-first-floor"
    assert kit_main(["slam", str(bag), "--out", str(tmp_path), "--quiet"]) == 0
    building = maps.read_map(
        shared_data / "maps/olin-mac-first-floor-real/mac_1st_floor_final.yaml")
    share, _ = evaluate.map_agreement(maps.read_map(tmp_path / "map.yaml"), building)
    assert share >= 0.8


@pytest.mark.dataset
@pytest.mark.slow
def test_gazebo_turtlebot3_bag_is_mapped(shared_data, tmp_path):
    """The Gazebo bag stamps its messages with simulation time and its scan spans
    angle_max = 6.28: the map still shows turtlebot3_world's nine pillars and walls, and
    lies within 0.1 m of ROBOTIS' own map of that world once aligned (≥ 80 % of cells)."""
    from kit.slam import evaluate

    bag = shared_data / "ros2-bags/turtlebot3-burger-gazebo-walker"
    assert kit_main(["slam", str(bag), "--out", str(tmp_path), "--quiet"]) == 0
    ours = maps.read_map(tmp_path / "map.yaml")
    world = maps.read_map(shared_data / "maps/turtlebot3-world-nav2/map.yaml")
    share, _ = evaluate.map_agreement(ours, world)
    assert share >= 0.8


def test_thinning_keeps_each_cells_first_point_as_numpys_row_unique_finds_it():
    """``thin`` and the correlative field's cells, keyed by one integer per cell, agree with
    ``np.unique(cells, axis=0)`` (rows compared as rows) on scattered and negative cells."""
    rng = np.random.default_rng(4)
    points = rng.uniform(-7.0, 5.0, (3000, 2)) * [1.0, 0.3]
    cells = np.floor(points / 0.05).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    assert np.array_equal(thin(points, 0.05), points[np.sort(first)])
    keys = correlative.cell_keys(cells)
    assert len(np.unique(keys)) == len(first)
    field = correlative.likelihood_field(points, 0.05, 0.05, margin=0.3)
    again = correlative.likelihood_field(points[::-1], 0.05, 0.05, margin=0.3)
    assert np.array_equal(field.values, again.values)


def test_a_loops_reference_is_reused_while_its_nodes_stay_and_the_closures_are_the_same(
        tmp_path, monkeypatch):
    """Successive nodes often search the same candidate's scans: their reference (with its
    likelihood field and ICP reference) is built once while those nodes' poses stay, and the
    SLAM's closures and trajectory are those of building it for every search."""
    write_log(tmp_path / "room.log", route(), np.random.default_rng(0))
    log = carmen.read_carmen(tmp_path / "room.log")
    searches, built = [], []
    search, build = frontend.Slam._loop_reference, loops.LoopReference.__init__
    monkeypatch.setattr(frontend.Slam, "_loop_reference",
                        lambda self, *a: searches.append(1) or search(self, *a))
    monkeypatch.setattr(loops.LoopReference, "__init__",
                        lambda self, *a: built.append(1) or build(self, *a))
    reused = offline.run_carmen(log)
    assert 0 < len(built) < len(searches)

    def fresh(self, *args):
        self._loop_cache = None
        return search(self, *args)

    monkeypatch.setattr(frontend.Slam, "_loop_reference", fresh)
    rebuilt = offline.run_carmen(log)
    assert reused.closures and len(reused.closures) == len(rebuilt.closures)
    for a, b in zip(reused.closures, rebuilt.closures, strict=True):
        assert (a.node, a.candidate, a.accepted, a.reason, a.reference) == \
            (b.node, b.candidate, b.accepted, b.reason, b.reference)
        assert np.array_equal([a.response, a.support, a.chi2], [b.response, b.support, b.chi2],
                              equal_nan=True)
        assert np.array_equal(a.measurement, b.measurement)
    assert np.array_equal(reused.trajectory()[1], rebuilt.trajectory()[1])


def test_odometry_that_stalls_then_jumps_does_not_turn_the_map():
    """Odometry that repeats one reading while the robot turns on (18° a scan), then jumps
    by all it missed, as CSAIL's raw log does once (one reading for four scans of a 75°/s
    turn, then 85.5° at once): the jump is predicted from the scan before the repeats, so
    the scan after it is matched from the right guess. Predicted from the last scan, the
    guess counts the turn twice (90° here) and ICP settles a quarter turn off in the
    rectangular room: the map turned by 90° from there on."""
    from kit import msgs

    steps = 24
    truth = np.array([[3.0 + 0.04 * k, 2.5 + 0.02 * k,
                       geometry.wrap_angle(0.3 + np.radians(18) * k)] for k in range(steps)])
    reading = truth.copy()
    reading[8:13] = reading[7]                 # stalled for five scans, then caught up at 13
    slam = frontend.Slam()
    rng = np.random.default_rng(2)
    for k, pose in enumerate(truth):
        ranges, angles = cast_with_person(pose, np.array([100.0, 100.0]))
        scan = msgs.LaserScan(angle_min=float(angles[0]),
                              angle_increment=float(angles[1] - angles[0]), range_max=30.0,
                              ranges=ranges + rng.normal(0, 0.005, len(ranges)))
        slam.add_scan(scan, reading[k], 0.2 * k)
    slam.optimize()
    _, poses = slam.trajectory()
    assert [r.matched for r in slam.records[1:]] == ["icp"] * (steps - 1)
    heading = np.abs(geometry.wrap_angle(poses[:, 2] - truth[:, 2]))
    assert np.degrees(heading.max()) < 1.0
    assert np.hypot(*(poses[:, :2] - truth[:, :2]).T).max() < 0.05


def test_a_loops_drift_allowance_runs_the_shortest_way_through_accepted_closures():
    """The driving along which a loop's drift can lie is the shortest way between its two
    nodes along the chain and across closures already accepted: nodes 1 m of driving apart,
    a closure tying node 80 to node 10 makes node 90 and node 5 15 m apart (10 + 5), not the
    85 m of driving between them; a second closure (30 to 88) makes 95 and 25 12 m apart
    (7 + 5); a rejected closure ties nothing."""
    from types import SimpleNamespace

    slam = frontend.Slam()
    slam.nodes = [SimpleNamespace(travelled=float(k)) for k in range(100)]
    assert slam._drift_path(90, 5) == 85.0
    slam.backend.closures.append(loops.LoopClosure(80, 10, accepted=True, reference=10))
    assert slam._drift_path(90, 5) == pytest.approx(15.0)
    assert slam._drift_path(50, 40) == pytest.approx(10.0)       # the chain is shorter
    slam.backend.closures.append(loops.LoopClosure(88, 30, accepted=True, reference=30))
    slam.backend.closures.append(loops.LoopClosure(60, 20, accepted=False, reference=20))
    assert slam._drift_path(95, 25) == pytest.approx(12.0)       # 95→88, 30→25
    assert slam._drift_path(65, 20) == pytest.approx(25.0)       # 65→80, 10→20; not 60→20

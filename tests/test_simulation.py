"""The pymunk simulator: determinism, traction physics, sensors against geometry, people,
bags and rendering."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import geometry, msgs, odometry, robots, rosconv
from sim import Simulation, World, WorldError, load_world
from sim.raycast import cast_rays
from sim.world import _build


def twist(v: float = 0.0, w: float = 0.0) -> msgs.Twist:
    return msgs.Twist(msgs.Vector3(v, 0.0, 0.0), msgs.Vector3(0.0, 0.0, w))


def world_of(walls=(), glass=(), circles=(), routes=(), oil=(), spawn=(0.0, 0.0, 0.0),
             boxes=(), polylines=(), alcoves=()) -> World:
    items = [([list(a), list(b)], "wall") for a, b in walls] + \
        [([list(a), list(b)], "glass") for a, b in glass] + \
        [([list(p) for p in line], "wall") for line in polylines]
    return _build("test", "", items, [tuple(b) for b in boxes], [list(c) for c in circles],
                  [list(o) for o in oil], list(spawn), [list(map(list, r)) for r in routes],
                  "test", [list(a) for a in alcoves])


def quiet_lidar(sim: Simulation) -> None:
    lidar = sim.robots[0].lidar
    lidar.noise_std = 0.0
    lidar.dropout = 0.0


def first_scan(sim: Simulation, cmd=None) -> msgs.LaserScan:
    for _ in range(1000):
        for topic, m in sim.step(cmd):
            if topic.endswith("/scan"):
                return m
        cmd = None
    raise AssertionError("no scan within 10 s")


# ------------------------------------------------------------------ determinism

def stream(seed: int) -> list[bytes]:
    sim = Simulation(world="office", robot="uiabot", seed=seed, people=3)
    out = sim.run(1.0, twist(0.3, 0.2))
    return [t.encode() + rosconv.serialize_cdr(m) for t, m in out]


def test_same_seed_gives_identical_sensor_streams_and_another_seed_other_noise():
    a, b, c = stream(11), stream(11), stream(12)
    assert a == b
    assert len(a) == len(c) and a != c


def test_reset_replays_the_same_run():
    sim = Simulation(world="square", seed=4, people=1)
    first = [rosconv.serialize_cdr(m) for _, m in sim.run(0.5, twist(0.2, 0.1))]
    sim.reset()
    again = [rosconv.serialize_cdr(m) for _, m in sim.run(0.5, twist(0.2, 0.1))]
    assert first == again


# ------------------------------------------------------------------ physics

@pytest.mark.parametrize("name", robots.ROBOTS)
def test_commanded_speed_is_travelled_within_two_percent(name):
    sim = Simulation(world="square", robot=name, seed=1, start=[1.0, 5.0, 0.0], sensors=False)
    v = 0.3
    sim.run(1.0, twist(v))  # up to speed
    x0 = sim.ground_truth().pose[0]
    sim.run(4.0)
    assert sim.ground_truth().pose[0] - x0 == pytest.approx(v * 4.0, rel=0.02)


@pytest.mark.parametrize("name", robots.ROBOTS)
def test_turning_in_place_gives_the_commanded_rate_within_two_percent(name):
    sim = Simulation(world="square", robot=name, seed=1, start=[5.0, 5.0, 0.0], sensors=False)
    sim.run(1.0, twist(0.0, 1.0))
    gt = sim.ground_truth()
    assert gt.velocity[1] == pytest.approx(1.0, rel=0.02)
    assert np.hypot(*(gt.pose[:2] - [5.0, 5.0])) < 0.01


def test_accelerating_beyond_traction_makes_encoders_overcount():
    robot = robots.load("uiabot")
    sim = Simulation(world="square", robot="uiabot", seed=1, start=[1.0, 5.0, 0.0],
                     sensors=False)
    start_ticks = sim.encoder_ticks()
    sim.run(0.6, (robot.max_wheel_speed, robot.max_wheel_speed))  # a step to full speed
    travelled = sim.ground_truth().pose[0] - 1.0
    ticks = odometry.tick_delta(np.array(start_ticks), np.array(sim.encoder_ticks()),
                                robot.counter_bits)
    encoder_distance = float(np.mean(ticks)) * robot.metres_per_tick
    assert encoder_distance > travelled + 0.01


def test_on_oil_the_encoder_heading_drifts_while_the_true_heading_does_not():
    robot = robots.load("uiabot")
    world = world_of(walls=[((0, 0), (10, 0))], oil=[(3, 3, 7, 7)])
    sim = Simulation(world=world, robot=robot, seed=1, start=[5.0, 5.0, 0.0], sensors=False)
    before = np.array(sim.encoder_ticks())
    sim.run(0.3, twist(0.0, 2.0))
    d = odometry.tick_delta(before, np.array(sim.encoder_ticks()), robot.counter_bits)
    encoder_heading = (d[0] - d[1]) * robot.metres_per_tick / robot.wheel_separation
    true_heading = sim.ground_truth().pose[2]
    assert sim.ground_truth().in_oil
    assert encoder_heading > 0.3 and abs(true_heading) < 0.25 * encoder_heading


def test_full_speed_never_passes_through_a_wall_and_the_collision_is_reported():
    world = world_of(walls=[((3, -5), (3, 5))])
    sim = Simulation(world=world, robot="igv", seed=1, start=[0.0, 0.0, 0.0], sensors=False)
    sim.run(5.0, twist(5.0))  # beyond the IGV's limit: saturated to 110 RPM
    assert sim.ground_truth().pose[0] < 3.0 - 0.2  # the footprint's front is 0.25 m ahead
    assert any(c.other == "wall" for c in sim.collisions)


def test_a_pedestrian_in_the_way_is_a_collision():
    # a person standing still steps back from a robot coming at them (at most 1.5 m/s); the
    # IGV at its 1.8 m/s catches them: contact, reported
    world = world_of(walls=[((-1, -3), (30, -3))], routes=[[(3.0, 0.0)]])
    sim = Simulation(world=world, robot="igv", seed=3, people=1, start=[0.0, 0.0, 0.0])
    sim.run(12.0, twist(1.8))
    hits = [c for c in sim.collisions if c.other == "person"]
    assert hits and hits[0].robot == 0 and 1.0 < hits[0].time < 4.0


def test_a_pedestrian_steps_out_of_the_way_of_a_slow_robot():
    world = world_of(walls=[((-1, -3), (10, -3))], routes=[[(3.0, 0.0)]])  # standing still
    sim = Simulation(world=world, robot="uiabot", seed=3, people=1, start=[0.0, 0.0, 0.0])
    sim.run(8.0, twist(0.5))
    assert not [c for c in sim.collisions if c.other == "person"]
    assert sim.ground_truth().pose[0] > 3.5          # the robot drove on past their spot


def test_a_pedestrian_keeps_clear_of_the_igvs_rear_as_of_its_front():
    """The IGV's base_link is its front axle, with 0.75 m of body behind. Someone walking at
    its side, across its rear half, keeps clear of the body's edge: closing in is measured
    toward the outline's nearest point, not toward base_link (measured that way, a person
    heading for the rear slid along a circle round the axle into the body's side)."""
    world = world_of(walls=[((-6, -4), (6, -4))], routes=[[(-0.5, -3.0), (-0.5, 3.0)]])
    sim = Simulation(world=world, robot="igv", seed=2, people=1, start=[0.0, 0.0, 0.0])
    sim.run(15.0, twist(0.0))
    assert not [c for c in sim.collisions if c.other == "person"]


def test_a_pedestrian_pushed_off_their_line_against_a_box_walks_round_it():
    """Pushed off their route's line (passing someone, stepping round a robot), a person
    heading on for their next point can meet a box face-on; they step round it instead of
    pushing against it for good (in the aisle a person stood at a box like that for a whole
    episode, a wall the IGV could not pass)."""
    world = world_of(walls=[((-1, -1.0), (12, -1.0)), ((-1, 1.0), (12, 1.0))],
                     boxes=[(4.75, -1.0, 5.25, -0.2)], routes=[[(0.0, 0.0), (10.0, 0.0)]])
    sim = Simulation(world=world, seed=1, people=1, sensors=False, start=[-0.5, 0.6, 0.0])
    person = sim.people[0]
    person.body.position = (4.0, -0.45)          # pushed down beside the box
    person.target, person.direction = 1, 1
    sim.run(10.0)
    x, y = person.body.position
    assert x > 6.0, f"the person is still at ({x:.2f}, {y:.2f})"


def test_a_person_steps_into_a_door_to_let_the_igv_by_then_goes_on():
    """In a 1.5 m corridor nobody can pass the IGV (0.84 m wide). A person walking toward it
    steps back into the door behind them before they meet, waits there until it has gone
    by, then walks on: no contact, though the robot drives straight on blind."""
    recess = [(-2.0, 0.0), (8.0, 0.0), (8.0, -0.7), (9.0, -0.7), (9.0, 0.0), (20.0, 0.0)]
    world = world_of(walls=[((-2.0, 1.5), (20.0, 1.5))], polylines=[recess],
                     routes=[[(14.0, 0.75), (-1.0, 0.75)]],
                     alcoves=[(8.5, 0.75, 8.5, -0.4)])
    sim = Simulation(world=world, robot="igv", seed=2, people=1, start=[0.0, 0.75, 0.0])
    person = sim.people[0]
    assert person.body.position[0] > 10.0          # starts well beyond the door
    track, beside = [], []
    for _ in range(100):
        sim.run(0.25, twist(0.8))
        track.append(tuple(person.body.position))
        if 8.0 < sim.ground_truth().pose[0] < 9.75:  # the body alongside the door
            beside.append(person.body.position[1])
    assert not [c for c in sim.collisions if c.other == "person"]
    assert sim.ground_truth().pose[0] > 15.0       # the robot drove past the door
    assert beside and max(beside) < -0.1           # meanwhile in the door, out of the way
    assert track[-1][0] < 6.0                       # and on their way again afterwards


def test_several_robots_share_a_world_with_their_own_topics():
    sim = Simulation(world="square", robot=["uiabot", "eddie"], seed=1)
    out = sim.run(0.5, {0: twist(0.2), 1: twist(0.0, 0.5)})
    topics = {t for t, _ in out}
    assert {"/robot0/imu", "/robot0/joint_states", "/robot1/joint_states"} <= topics
    assert sim.ground_truth(0).pose[0] > sim.world.spawn[0] + 0.05
    assert sim.ground_truth(1).pose[2] > 0.1


# ------------------------------------------------------------------ lidar

def test_raycaster_matches_analytic_geometry_in_float64():
    angles = np.linspace(-0.7, 0.7, 41)
    origins = np.tile([0.1, 0.0], (41, 1))
    ranges = cast_rays(origins, angles, np.array([[5.0, -10.0, 5.0, 10.0]]), np.empty((0, 3)),
                       20.0)
    np.testing.assert_allclose(ranges, 4.9 / np.cos(angles), rtol=0, atol=1e-12)
    ranges = cast_rays(np.array([[0.0, 0.0]]), np.array([0.0]), np.empty((0, 4)),
                       np.array([[3.0, 0.0, 0.5]]), 20.0)
    assert ranges[0] == pytest.approx(2.5, abs=1e-12)


def test_scan_of_a_wall_and_a_pillar_against_geometry():
    world = world_of(walls=[((5, -10), (5, 10))], circles=[(0.1, 3.0, 0.5)])
    sim = Simulation(world=world, robot="uiabot", seed=1, start=[0.0, 0.0, 0.0])
    quiet_lidar(sim)
    scan = first_scan(sim)
    # exact beam angles: the message's float32 angle fields carry ~1e-7 rad of rounding
    angles = -math.pi + 2 * math.pi / 360 * np.arange(360)
    np.testing.assert_allclose(scan.angles(), angles, atol=1e-6)
    ahead = np.abs(angles) < 1.0
    expected = 4.9 / np.cos(angles[ahead])  # the lidar is 0.10 m ahead of base_link
    lidar = sim.robots[0].lidar
    np.testing.assert_allclose(lidar.last_ranges[ahead], expected, rtol=0, atol=1e-9)
    np.testing.assert_allclose(scan.ranges[ahead], expected, rtol=0, atol=1e-6)
    # counter-clockwise: the pillar on the left (+y) is seen at +90 degrees, 2.5 m away
    left = int(np.argmin(np.abs(angles - math.pi / 2)))
    assert angles[left] == pytest.approx(math.pi / 2, abs=1e-6)
    assert scan.ranges[left] == pytest.approx(2.5, abs=1e-6)
    assert scan.angle_min + scan.angle_increment * (len(scan.ranges) - 1) == \
        pytest.approx(scan.angle_max)


def test_glass_stops_the_robot_but_not_the_lidar():
    world = world_of(walls=[((5, -10), (5, 10))], glass=[((2, -10), (2, 10))])
    sim = Simulation(world=world, robot="uiabot", seed=1, start=[0.0, 0.0, 0.0])
    quiet_lidar(sim)
    scan = first_scan(sim)
    assert scan.ranges[int(np.argmin(np.abs(scan.angles())))] == pytest.approx(4.9, abs=1e-6)
    sim.run(6.0, twist(0.5))
    assert sim.ground_truth().pose[0] < 2.0


def test_a_turning_rplidar_bends_its_scan_the_way_per_beam_timing_says():
    world = load_world("square")
    sim = Simulation(world=world, robot="uiabot", seed=1, start=[5.0, 5.0, 0.0])
    quiet_lidar(sim)
    sim.run(1.0, twist(0.0, 1.5))
    truth = {}
    scan = None
    for _ in range(100):
        out = sim.step()
        truth[round(sim.time, 6)] = sim.ground_truth().pose
        scans = [m for t, m in out if t == "/scan"]
        if scans and scans[0].header.stamp.to_sec() > min(truth):
            scan = scans[0]
            break
    assert scan is not None
    times = np.array(sorted(truth))
    yaw = np.unwrap([truth[t][2] for t in times])
    beam_t = scan.header.stamp.to_sec() + scan.time_increment * np.arange(len(scan.ranges))
    per_beam_yaw = np.interp(beam_t, times, yaw)
    lidar_x = 5.0 + 0.10 * np.cos(per_beam_yaw)
    lidar_y = 5.0 + 0.10 * np.sin(per_beam_yaw)
    a = per_beam_yaw + scan.angles()
    r = scan.ranges.astype(float)
    px, py = lidar_x + r * np.cos(a), lidar_y + r * np.sin(a)
    off_wall = np.minimum.reduce([np.abs(px), np.abs(px - 10), np.abs(py), np.abs(py - 10)])
    assert np.max(off_wall) < 0.03  # each beam from its own pose lands on a wall
    single = geometry.transform_points(
        [5.0, 5.0, per_beam_yaw[0]],
        np.column_stack([0.1 + r * np.cos(scan.angles()), r * np.sin(scan.angles())]))
    off_wall_single = np.minimum.reduce([np.abs(single[:, 0]), np.abs(single[:, 0] - 10),
                                         np.abs(single[:, 1]), np.abs(single[:, 1] - 10)])
    assert np.max(off_wall_single) > 0.5  # one pose for the whole scan does not


def test_lidar_sees_people_and_reports_out_of_range_as_inf():
    world = world_of(walls=[((30, -1), (30, 1))], routes=[[(2.0, 0.0), (2.0, 0.0)]])
    sim = Simulation(world=world, robot="uiabot", seed=1, people=1, start=[0.0, 0.0, 0.0])
    quiet_lidar(sim)
    scan = first_scan(sim)
    ahead = int(np.argmin(np.abs(scan.angles())))
    assert scan.ranges[ahead] == pytest.approx(2.0 - 0.25 - 0.1, abs=0.05)
    behind = int(np.argmin(np.abs(np.abs(scan.angles()) - math.pi)))
    assert scan.ranges[behind] == np.inf


def test_lms291_and_kinect_scans_have_their_devices_geometry():
    sim = Simulation(world="square", robot="igv", seed=1, start=[5.0, 5.0, 0.0])
    scan = first_scan(sim)
    assert len(scan.ranges) == 181 and scan.angle_min == pytest.approx(-math.pi / 2)
    sim = Simulation(world="square", robot="eddie", seed=1, start=[5.0, 5.0, 0.0])
    scan = first_scan(sim)
    assert scan.time_increment == 0.0 and abs(scan.angle_min) < 0.5
    assert np.all(np.isinf(scan.ranges))  # 4.9 m to the wall: beyond the Kinect's 4.5 m


# ------------------------------------------------------------------ IMU and encoders

def test_imu_is_noisy_but_unbiased_enough_and_igv_compass_has_no_rates():
    sim = Simulation(world="square", robot="uiabot", seed=2, start=[5.0, 5.0, 0.5])
    imus = [m for t, m in sim.run(5.0) if t == "/imu"]
    assert len(imus) == 500  # 100 Hz
    yaws = np.array([float(geometry.quaternion_to_yaw([m.orientation.x, m.orientation.y,
                                                       m.orientation.z, m.orientation.w]))
                     for m in imus])
    assert np.std(yaws) > 1e-3 and abs(np.mean(yaws) - 0.5) < 0.02
    assert np.mean([m.linear_acceleration.z for m in imus]) == pytest.approx(9.81, abs=0.05)
    sim = Simulation(world="square", robot="igv", seed=2, start=[5.0, 5.0, 0.0])
    compass = [m for t, m in sim.run(1.0) if t == "/imu"]
    assert compass[0].angular_velocity_covariance[0] == -1.0


def test_joint_states_follow_the_encoders():
    sim = Simulation(world="square", robot="eddie", seed=2, start=[2.0, 5.0, 0.0])
    states = [m for t, m in sim.run(2.0, twist(0.3)) if t == "/joint_states"]
    stamps = np.array([m.header.stamp.to_sec() for m in states])
    np.testing.assert_allclose(np.diff(stamps), 0.02, atol=1e-9)  # 50 Hz
    assert states[-1].name == ("right_wheel_joint", "left_wheel_joint")
    per_tick = 2 * math.pi / 144
    assert np.allclose(np.mod(states[-1].position / per_tick, 1.0), 0.0, atol=1e-6)


# ------------------------------------------------------------------ input, bags, rendering

def test_bad_commands_and_worlds_are_refused_clearly(tmp_path):
    sim = Simulation(world="square", sensors=False)
    with pytest.raises(ValueError, match=r"\(right, left\) in rad/s"):
        sim.step((1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="no routes"):
        Simulation(world=world_of(walls=[((0, 0), (1, 0))]), people=2)
    (tmp_path / "w.toml").write_text("[[walls]]\npoints = [[0, 0]]\n")
    with pytest.raises(WorldError, match=r"w\.toml: walls need 2 or more"):
        load_world(tmp_path / "w.toml")
    (tmp_path / "g.toml").write_text("[[walls]]\nmaterial = 'rubber'\npoints = [[0,0],[1,0]]\n")
    with pytest.raises(WorldError, match="material must be one of"):
        load_world(tmp_path / "g.toml")
    with pytest.raises(WorldError, match="neither a built-in world"):
        load_world("moon")
    walls = "[[walls]]\npoints = [[0, 0], [10, 0], [10, 2], [0, 2], [0, 0]]\n"
    (tmp_path / "r.toml").write_text(walls + "[[boxes]]\ncenter = [5, 1]\nsize = [1, 1]\n"
                                     "[[routes]]\npoints = [[1, 1], [9, 1]]\n")
    with pytest.raises(WorldError, match=r"r\.toml: route 1 walks through a wall from "
                                         r"\[1\.0, 1\.0\] to \[9\.0, 1\.0\]"):
        load_world(tmp_path / "r.toml")
    (tmp_path / "a.toml").write_text(walls + "[[alcoves]]\nfront = [5, 1]\nback = [5, -0.5]\n")
    with pytest.raises(WorldError, match=r"alcove 1's step from \[5\.0, 1\.0\] to "
                                         r"\[5\.0, -0\.5\] crosses a wall"):
        load_world(tmp_path / "a.toml")
    (tmp_path / "n.toml").write_text(walls + "[[routes]]\npoints = [[1, 1], [1, nan]]\n")
    with pytest.raises(WorldError, match="route 1 needs finite"):
        load_world(tmp_path / "n.toml")


def test_a_recorded_run_reads_back_equal_and_rosbags_sees_the_types(tmp_path):
    from rosbags.highlevel import AnyReader

    from sim.bag import BagWriter, read_bag

    sim = Simulation(world="office", seed=5, people=2)
    out = sim.run(1.0, twist(0.3, 0.2))
    with BagWriter(tmp_path / "run") as bag:
        bag.write("/tf_static", sim.static_transforms(), 0)
        for topic, m in out:
            bag.write(topic, m)
    assert (tmp_path / "run" / "run.mcap").is_file()
    back = list(read_bag(tmp_path / "run"))
    for topic in ("/scan", "/imu", "/joint_states"):
        sent = [m for t, m in out if t == topic]
        got = [m for t, _, m in back if t == topic]
        assert sent and got == sent
    with AnyReader([tmp_path / "run"], default_typestore=rosconv.typestore()) as reader:
        types = {c.topic: c.msgtype for c in reader.connections}
    assert types == {"/tf_static": "tf2_msgs/msg/TFMessage",
                     "/scan": "sensor_msgs/msg/LaserScan", "/imu": "sensor_msgs/msg/Imu",
                     "/joint_states": "sensor_msgs/msg/JointState"}


def test_rendering_works_headless(tmp_path):
    import matplotlib

    matplotlib.use("Agg")
    from sim import render

    sim = Simulation(world="office", seed=1, people=2)
    frames, scan = [], None
    for _ in range(5):
        out = sim.run(0.2, twist(0.3))
        scan = next((m for t, m in reversed(out) if t == "/scan"), scan)
        frames.append(render.snapshot(sim, scan))
    ax = render.plot_scene(sim, scan, rays=True, paths={"path": np.array([[1, 6], [2, 6]])})
    ax.figure.savefig(tmp_path / "scene.png")
    assert (tmp_path / "scene.png").stat().st_size > 10_000
    html = render.animation_html(sim, frames)
    assert "<script" in html and "animation" in html.lower()


@pytest.mark.dataset
def test_a_nav2_map_is_a_world_the_robot_can_drive_in(shared_data):
    world = load_world(shared_data / "maps" / "turtlebot3-world-nav2" / "map.yaml")
    sim = Simulation(world=world, robot="uiabot", seed=1)
    scan = first_scan(sim, twist(0.1))
    assert np.isfinite(scan.ranges).sum() > 100


def test_compiled_scan_caster_agrees_with_the_numpy_reference():
    from sim.raycast import cast_scan

    rng = np.random.default_rng(7)
    world = load_world("office")
    for _ in range(5):
        origins = np.column_stack([rng.uniform(1, 19, 300), rng.uniform(1, 11, 300)])
        angles = rng.uniform(-np.pi, np.pi, 300)
        people = rng.uniform(0, 20, (4, 6, 3))
        people[..., 2] = 0.25
        step = rng.integers(0, 4, 300)
        fast = cast_scan(origins, angles, world.lidar_segments, world.circles, people, step, 12.0)
        reference = np.minimum(
            cast_rays(origins, angles, world.lidar_segments, world.circles, 12.0),
            cast_rays(origins, angles, np.empty((0, 4)), people[step], 12.0))
        assert np.array_equal(np.isinf(fast), np.isinf(reference))
        finite = np.isfinite(reference)
        np.testing.assert_allclose(fast[finite], reference[finite], rtol=0, atol=1e-12)


@pytest.mark.dataset
def test_a_real_robots_bag_reads_into_kit_messages(shared_data):
    from sim.bag import read_bag

    bag = shared_data / "ros2-bags" / "turtlebot4-real-olin-mac-first-floor"
    counts: dict[str, int] = {}
    for topic, _t, m in read_bag(bag, topics=["/scan", "/odom", "/cmd_vel"]):
        counts[topic] = counts.get(topic, 0) + 1
        assert isinstance(m, (msgs.LaserScan, msgs.Odometry, msgs.Twist))
    assert counts == {"/scan": 357, "/odom": 920, "/cmd_vel": 192}


def test_teleop_panel_buttons_drive_the_robot():
    import matplotlib

    matplotlib.use("Agg")
    from sim import render

    sim = Simulation(world="square", seed=1, start=[5.0, 5.0, 0.0])
    panel = render.teleop_panel(sim, step_seconds=0.5)
    buttons = {b.description: b for b in panel.children[0].children}
    assert set(buttons) == {"◀ left", "▲ forward", "▶ right", "▼ back", "■ stop"}
    buttons["▲ forward"].click()
    assert sim.ground_truth().pose[0] > 5.05
    buttons["◀ left"].click()
    assert sim.ground_truth().pose[2] > 0.1


def test_wheel_servos_can_run_a_motor_and_lab_04s_controller():
    """The IGV's wheels as its DC gear-motors, each under a PI speed loop (pole placement on
    the motor model): the robot reaches the commanded speed; a P-only loop falls short."""
    import control

    from kit.control import IGV_MOTOR, PID, PIDGains, pole_placement_pi
    from sim import Physics

    G = IGV_MOTOR.transfer_function()
    K, tau = float(control.dcgain(G)), 1.0 / abs(max(control.poles(G).real))
    pi = pole_placement_pi(K, tau, 10.0, 0.9)
    for gains, reaches in ((PIDGains(kp=pi.kp, ki=pi.ki, dt=0.01,
                                     output_limits=(-24.0, 24.0)), True),
                           (PIDGains(kp=pi.kp, dt=0.01, output_limits=(-24.0, 24.0)), False)):
        sim = Simulation(world="square", robot="igv", seed=1, start=[1.0, 5.0, 0.0],
                         sensors=False, physics=Physics(wheel_motor=IGV_MOTOR),
                         wheel_controllers=lambda g=gains: PID(g))
        sim.run(2.0, twist(0.8))
        v = sim.ground_truth().velocity[0]
        if reaches:
            assert v == pytest.approx(0.8, rel=0.02)
        else:
            assert v < 0.8 * 0.97
    with pytest.raises(ValueError, match="go together"):
        Simulation(world="square", robot="igv", wheel_controllers=lambda: PID(gains))

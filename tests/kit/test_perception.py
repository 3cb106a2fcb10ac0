"""kit.perception: beams to points, checked against the simulator's analytic geometry."""

import numpy as np
import pytest

from kit import geometry, msgs, perception
from sim import Simulation


def test_points_of_a_simulated_scan_lie_on_the_walls_the_simulator_sees():
    sim = Simulation(world="square", robot="uiabot", seed=3, start=[2.0, 5.0, 0.3])
    scan = next(m for _ in range(200) for t, m in sim.step((0.0, 0.0)) if t.endswith("scan"))
    robot = sim.description()
    laser = robot.joint("laser_joint")
    T_base_laser = [laser.xyz[0], laser.xyz[1], laser.rpy[2]]
    pose = sim.ground_truth().pose  # still standing: no motion distortion
    T_world_laser = geometry.compose(pose, T_base_laser)
    points = perception.scan_to_points(scan, T_world_laser)
    assert len(points) == perception.valid_returns(scan).sum() > 300
    # the square world's walls are the lines x = 0, x = 10, y = 0, y = 10
    x, y = points.T
    to_wall = np.min(np.abs(np.stack([x, 10 - x, y, 10 - y])), axis=0)
    assert np.median(to_wall) < 0.03


def test_rep117_beams_become_no_points():
    scan = msgs.LaserScan(angle_min=-1.0, angle_increment=0.5, range_min=0.15, range_max=8.0,
                          ranges=np.array([np.inf, -np.inf, np.nan, 0.1, 9.0, 2.0]))
    assert perception.valid_returns(scan).tolist() == [False] * 5 + [True]
    assert perception.max_range_beams(scan).tolist() == [True, False, False, False, True,
                                                         False]
    np.testing.assert_allclose(perception.scan_to_points(scan),
                               [[2.0 * np.cos(1.5), 2.0 * np.sin(1.5)]])


def test_a_pose_of_the_wrong_shape_is_refused():
    scan = msgs.LaserScan(angle_increment=0.1, range_max=1.0, ranges=np.ones(3))
    with pytest.raises(ValueError, match="pose"):
        perception.scan_to_points(scan, pose=[1.0, 2.0])


# ------------------------------------------------------------------ de-skewing, depth rows

def test_a_scan_taken_while_turning_lands_on_the_walls_once_de_skewed():
    """The simulated Uiabot spins at 1 rad/s in the square world: drawn from the stamp's pose
    its scan lies > 10 cm (median) off the walls; each beam placed from the scanner's pose at
    its own time (deskew_beam) brings it within 2 cm."""
    from kit import geometry
    from sim import Simulation

    sim = Simulation(world="square", robot="uiabot", seed=1, people=0)
    joint = sim.description().joint("laser_joint")
    mount = np.array([joint.xyz[0], joint.xyz[1], joint.rpy[2]])
    times, poses, scans = [], [], []
    for _ in range(300):
        for topic, message in sim.step(msgs.Twist(msgs.Vector3(), msgs.Vector3(0, 0, 1.0))):
            if topic == "/scan":
                scans.append(message)
        times.append(sim.time)
        poses.append(sim.ground_truth().pose.copy())
    times_a, poses_a, scan = np.array(times), np.array(poses), scans[-2]

    def laser_at(t):
        k = int(np.clip(np.searchsorted(times_a, t), 1, len(times_a) - 1))
        f = (t - times_a[k - 1]) / (times_a[k] - times_a[k - 1])
        a, b = poses_a[k - 1], poses_a[k]
        return geometry.compose([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]),
                                 a[2] + f * float(geometry.wrap_angle(b[2] - a[2]))], mount)

    segments = sim.world.segments

    def to_walls(p):
        a, b = segments[:, :2], segments[:, 2:]
        ab = b - a
        t = np.clip(((p - a) * ab).sum(axis=1) / (ab * ab).sum(axis=1), 0, 1)
        return float(np.min(np.linalg.norm(p - (a + t[:, None] * ab), axis=1)))

    r, angles = np.asarray(scan.ranges, float), perception.beam_angles(scan)
    stamp = scan.header.stamp.to_sec()
    reference = laser_at(stamp)
    valid = np.flatnonzero(perception.valid_returns(scan))
    bent = [to_walls(perception.beam_to_point(r[i], angles[i], reference)) for i in valid]
    fixed = [to_walls(geometry.transform_points(reference, perception.deskew_beam(
        r[i], angles[i], laser_at(stamp + i * scan.time_increment), reference)[None])[0])
        for i in valid]
    assert np.median(bent) > 0.10
    assert np.median(fixed) < 0.02


def test_depth_row_of_a_wall_gives_the_range_along_each_ray():
    """A flat wall D = 2 m in front of the camera, perpendicular to its axis: the pixel of
    column u sees it along a ray at φ = atan((u − cx) / fx), at range D / cos φ (geometry,
    not the formula under test). Each beam that received a column holds one of those
    ranges — the nearest of its columns — to 1e-6 m."""
    fx, cx, cy, wall = 525.0, 319.5, 239.5, 2.0
    image = np.full((480, 640), wall, dtype=np.float32)
    scan = perception.depth_image_to_scan(image, fx, cx, cy, range_min=0.45, range_max=10.0)
    phi = np.arctan((np.arange(640) - cx) / fx)
    along_rays = wall / np.cos(phi)
    ranges = np.asarray(scan.ranges, dtype=float)
    filled = np.isfinite(ranges)
    assert filled.sum() > 600
    for k in np.flatnonzero(filled):
        assert np.min(np.abs(along_rays - ranges[k])) < 1e-6
    # beam k looks where its columns look: its angle is within one increment of their rays'
    beam_angle = scan.angle_min + scan.angle_increment * np.arange(len(ranges))
    column = np.argmin(np.abs(along_rays[None, :] - ranges[filled, None])
                       + 10 * np.abs(-phi[None, :] - beam_angle[filled, None]), axis=1)
    assert np.all(np.abs(-phi[column] - beam_angle[filled]) <= scan.angle_increment + 1e-9)


def test_reverse_beam_order_keeps_every_beam_and_puts_them_in_measurement_order():
    # rplidar_ros's publish_scan with inverted=false: angle_min = π − 359°, angle_max = π,
    # and message index k holds the node measured (N − 1 − k)-th; the bag's stamp is when the
    # revolution was handed over (its last-measured beam).
    n, dt = 720, 1.871e-4
    scan = msgs.LaserScan(header=msgs.Header(msgs.Time(1663967375, 543606542), "rplidar_link"),
                          angle_min=np.pi - np.radians(359.0), angle_max=np.pi,
                          angle_increment=np.radians(0.5), time_increment=dt,
                          scan_time=dt * (n - 1), range_min=0.15, range_max=12.0,
                          ranges=np.where(np.arange(n) == 10, np.inf, np.linspace(0.5, 5.0, n)),
                          intensities=np.arange(n))
    out = perception.reverse_beam_order(scan)
    assert np.array_equal(out.ranges, scan.ranges[::-1], equal_nan=True)
    assert np.array_equal(out.intensities, scan.intensities[::-1])
    assert out.angle_increment == pytest.approx(-scan.angle_increment)
    assert out.angle_min == pytest.approx(scan.angle_min + (n - 1) * scan.angle_increment)
    assert out.header.stamp == scan.header.stamp               # not asked to move it
    # the same points, the other way round (to the message's float32 angle fields: 3e-7 rad)
    assert np.allclose(perception.scan_to_points(out), perception.scan_to_points(scan)[::-1],
                       rtol=0, atol=2e-6)
    assert np.allclose(perception.beam_angles(out), perception.beam_angles(scan)[::-1],
                       rtol=0, atol=4e-7)
    # stamped at the end: the first measured beam (old index N − 1) is at stamp − (N−1)·dt
    at_start = perception.reverse_beam_order(scan, stamped_at_end=True)
    old_times = scan.header.stamp.to_sec() - scan.time_increment * np.arange(n)  # stamp − k·dt
    assert np.allclose(perception.beam_times(at_start), old_times[::-1], atol=1e-6, rtol=0)  # µs
    assert at_start.header.stamp.to_nsec() == scan.header.stamp.to_nsec() - round(
        scan.time_increment * (n - 1) * 1e9)
    assert at_start.header.frame_id == "rplidar_link"
    # twice is the identity for the beams
    back = perception.reverse_beam_order(out)
    assert np.array_equal(back.ranges, scan.ranges)
    assert back.angle_min == pytest.approx(scan.angle_min)

"""The kinematic model (sim.kinematic) and the demo."""


import numpy as np
import pytest

from kit import odometry, robots
from kit.geometry import wrap_angle
from sim import DiffDriveModel, WheelErrors, drive_square
from sim import demo as demo_module

PERFECT = WheelErrors(radius_error_right=0.0, radius_error_left=0.0, slip_std=0.0)


def test_same_seed_same_run_other_seed_other_noise():
    robot = robots.load("uiabot")
    a = drive_square(DiffDriveModel(robot, seed=5), side=1.0)
    b = drive_square(DiffDriveModel(robot, seed=5), side=1.0)
    c = drive_square(DiffDriveModel(robot, seed=6), side=1.0)
    assert np.array_equal(a["ticks"], b["ticks"]) and np.array_equal(a["true_pose"],
                                                                     b["true_pose"])
    assert not np.array_equal(a["true_pose"], c["true_pose"])


def test_perfect_wheels_give_odometry_equal_to_truth_up_to_quantisation():
    robot = robots.load("igv")
    model = DiffDriveModel(robot, seed=1, errors=PERFECT)
    run = drive_square(model, side=3.0)
    node = odometry.WheelOdometry.for_robot(robot)
    for t, (right, left) in zip(run["time"], run["ticks"], strict=True):
        node.update(int(right), int(left), float(t))
    # one tick of the IGV is 2.5 mm of wheel travel
    assert np.linalg.norm(node.pose[:2] - run["true_pose"][-1, :2]) < 0.02
    # and the timed commands closed the square
    assert np.linalg.norm(run["true_pose"][-1, :2]) < 0.05


def test_wheel_speeds_follow_the_servo_and_respect_the_limit():
    robot = robots.load("eddie")
    model = DiffDriveModel(robot, seed=0, errors=PERFECT)
    for _ in range(200):
        model.step(5.0, 0.0)  # far beyond Eddie's wheels
    assert np.allclose(model.wheel_speeds, robot.max_wheel_speed, rtol=1e-6)
    assert model.pose[0] == pytest.approx(2 * 200 * 0.01 * robot.max_wheel_speed *
                                          robot.wheel_radius / 2, rel=0.1)


def test_encoders_quantise_and_roll_over():
    robot = robots.load("eddie")
    model = DiffDriveModel(robot, seed=0, errors=PERFECT, initial_ticks=(65530, 65530))
    for _ in range(100):
        model.step(0.3, 0.0)
    right, left = model.encoder_ticks()
    assert right < 65530 and left < 65530  # wrapped through 0
    delta = int(odometry.tick_delta(65530, right, robot.counter_bits))
    assert delta * robot.metres_per_tick == pytest.approx(model.pose[0], abs=2 *
                                                          robot.metres_per_tick + 1e-3)


def test_oil_patch_makes_odometry_worse():
    robot = robots.load("eddie")
    errors = []
    for oil in (None, (-1.0, -1.0, 5.0, 5.0)):
        err = WheelErrors(radius_error_right=0.0, radius_error_left=0.0, slip_std=0.005,
                          oil=oil)
        finals = []
        for seed in range(3):
            model = DiffDriveModel(robot, seed=seed, errors=err)
            run = drive_square(model, side=2.0)
            est = odometry.integrate_odometry(
                *[np.diff(run["ticks"][:, i]) * robot.metres_per_tick for i in (0, 1)],
                robot.wheel_separation)
            finals.append(abs(float(wrap_angle(est[-1, 2] - run["true_pose"][-1, 2]))))
        errors.append(np.mean(finals))
    assert errors[1] > 3 * errors[0]


def test_demo_drives_the_route_and_writes_figure_and_bag(tmp_path, capsys):
    from sim.bag import read_bag

    # the demo's own seed. Steering by odometry alone it can miss a door: in seeds 1 and 5 it
    # slips on the oil while waiting for people, ends 0.3-0.4 m off, faces the wall beside
    # the north-west office's door and waits there as if someone were in the way
    assert demo_module.main(tmp_path, seed=7) == 0
    out = capsys.readouterr().out
    assert (tmp_path / "demo_office.png").stat().st_size > 20_000
    assert "9 of 9 waypoints reached" in out and "collisions: 0" in out
    topics = {t for t, _, _ in read_bag(tmp_path / "demo_office")}
    assert topics == {"/scan", "/odom", "/imu", "/joint_states", "/cmd_vel", "/tf",
                      "/tf_static", "/clock"}

"""The EKF against a Kalman filter and filterpy, the planar model's Jacobian, and the fusion
filter on the simulated Uiabot's oil-patch slip."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import msgs, odometry
from kit.estimation import (
    EKF,
    FusionFilter,
    PlanarModel,
    SensorConfig,
    nis,
    predict,
    residual,
    update,
)
from kit.geometry import wrap_angle
from sim import Simulation

T, F = True, False
ODOM0 = SensorConfig((T, T, T, F, F, F, F, F, F, F, F, T, F, F, F))  # the Uiabot's odom0_config
IMU0 = SensorConfig((F, F, F, T, T, T, F, F, F, F, F, F, F, F, F))  # and its imu0_config


def test_planar_model_jacobian_matches_finite_differences():
    model = PlanarModel()
    rng = np.random.default_rng(0)
    for _ in range(20):
        x = rng.normal(0, 1, 6)
        dt = float(rng.uniform(0.01, 0.2))
        eps = 1e-6
        numeric = np.column_stack([
            residual(model.f(x + eps * e, dt), model.f(x - eps * e, dt), [2]) / (2 * eps)
            for e in np.eye(6)])
        np.testing.assert_allclose(model.F_x(x, dt), numeric, atol=1e-7)
    q = model.Q(0.05)
    assert np.allclose(q, q.T) and np.linalg.eigvalsh(q).min() > 0


def test_ekf_on_a_linear_model_is_the_kalman_filter():
    rng = np.random.default_rng(1)
    dt = 0.1
    Fm = np.array([[1, dt], [0, 1]])
    Hm = np.array([[1.0, 0.0]])
    Q = np.diag([1e-4, 1e-2])
    R = np.array([[0.25]])
    x_ekf, P_ekf = np.zeros(2), np.eye(2)
    x_kf, P_kf = np.zeros(2), np.eye(2)
    truth = np.array([0.0, 1.0])
    for _ in range(100):
        truth = Fm @ truth + rng.multivariate_normal([0, 0], Q)
        z = Hm @ truth + rng.normal(0, 0.5, 1)
        x_ekf, P_ekf = predict(x_ekf, P_ekf, lambda s: Fm @ s, Fm, Q)
        x_ekf, P_ekf, _, _ = update(x_ekf, P_ekf, z, lambda s: Hm @ s, Hm, R)
        # the textbook Kalman filter, short-form covariance update
        x_kf, P_kf = Fm @ x_kf, Fm @ P_kf @ Fm.T + Q
        S = Hm @ P_kf @ Hm.T + R
        K = P_kf @ Hm.T @ np.linalg.inv(S)
        x_kf = x_kf + K @ (z - Hm @ x_kf)
        P_kf = (np.eye(2) - K @ Hm) @ P_kf
        np.testing.assert_allclose(x_ekf, x_kf, atol=1e-12)
        np.testing.assert_allclose(P_ekf, P_kf, atol=1e-12)


def test_ekf_matches_filterpy_on_the_planar_model():
    filterpy = pytest.importorskip("filterpy.kalman")
    model = PlanarModel()
    dt = 0.02
    H = np.zeros((3, 6))
    H[0, 2] = H[1, 3] = H[2, 4] = 1.0  # yaw, vx, vyaw
    R = np.diag([1e-4, 1e-3, 4e-4])

    class Reference(filterpy.ExtendedKalmanFilter):
        def predict_x(self, u=0):
            self.x = model.f(self.x.ravel(), dt).reshape(-1, 1)

    ref = Reference(dim_x=6, dim_z=3)
    ref.x = np.array([[0.0, 0.0, 0.1, 0.3, 0.2, 0.0]]).T
    ref.P = np.eye(6) * 0.01
    ours = EKF(ref.x.ravel(), ref.P)
    rng = np.random.default_rng(2)
    for k in range(200):
        ref.F = model.F_x(ref.x.ravel(), dt)
        ref.Q = model.Q(dt)
        ref.predict()
        ours.predict(lambda s: model.f(s, dt), model.F_x(ours.x, dt), model.Q(dt))
        z = np.array([0.1 + 0.2 * k * dt, 0.3, 0.2]) + rng.normal(0, 0.01, 3)
        ref.update(z.reshape(-1, 1), lambda x: H, lambda x: H @ x, R=R)
        ours.update(z, lambda s: H @ s, H, R)
        np.testing.assert_allclose(ours.x, ref.x.ravel(), atol=1e-9)
        np.testing.assert_allclose(ours.P, ref.P, atol=1e-9)


def test_angle_residuals_wrap_and_nis_is_chi_square_sized():
    assert residual([math.pi - 0.01], [-math.pi + 0.01], [0])[0] == pytest.approx(-0.02)
    x, _, y, S = update([3.1, 0.0], np.eye(2) * 0.1, [-3.1], lambda s: s[:1],
                        [[1.0, 0.0]], [[0.1]], [0], [0])
    assert y[0] == pytest.approx(2 * math.pi - 6.2)
    assert -math.pi <= x[0] < math.pi
    assert nis(y, S) == pytest.approx(y[0] ** 2 / 0.2)


def test_sensor_configs_are_validated():
    with pytest.raises(ValueError, match="15 booleans"):
        SensorConfig((True, False))
    assert ODOM0.fused() == ["x", "y", "vyaw"] and IMU0.fused() == ["yaw"]
    with pytest.raises(ValueError, match="two_d_mode"):
        FusionFilter({}, two_d_mode=False)


def odom_message(t: float, pose, velocity=(0.0, 0.0), var=1e-4) -> msgs.Odometry:
    return odometry.odometry_message(pose, velocity, msgs.Time.from_sec(t), np.eye(3) * var,
                                     np.eye(3) * var)


def test_relative_and_differential_modes():
    rel = FusionFilter({"o": SensorConfig((T, T, F, F, F, T) + (F,) * 9, relative=True)})
    for k in range(50):
        rel.add_odometry("o", odom_message(0.02 * k, [5.0, -2.0, 1.0]))
    np.testing.assert_allclose(rel.x[:3], 0.0, atol=1e-6)  # the first pose is the origin

    diff = FusionFilter({"o": SensorConfig((T, T, F, F, F, T) + (F,) * 9, differential=True)})
    for k in range(200):  # driving 0.5 m/s along a heading of 1 rad, far from the origin
        t = 0.02 * k
        diff.add_odometry("o", odom_message(t, [7.0 + 0.5 * t * math.cos(1.0),
                                                3.0 + 0.5 * t * math.sin(1.0), 1.0]))
    assert diff.x[3] == pytest.approx(0.5, abs=0.01)  # fused as a forward velocity
    # the position is integrated from the velocity (lagging while it converges), never
    # pulled to the sensor's absolute (7, 3)
    assert 1.5 < np.hypot(diff.x[0], diff.x[1]) < 0.5 * 3.98 + 0.01


def twist(v: float, w: float) -> msgs.Twist:
    return msgs.Twist(msgs.Vector3(v, 0, 0), msgs.Vector3(0, 0, w))


def drive_and_fuse(sim: Simulation, sensors: dict[str, SensorConfig],
                   plan: list[tuple[float, msgs.Twist]]
                   ) -> tuple[odometry.WheelOdometry, FusionFilter]:
    """Drive ``plan`` (seconds, command); the odometry node runs on the encoders with the
    joint states, the fusion filter takes its Odometry as "odom0" and the IMU as "imu0"."""
    from sim.runner import FusionNode, Runner, ScriptedCommands, WheelOdometryNode

    start = sim.ground_truth().pose
    wheels = WheelOdometryNode()
    fusion = FusionFilter(sensors, frequency=30.0, initial_pose=start)
    commands = ScriptedCommands(plan)
    Runner(sim, [wheels, FusionNode(fusion, {"/odom": "odom0", "/imu": "imu0"})],
           controller=commands).run(commands.duration)
    assert wheels.odometry is not None
    return wheels.odometry, fusion


def test_fusion_keeps_the_heading_when_a_wheel_slips_on_oil():
    """The Uiabot drives onto the oil, turns there and drives on: the wheels spin, so wheel
    odometry's heading is off by about 30°; fused with the BNO055's yaw it is not."""
    ratios = []
    plan = [(1.5, twist(0.4, 0)), (1.5, twist(0.0, 2.0)), (1.0, twist(0.0, -2.0)),
            (3.0, twist(0.4, 0.0)), (2.0, twist(0.3, 0.5))]
    for seed in range(3):
        sim = Simulation(world="square", robot="uiabot", seed=seed, start=[3.6, 2.0, 0.0])
        node, fusion = drive_and_fuse(sim, {"odom0": ODOM0, "imu0": IMU0}, plan)
        truth = sim.ground_truth().pose[2]
        wheel_error = abs(float(wrap_angle(node.pose[2] - truth)))
        fused_error = abs(float(wrap_angle(fusion.x[2] - truth)))
        assert wheel_error > 0.3
        ratios.append(wheel_error / fused_error)
        out = fusion.odometry()
        assert out.header.frame_id == "odom" and out.child_frame_id == "base_link"
    assert min(ratios) >= 5


def test_outputs_at_the_configured_frequency():
    fusion = FusionFilter({"o": ODOM0}, frequency=10.0)
    stream = [("o", odom_message(0.02 * k, [0.01 * k, 0.0, 0.0], (0.5, 0.0)))
              for k in range(101)]
    published = fusion.outputs(stream)
    stamps = [m.header.stamp.to_sec() for m in published]
    np.testing.assert_allclose(np.diff(stamps), 0.1, atol=1e-9)
    assert len(published) == 20
    with pytest.raises(ValueError, match="time order"):
        fusion.add_odometry("o", odom_message(0.5, [0, 0, 0]))


def test_fusion_is_consistent_over_50_seeded_simulator_runs():
    """Monte-Carlo consistency (Bar-Shalom): the wheels slip at random exactly as the
    odometry covariance says (Physics.slip_variance = the Uiabot's odometry_k), the odometry's
    velocities and the BNO055's yaw are fused (fusing odometry's integrated pose as if its
    errors were white would make any filter overconfident), and over 50 runs the average
    NEES of (x, y, yaw) at the end and the average NIS of each sensor's last update lie in
    their 95 % χ² bounds."""
    from scipy import stats

    from kit.estimation import nees
    from sim import Physics

    odom_velocities = SensorConfig((F, F, F, F, F, F, T, F, F, F, F, T, F, F, F))
    imu_yaw = SensorConfig((F, F, F, F, F, T, F, F, F, F, F, F, F, F, F))
    runs = 50
    nees_end, nis_imu, nis_odom = [], [], []
    for seed in range(runs):
        robot_k = 1e-4  # hardware/robots/uiabot.toml [odometry]
        sim = Simulation(world="square", robot="uiabot", seed=seed, start=[2.0, 5.0, 0.0],
                         physics=Physics(slip_variance=robot_k))
        node, fusion = drive_and_fuse(
            sim, {"odom0": odom_velocities, "imu0": imu_yaw},
            [(2.0, twist(0.4, 0.3)), (2.0, twist(0.3, -0.4)), (2.0, twist(0.4, 0.2))])
        assert node.k == (robot_k, robot_k)
        nees_end.append(nees(sim.ground_truth().pose, fusion.x[:3], fusion.P[:3, :3], [2]))
        last = {name: value for name, value, _ in fusion.nis_log}
        nis_imu.append(last["imu0"])
        nis_odom.append(last["odom0"])

    def band(dof):
        return stats.chi2.ppf([0.025, 0.975], dof * runs) / runs

    low, high = band(3)
    assert low < np.mean(nees_end) < high
    low, high = band(1)
    assert low < np.mean(nis_imu) < high
    low, high = band(2)
    assert low < np.mean(nis_odom) < high

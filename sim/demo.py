"""The headless see–think–act demo: each robot drives a square by the kit's kinematics, its
odometry integrates the noisy encoder ticks, and the demo reports the final odometry error
and draws true against estimated paths."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from kit import odometry, robots
from sim.kinematic import DiffDriveModel, drive_square


def run_robot(name: str, seed: int, side: float = 2.0) -> dict[str, np.ndarray]:
    robot = robots.load(name)
    model = DiffDriveModel(robot, seed=seed)
    run = drive_square(model, side=side)
    node = odometry.WheelOdometry.for_robot(robot)
    estimate = []
    for t, (right, left) in zip(run["time"], run["ticks"], strict=True):
        node.update(int(right), int(left), float(t))
        estimate.append(node.pose.copy())
    run["odometry"] = np.array(estimate)
    run["covariance"] = node.covariance.copy()
    return run


def main(out_dir: Path, seed: int = 7) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from kit import viz

    out_dir.mkdir(parents=True, exist_ok=True)
    fig, axes = plt.subplots(1, len(robots.ROBOTS), figsize=(5 * len(robots.ROBOTS), 5))
    print("robot    side  final position error  heading error  1-sigma (odometry covariance)")
    for ax, name in zip(axes, robots.ROBOTS, strict=True):
        run = run_robot(name, seed)
        truth, est = run["true_pose"], run["odometry"]
        position_error = float(np.linalg.norm(truth[-1, :2] - est[-1, :2]))
        heading_error = float(np.degrees(abs(np.angle(np.exp(1j * (truth[-1, 2] -
                                                                  est[-1, 2]))))))
        sigma = float(np.sqrt(run["covariance"][0, 0] + run["covariance"][1, 1]))
        print(f"{name:<8} 2 m   {position_error:8.3f} m            {heading_error:6.2f} deg"
              f"     {sigma:.3f} m")
        viz.plot_trajectories({"true": truth, "odometry": est}, ax=ax,
                              title=f"{name}: error {position_error:.2f} m")
        viz.plot_robot(truth[-1], robots.load(name).footprint, ax=ax)
    fig.tight_layout()
    path = out_dir / "demo_square.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print(f"wrote {path}")
    return 0

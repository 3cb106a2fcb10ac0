"""``kit slam`` on the two ROS 2 bags beside the kit, scored against their worlds' maps.

    .venv/bin/python benchmarks/slam_bags.py [--out out/slam_bags]

The real TurtleBot 4 bag (Olin MAC first floor) against the building's map, and the Gazebo
TurtleBot3 bag against ROBOTIS' map of turtlebot3_world: each bag mapped by the command a user
runs, the map aligned rigidly to the reference (``kit.slam.evaluate.map_agreement``), the share
of the kit map's occupied cells within 0.1 m of the reference's printed, and a PNG with the two
maps side by side and overlaid written per bag. Needs ``../shared/data`` beside the checkout.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from kit import geometry, maps
from kit.cli import main as kit_main
from kit.slam import evaluate

DATA = Path(__file__).resolve().parents[2] / "shared" / "data"
BAGS = {
    "turtlebot4-real": ("ros2-bags/turtlebot4-real-olin-mac-first-floor",
                        "maps/olin-mac-first-floor-real/mac_1st_floor_final.yaml"),
    "turtlebot3-gazebo": ("ros2-bags/turtlebot3-burger-gazebo-walker",
                          "maps/turtlebot3-world-nav2/map.yaml"),
}


def side_by_side(ours, reference, pose, share: float, title: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from kit import viz

    fig, axes = plt.subplots(1, 3, figsize=(16, 5.5))
    viz.plot_grid(ours, ax=axes[0], title="kit slam")
    viz.plot_grid(reference, ax=axes[1], title="reference map")
    theirs = evaluate.occupied_points(reference)
    mine = geometry.transform_points(pose, evaluate.occupied_points(ours))
    axes[2].plot(theirs[:, 0], theirs[:, 1], ",", color="0.5", label="reference")
    axes[2].plot(mine[:, 0], mine[:, 1], ",", color="tab:red", label="kit, aligned")
    axes[2].set_aspect("equal")
    axes[2].set_title(f"{100 * share:.1f} % of the kit's occupied cells within 0.1 m")
    fig.suptitle(title)
    fig.savefig(path, dpi=110, bbox_inches="tight")
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/slam_bags"))
    args = parser.parse_args()
    if not DATA.exists():
        print(f"{DATA} is not there: nothing to measure")
        return 1
    for name, (bag, reference_map) in BAGS.items():
        out = args.out / name
        start = time.perf_counter()
        kit_main(["slam", str(DATA / bag), "--out", str(out), "--quiet"])
        seconds = time.perf_counter() - start
        ours = maps.read_map(out / "map.yaml")
        reference = maps.read_map(DATA / reference_map)
        share, pose = evaluate.map_agreement(ours, reference)
        side_by_side(ours, reference, pose, share, f"{name}: {bag}", out / "side_by_side.png")
        print(f"{name}: kit slam {seconds:.1f} s; {100 * share:.1f} % of the kit map's occupied "
              f"cells within 0.1 m of {reference_map}; wrote {out / 'side_by_side.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

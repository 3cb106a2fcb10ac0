"""SLAM: scan matching, pose graphs, the front end, CARMEN logs and the benchmark metric."""

from kit.slam.pose_graph import (
    OptimizationResult,
    PoseGraph,
    PoseGraphError,
    read_g2o,
    read_toro,
    write_g2o,
    write_toro,
)

__all__ = [
    "OptimizationResult",
    "PoseGraph",
    "PoseGraphError",
    "read_g2o",
    "read_toro",
    "write_g2o",
    "write_toro",
]

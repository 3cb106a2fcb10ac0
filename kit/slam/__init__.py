"""SLAM: scan matching, pose graphs, the SLAM front end, CARMEN logs and the benchmark metric.

* :mod:`~kit.slam.scan_matching` — point-to-line ICP and Olson's correlative matcher;
* :mod:`~kit.slam.pose_graph` — SE(2) pose graphs, Gauss–Newton / Levenberg–Marquardt,
  g2o and TORO files;
* :mod:`~kit.slam.frontend` — graph SLAM in SLAM Toolbox's design, online or over a log;
* :mod:`~kit.slam.carmen`, :mod:`~kit.slam.evaluate` — CARMEN logs, Kümmerle relations and
  their metric.
"""

from kit.slam.carmen import (
    CarmenError,
    CarmenLog,
    LaserRecord,
    Relations,
    laser_to_scan,
    read_carmen,
    read_relations,
)
from kit.slam.evaluate import ErrorSummary, RelationErrors, relation_errors, summarize
from kit.slam.frontend import ScanRecord, Slam, SlamConfig, map_beams, scan_points
from kit.slam.pose_graph import (
    OptimizationResult,
    PoseGraph,
    PoseGraphError,
    chi2,
    edge_error,
    edge_jacobians,
    gauss_newton_step,
    read_g2o,
    read_toro,
    robust_weight,
    write_g2o,
    write_toro,
)
from kit.slam.scan_matching import (
    IcpConfig,
    LikelihoodField,
    MatchResult,
    PointCloudReference,
    correlative_match,
    estimate_normals,
    icp,
    icp_iteration,
    likelihood_field,
)

__all__ = [
    "CarmenError",
    "CarmenLog",
    "ErrorSummary",
    "IcpConfig",
    "LaserRecord",
    "LikelihoodField",
    "MatchResult",
    "OptimizationResult",
    "PointCloudReference",
    "PoseGraph",
    "PoseGraphError",
    "RelationErrors",
    "Relations",
    "ScanRecord",
    "Slam",
    "SlamConfig",
    "chi2",
    "correlative_match",
    "edge_error",
    "edge_jacobians",
    "estimate_normals",
    "gauss_newton_step",
    "icp",
    "icp_iteration",
    "laser_to_scan",
    "likelihood_field",
    "map_beams",
    "read_carmen",
    "read_g2o",
    "read_relations",
    "read_toro",
    "relation_errors",
    "robust_weight",
    "scan_points",
    "summarize",
    "write_g2o",
    "write_toro",
]

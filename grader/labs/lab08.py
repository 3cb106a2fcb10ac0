"""Lab 08 — mapping and SLAM (think): the exercises, their cases and their known mistakes.

Students write the clamped log-odds update, beam endpoints in the map frame, the error of a
pose-graph edge, its Jacobians, and one Gauss–Newton step of a small pose graph; the kit's
:mod:`kit.mapping`, :mod:`kit.geometry` and :mod:`kit.slam.pose_graph` are the references.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import geometry, mapping
from kit.slam import pose_graph as pg

_BLOCKED = (
    "kit.mapping:update_log_odds", "kit.mapping:OccupancyGridMap",
    "kit.slam.pose_graph:edge_error", "kit.slam.pose_graph:edge_jacobians",
    "kit.slam.pose_graph:gauss_newton_step", "kit.slam.pose_graph:PoseGraph",
    "kit.slam.pose_graph:edge_errors", "kit.slam.frontend:scan_points",
    "kit.slam.frontend:map_beams",
)


# ---------------------------------------------------------------- log-odds

def _update(l: Any, change: Any, l_min: float, l_max: float) -> Any:  # noqa: E741
    return mapping.update_log_odds(l, change, l_min, l_max)


def _update_unclamped(l: Any, change: Any, l_min: float, l_max: float) -> Any:  # noqa: E741
    return np.asarray(l, float) + np.asarray(change, float)


def _update_probabilities(l: Any, change: Any, l_min: float, l_max: float) -> Any:  # noqa: E741
    """Probabilities multiplied instead of log-odds added."""
    p = mapping.probability(l) * mapping.probability(change)
    return np.clip(np.log(p / (1 - p)), l_min, l_max)


_MODEL = mapping.InverseSensorModel()
_L = (_MODEL.l_min, _MODEL.l_max)


def _update_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        n = int(rng.integers(5, 12))
        l = rng.uniform(_L[0], _L[1], n)  # noqa: E741
        change = rng.choice([_MODEL.l_occupied, _MODEL.l_free, 0.0], n) * rng.integers(1, 4, n)
        cases.append(Case(f"random {i}", (l, change, *_L)))
    return cases


update_log_odds = Exercise(
    id="lab08.update_log_odds", function="update_log_odds", title="The log-odds update",
    reference=_update, points=2,
    public=(Case("a hit, a pass, nothing", (np.zeros(3), np.array([_MODEL.l_occupied,
                                                                 _MODEL.l_free, 0.0]), *_L)),
            Case("hits on a wall seen for a while", (np.array([3.2, 3.4, -1.9, -1.0]),
                                                     np.array([0.85, 0.85, -0.4, 0.85]),
                                                     *_L))),
    hidden=_update_hidden, rtol=1e-12, atol=1e-12,
    diagnostics=(
        Diagnostic("log-odds not clamped", _update_unclamped,
                   "clamp to [l_min, l_max]: a cell seen as a wall a thousand times must "
                   "still be able to turn free when a door opens"),
        Diagnostic("probabilities multiplied", _update_probabilities,
                   "in log-odds the Bayes update is a sum: l ← l + change, then clamp"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- beam endpoints

def _angles(n: int, angle_min: float, angle_increment: float) -> Any:
    return angle_min + angle_increment * np.arange(n)


def _endpoints(ranges: Any, angle_min: float, angle_increment: float, laser_pose: Any) -> Any:
    r = np.asarray(ranges, dtype=float)
    a = _angles(len(r), angle_min, angle_increment)
    ok = np.isfinite(r)
    points = np.column_stack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])])
    return geometry.transform_points(laser_pose, points)


def _endpoints_not_rotated(ranges: Any, angle_min: float, angle_increment: float,
                           laser_pose: Any) -> Any:
    p = geometry.check_pose(laser_pose)
    return _endpoints(ranges, angle_min, angle_increment, [p[0], p[1], 0.0])


def _endpoints_in_laser_frame(ranges: Any, angle_min: float, angle_increment: float,
                              laser_pose: Any) -> Any:
    return _endpoints(ranges, angle_min, angle_increment, [0.0, 0.0, 0.0])


def _endpoints_with_inf(ranges: Any, angle_min: float, angle_increment: float,
                        laser_pose: Any) -> Any:
    r = np.asarray(ranges, dtype=float)
    a = _angles(len(r), angle_min, angle_increment)
    with np.errstate(invalid="ignore"):
        points = np.column_stack([r * np.cos(a), r * np.sin(a)])
        return geometry.transform_points(laser_pose, points)


def _endpoints_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        n = int(rng.integers(6, 20))
        r = rng.uniform(0.3, 8.0, n)
        r[rng.random(n) < 0.2] = np.inf
        pose = [float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)),
                float(rng.uniform(-np.pi, np.pi))]
        cases.append(Case(f"random {i}", (r, float(-np.pi / 2), float(np.pi / (n - 1)), pose)))
    return cases


beam_endpoints = Exercise(
    id="lab08.beam_endpoints", function="beam_endpoints", title="Beams into the map frame",
    reference=_endpoints, points=2,
    public=(Case("three beams, laser turned left", (np.array([1.0, 2.0, 1.5]), -np.pi / 2,
                                                    np.pi / 2, [1.0, 2.0, np.pi / 2])),
            Case("an inf beam is not a point", (np.array([2.0, np.inf, 3.0, 4.0]), 0.0, 0.5,
                                                [-1.0, 0.5, 2.5]))),
    hidden=_endpoints_hidden, rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("the laser's heading ignored", _endpoints_not_rotated,
                   "rotate the points by the laser's heading θ before adding its position: "
                   "p_map = R(θ) p_laser + t"),
        Diagnostic("points left in the laser's frame", _endpoints_in_laser_frame,
                   "the beams are measured in the laser's frame: transform them by the "
                   "laser's pose in the map"),
        Diagnostic("inf ranges made into points", _endpoints_with_inf,
                   "REP-117: an inf range saw nothing within range_max; it is not an "
                   "obstacle point — leave it out"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- edge error

def _edge_error(x_i: Any, x_j: Any, z: Any) -> Any:
    return pg.edge_error(x_i, x_j, z)


def _edge_error_unwrapped(x_i: Any, x_j: Any, z: Any) -> Any:
    e = pg.edge_error(x_i, x_j, z)
    raw = (float(x_j[2]) - float(x_i[2])) - float(z[2])
    return np.array([e[0], e[1], raw])


def _edge_error_difference(x_i: Any, x_j: Any, z: Any) -> Any:
    """The measurement subtracted in the world frame: (x_j − x_i) − z."""
    return np.asarray(x_j, float) - np.asarray(x_i, float) - np.asarray(z, float)


def _pose(rng: np.random.Generator, spread: float = 3.0) -> list[float]:
    return [float(rng.uniform(-spread, spread)), float(rng.uniform(-spread, spread)),
            float(rng.uniform(-np.pi, np.pi))]


def _edge_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (_pose(rng), _pose(rng), _pose(rng, 1.0))) for i in range(4)]


edge_error = Exercise(
    id="lab08.edge_error", function="edge_error", title="The error of an edge",
    reference=_edge_error, points=2,
    public=(Case("a perfect measurement", ([0.0, 0.0, 0.0], [1.0, 0.0, np.pi / 2],
                                           [1.0, 0.0, np.pi / 2])),
            Case("10 cm short, node i turned", ([0.0, 0.0, np.pi / 2], [0.0, 1.0, np.pi / 2],
                                               [0.9, 0.0, 0.0])),
            Case("across ±π", ([2.0, 1.0, 3.0], [1.0, 1.2, -3.0], [-1.0, 0.1, 0.25]))),
    hidden=_edge_hidden, rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("angle residual not wrapped", _edge_error_unwrapped,
                   "wrap the angle of the error to [-π, π): θ_j − θ_i − θ_z can be near ±2π "
                   "for a small error"),
        Diagnostic("poses subtracted in the world frame", _edge_error_difference,
                   "the measurement is node j seen from node i: e = t2v(Z⁻¹ (X_i⁻¹ X_j)), "
                   "not x_j − x_i − z"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- Jacobians

def _jacobians(x_i: Any, x_j: Any, z: Any) -> Any:
    return pg.edge_jacobians(x_i, x_j, z)


def _jacobians_transposed(x_i: Any, x_j: Any, z: Any) -> Any:
    A, B = pg.edge_jacobians(x_i, x_j, z)
    return A.T, B.T


def _jacobians_swapped(x_i: Any, x_j: Any, z: Any) -> Any:
    A, B = pg.edge_jacobians(x_i, x_j, z)
    return B, A


edge_jacobians = Exercise(
    id="lab08.edge_jacobians", function="edge_jacobians", title="The Jacobians of an edge",
    reference=_jacobians, points=3,
    public=(Case("node i turned a quarter", ([0.0, 0.0, np.pi / 2], [0.0, 1.0, np.pi / 2],
                                             [0.9, 0.0, 0.0])),
            Case("a general edge", ([1.0, -0.5, 0.3], [2.5, 0.7, 1.1], [1.8, 0.6, 0.75]))),
    hidden=_edge_hidden, rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("Jacobians transposed", _jacobians_transposed,
                   "A[r, c] = ∂e_r / ∂x_i[c]: rows are the error's components, columns the "
                   "pose's (x, y, θ)"),
        Diagnostic("A and B swapped", _jacobians_swapped,
                   "return (A, B) = (∂e/∂x_i, ∂e/∂x_j): A carries the minus signs"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- a Gauss–Newton step

def _graph(poses: Any, edges: Any, invert: bool = False) -> pg.PoseGraph:
    graph = pg.PoseGraph()
    for p in np.asarray(poses, dtype=float):
        graph.add_node(p)
    for i, j, z, omega in edges:
        om = np.asarray(omega, dtype=float)
        graph.add_edge(int(i), int(j), z, np.linalg.inv(om) if invert else om)
    return graph


def _gn_step(poses: Any, edges: Any) -> Any:
    return pg.gauss_newton_step(_graph(poses, edges))


def _gn_information_inverted(poses: Any, edges: Any) -> Any:
    return pg.gauss_newton_step(_graph(poses, edges, invert=True))


def _gn_gradient_sign(poses: Any, edges: Any) -> Any:
    """H Δx = +g: the step goes uphill."""
    x = np.asarray(poses, dtype=float)
    new = pg.gauss_newton_step(_graph(poses, edges))
    back = x - (new - x)
    back[:, 2] = geometry.wrap_angle(back[:, 2])
    back[0] = x[0]
    return back


def _loop(rng: np.random.Generator | None, n: int, noise: float) -> tuple[Any, list[Any]]:
    """n poses round a square-ish loop, odometry edges and one loop closure, the initial
    guess perturbed by ``noise``; anisotropic information matrices."""
    angles = np.linspace(0, 2 * np.pi, n, endpoint=False)
    truth = np.column_stack([2 * np.cos(angles), 2 * np.sin(angles), angles + np.pi / 2])
    truth[:, 2] = geometry.wrap_angle(truth[:, 2])
    info = np.diag([100.0, 50.0, 400.0])
    edges = [(k, k + 1, geometry.relative(truth[k], truth[k + 1]), info) for k in range(n - 1)]
    edges.append((n - 1, 0, geometry.relative(truth[n - 1], truth[0]), np.diag([20.0, 20.0,
                                                                                100.0])))
    shake = (np.zeros((n, 3)) if rng is None else rng.normal(0, noise, (n, 3)))
    guess = truth + shake
    if rng is None:
        guess += np.outer(np.arange(n), [0.05, -0.03, 0.02])       # drift, growing
    guess[0] = truth[0]
    guess[:, 2] = geometry.wrap_angle(guess[:, 2])
    return guess, edges


def _gn_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(2):
        poses, edges = _loop(rng, int(rng.integers(4, 8)), float(rng.uniform(0.05, 0.2)))
        cases.append(Case(f"random loop {i}", (poses, edges)))
    return cases


_THREE = (np.array([[0.0, 0.0, 0.0], [1.1, 0.0, 0.0], [2.1, 0.1, 0.0]]),
          [(0, 1, [1.0, 0.0, 0.0], np.eye(3)), (1, 2, [1.0, 0.0, 0.0], np.eye(3))])

gauss_newton_step = Exercise(
    id="lab08.gauss_newton_step", function="gauss_newton_step",
    title="One Gauss–Newton step of a pose graph", reference=_gn_step, points=3,
    public=(Case("three nodes in a row", _THREE),
            Case("a drifted loop of six", _loop(None, 6, 0.0))),
    hidden=_gn_hidden, rtol=1e-7, atol=1e-9,
    diagnostics=(
        Diagnostic("information matrix inverted", _gn_information_inverted,
                   "Ω is the information (the inverse covariance): weigh by Ω itself, "
                   "H += Aᵀ Ω A, b += Aᵀ Ω e"),
        Diagnostic("the step taken uphill", _gn_gradient_sign,
                   "solve H Δx = −b (b = Σ Jᵀ Ω e): the step goes against the gradient"),
    ),
    blocked=_BLOCKED,
)


SPEC = LabSpec(name="lab08", title="Mapping and SLAM",
               exercises=(update_log_odds, beam_endpoints, edge_error, edge_jacobians,
                          gauss_newton_step))

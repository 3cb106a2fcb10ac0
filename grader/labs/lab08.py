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
    """Random cells, and in every case a cell at each clamp (or within one update of it)
    that the change pushes further out: a wall seen again, a free cell passed again."""
    cases = []
    for i in range(3):
        n = int(rng.integers(5, 12))
        l = rng.uniform(_L[0], _L[1], n)  # noqa: E741
        change = rng.choice([_MODEL.l_occupied, _MODEL.l_free, 0.0], n) * rng.integers(1, 4, n)
        top, bottom = rng.choice(n, 2, replace=False)
        l[top] = _L[1] - float(rng.uniform(0.0, 0.5)) * _MODEL.l_occupied
        change[top] = _MODEL.l_occupied * int(rng.integers(1, 4))
        l[bottom] = _L[0] - float(rng.uniform(0.0, 0.5)) * _MODEL.l_free
        change[bottom] = _MODEL.l_free * int(rng.integers(1, 4))
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
                   "add, then clamp to [l_min, l_max] (the sum l + change): a cell seen as a "
                   "wall a thousand times must still be able to turn free when a door opens"),
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


def _endpoints_rotated_back(ranges: Any, angle_min: float, angle_increment: float,
                            laser_pose: Any) -> Any:
    """Rᵀ in place of R: turned by −θ, then the laser's position added."""
    p = geometry.check_pose(laser_pose)
    local = _endpoints(ranges, angle_min, angle_increment, [0.0, 0.0, -p[2]])
    return local + p[:2]


def _endpoints_from_one(ranges: Any, angle_min: float, angle_increment: float,
                        laser_pose: Any) -> Any:
    return _endpoints(ranges, angle_min + angle_increment, angle_increment, laser_pose)


def _endpoints_hidden(rng: np.random.Generator) -> list[Case]:
    """The laser heading near ±π/2, near ±π and anywhere; inf beams in every case."""
    headings = [float(rng.choice([-1.0, 1.0])) * (np.pi / 2 + float(rng.uniform(-0.3, 0.3))),
                float(rng.choice([-1.0, 1.0])) * (np.pi - float(rng.uniform(0.0, 0.1))),
                float(rng.uniform(-np.pi, np.pi))]
    cases = []
    for i, heading in enumerate(headings):
        n = int(rng.integers(6, 20))
        r = rng.uniform(0.3, 8.0, n)
        r[rng.random(n) < 0.2] = np.inf
        r[int(rng.integers(1, n))] = np.inf
        pose = [float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)), heading]
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
        Diagnostic("Rᵀ in place of R", _endpoints_rotated_back,
                   "the beams turned by −θ: into the map frame a point goes by "
                   "R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]], then + (x, y)"),
        Diagnostic("the first beam at angle_min + angle_increment", _endpoints_from_one,
                   "beam k = 0 leaves at angle_min itself: α_k = angle_min + k · "
                   "angle_increment, k = 0 … N − 1"),
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


def _edge_error_order_swapped(x_i: Any, x_j: Any, z: Any) -> Any:
    """t2v((X_i⁻¹ X_j)⁻¹ Z): the residual inverted."""
    return geometry.relative(geometry.relative(x_i, x_j), z)


def _edge_error_not_transposed(x_i: Any, x_j: Any, z: Any) -> Any:
    """X_i⁻¹ X_j written with R(θ_i) where R(θ_i)ᵀ belongs."""
    a, b = geometry.check_pose(x_i), geometry.check_pose(x_j)
    seen = geometry.transform_points([0.0, 0.0, a[2]], (b[:2] - a[:2])[None, :])[0]
    return geometry.relative(z, [seen[0], seen[1], b[2] - a[2]])


def _pose(rng: np.random.Generator, spread: float = 3.0) -> list[float]:
    return [float(rng.uniform(-spread, spread)), float(rng.uniform(-spread, spread)),
            float(rng.uniform(-np.pi, np.pi))]


def _edge_hidden(rng: np.random.Generator) -> list[Case]:
    """Two random edges, and two whose nodes face across ±π with a measurement that nearly
    agrees (the angle's residual is small once wrapped and near ±2π before); node i never
    faces along an axis."""
    cases = []
    for i in range(2):
        side = float(rng.choice([-1.0, 1.0]))
        x_i = _pose(rng)
        x_i[2] = side * (np.pi - float(rng.uniform(0.05, 0.3)))
        x_j = _pose(rng)
        x_j[2] = -side * (np.pi - float(rng.uniform(0.05, 0.3)))
        true = geometry.relative(x_i, x_j)
        z = [float(true[0] + rng.normal(0, 0.1)), float(true[1] + rng.normal(0, 0.1)),
             float(geometry.wrap_angle(true[2] + rng.normal(0, 0.05)))]
        cases.append(Case(f"random {i}", (x_i, x_j, z)))
    return cases + [Case(f"random {i}", (_pose(rng), _pose(rng), _pose(rng, 1.0)))
                    for i in (2, 3)]


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
        Diagnostic("the other transform inverted", _edge_error_order_swapped,
                   "e = t2v(Z⁻¹ · (X_i⁻¹ X_j)): invert the measurement Z and compose it with "
                   "node j seen from node i; inverting X_i⁻¹ X_j instead gives the residual's "
                   "inverse (its signs flip)"),
        Diagnostic("R(θ_i) in place of its transpose", _edge_error_not_transposed,
                   "node j seen from node i is R(θ_i)ᵀ (t_j − t_i): X_i⁻¹ rotates by −θ_i"),
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


def _gn_system(poses: Any, edges: Any) -> tuple[Any, Any]:
    """H and b of the whole graph (every node, none fixed)."""
    x = np.asarray(poses, dtype=float)
    n = len(x)
    H, b = np.zeros((3 * n, 3 * n)), np.zeros(3 * n)
    for i, j, z, omega in edges:
        om = np.asarray(omega, dtype=float)
        e = pg.edge_error(x[i], x[j], z)
        blocks = tuple(zip((int(i), int(j)), pg.edge_jacobians(x[i], x[j], z), strict=True))
        for p, P in blocks:
            b[3 * p:3 * p + 3] += P.T @ om @ e
            for q, Q in blocks:
                H[3 * p:3 * p + 3, 3 * q:3 * q + 3] += P.T @ om @ Q
    return H, b


def _gn_unwrapped(poses: Any, edges: Any) -> Any:
    """x + Δx with the angles left as they come out of the sum."""
    x = np.asarray(poses, dtype=float)
    H, b = _gn_system(poses, edges)
    dx = np.zeros(len(b))
    dx[3:] = np.linalg.solve(H[3:, 3:], -b[3:])
    return x + dx.reshape(-1, 3)


def _gn_free(poses: Any, edges: Any) -> Any:
    """Every node free: the least-squares (pseudo-inverse) step of the singular system,
    which moves node 0 too."""
    x = np.asarray(poses, dtype=float)
    H, b = _gn_system(poses, edges)
    new = x + (np.linalg.pinv(H) @ -b).reshape(-1, 3)
    new[:, 2] = geometry.wrap_angle(new[:, 2])
    return new


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


def _across_pi(rng: np.random.Generator) -> tuple[Any, list[Any]]:
    """A chain of nodes heading near ±π whose odometry says that node k turned just past π,
    while the initial guess leaves it just short of π: the step carries its angle across ±π
    (and leaves the other nodes' angles where they are)."""
    n = int(rng.integers(3, 6))
    k = int(rng.integers(1, n))                          # the node that crosses
    side = float(rng.choice([-1.0, 1.0]))
    truth = np.zeros((n, 3))
    truth[0, 2] = side * (np.pi - float(rng.uniform(0.1, 0.3)))
    past = side * (np.pi + float(rng.uniform(0.03, 0.1)))          # node k's true heading
    for m in range(1, n):
        turn = past - truth[m - 1, 2] if m == k else float(rng.uniform(-0.05, 0.05))
        truth[m] = geometry.compose(truth[m - 1], [float(rng.uniform(0.5, 1.5)),
                                                   float(rng.uniform(-0.1, 0.1)), turn])
    info = np.diag([100.0, 50.0, 400.0])
    edges = [(m, m + 1, geometry.relative(truth[m], truth[m + 1]), info) for m in range(n - 1)]
    guess = truth + np.column_stack([rng.normal(0, 0.05, (n, 2)), np.zeros(n)])
    guess[0] = truth[0]
    guess[k, 2] = side * (np.pi - float(rng.uniform(0.03, 0.1)))
    return guess, edges


def _gn_hidden(rng: np.random.Generator) -> list[Case]:
    """A chain that carries an angle across ±π, and two drifted loops."""
    cases = [Case("random chain", _across_pi(rng))]
    for i in range(2):
        poses, edges = _loop(rng, int(rng.integers(4, 8)), float(rng.uniform(0.05, 0.2)))
        cases.append(Case(f"random loop {i}", (poses, edges)))
    return cases


_THREE = (np.array([[0.0, 0.0, 0.0], [1.1, 0.0, 0.0], [2.1, 0.1, 0.0]]),
          [(0, 1, [1.0, 0.0, 0.0], np.eye(3)), (1, 2, [1.0, 0.0, 0.0], np.eye(3))])
_THROUGH_PI = (np.array([[0.0, 0.0, 3.0], [1.0, 0.1, 3.1], [2.0, 0.0, -3.0]]),
               [(0, 1, [1.0, 0.0, 0.2], np.eye(3)), (1, 2, [1.0, 0.0, 0.0], np.eye(3))])

gauss_newton_step = Exercise(
    id="lab08.gauss_newton_step", function="gauss_newton_step",
    title="One Gauss–Newton step of a pose graph", reference=_gn_step, points=3,
    public=(Case("three nodes in a row", _THREE),
            Case("a drifted loop of six", _loop(None, 6, 0.0)),
            Case("turning through ±π", _THROUGH_PI)),
    hidden=_gn_hidden, rtol=1e-7, atol=1e-9,
    diagnostics=(
        Diagnostic("information matrix inverted", _gn_information_inverted,
                   "Ω is the information (the inverse covariance): weigh by Ω itself, "
                   "H += Aᵀ Ω A, b += Aᵀ Ω e"),
        Diagnostic("the step taken uphill", _gn_gradient_sign,
                   "solve H Δx = −b (b = Σ Jᵀ Ω e): the step goes against the gradient"),
        Diagnostic("angles not wrapped after the step", _gn_unwrapped,
                   "wrap every θ of x + Δx to [-π, π): a node that turns past π must come "
                   "out near −π"),
        Diagnostic("node 0 not held fixed", _gn_free,
                   "the graph only knows relative poses, so H is singular: hold node 0 "
                   "fixed — solve H[3:, 3:] Δx[3:] = −b[3:] and leave Δx[:3] = 0"),
    ),
    blocked=_BLOCKED,
    uses=("edge_error", "edge_jacobians"),
)


SPEC = LabSpec(name="lab08", title="Mapping and SLAM",
               exercises=(update_log_odds, beam_endpoints, edge_error, edge_jacobians,
                          gauss_newton_step))

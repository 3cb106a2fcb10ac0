"""PoseGraph.optimize with a Gauss–Newton step handed in as a function (a lab's): the
textbook's dense step reaches the sparse solver's optimum — robust kernels included, as
reweighted least squares — and a step that cannot work is refused with its reason."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import geometry
from kit.slam import PoseGraph
from kit.slam.pose_graph import edge_error, edge_jacobians


def dense_step(poses, edges):
    """Grisetti et al.'s tutorial, written out: H and b from every edge, node 0 fixed."""
    x = np.asarray(poses, float)
    n = len(x)
    H, b = np.zeros((3 * n, 3 * n)), np.zeros(3 * n)
    for i, j, z, omega in edges:
        e = edge_error(x[i], x[j], z)
        A, B = edge_jacobians(x[i], x[j], z)
        J = np.zeros((3, 3 * n))
        J[:, 3 * i:3 * i + 3], J[:, 3 * j:3 * j + 3] = A, B
        H += J.T @ omega @ J
        b += J.T @ omega @ e
    dx = np.zeros(3 * n)
    dx[3:] = np.linalg.solve(H[3:, 3:], -b[3:])
    new = x + dx.reshape(n, 3)
    new[:, 2] = geometry.wrap_angle(new[:, 2])
    return new


def loop(kernel: str) -> PoseGraph:
    """Twelve nodes round a circle, odometry drifting, one loop closure (under ``kernel``)
    and one wrong closure that a robust kernel should mostly ignore."""
    angles = np.linspace(0, 2 * math.pi, 12, endpoint=False)
    truth = np.column_stack([3 * np.cos(angles), 3 * np.sin(angles),
                             geometry.wrap_angle(angles + math.pi / 2)])
    graph = PoseGraph()
    for k, pose in enumerate(truth):
        graph.add_node(pose + np.array([0.04, -0.03, 0.02]) * k)
    info = np.diag([100.0, 100.0, 400.0])
    for k in range(11):
        graph.add_edge(k, k + 1, geometry.relative(truth[k], truth[k + 1]), info)
    graph.add_edge(11, 0, geometry.relative(truth[11], truth[0]), info, kernel=kernel)
    graph.add_edge(3, 9, [0.5, 0.0, 0.0], info, kernel=kernel, delta=1.0)   # wrong
    return graph


@pytest.mark.parametrize("kernel", ["none", "cauchy", "huber"])
def test_the_textbooks_dense_step_reaches_the_sparse_solvers_optimum(kernel):
    sparse, dense = loop(kernel), loop(kernel)
    a = sparse.optimize("gn", max_iterations=100, tolerance=1e-14)
    b = dense.optimize("gn", max_iterations=100, tolerance=1e-14, step=dense_step)
    assert a.converged and b.converged
    np.testing.assert_allclose(dense.poses, sparse.poses, atol=1e-7)
    assert b.cost == pytest.approx(a.cost, rel=1e-9)
    assert b.history[0] == pytest.approx(a.history[0], rel=1e-12)


def test_a_step_that_goes_uphill_does_not_lower_the_cost():
    def uphill(poses, edges):
        x = np.asarray(poses, float)
        return 2 * x - dense_step(poses, edges)

    graph = loop("none")
    result = graph.optimize("gn", max_iterations=3, step=uphill)
    assert result.cost > result.initial_cost


def test_steps_that_cannot_work_are_refused():
    graph = loop("none")
    with pytest.raises(ValueError, match="shape"):
        graph.optimize(step=lambda poses, edges: poses[1:])
    with pytest.raises(ValueError, match="NaN"):
        graph.optimize(step=lambda poses, edges: poses * np.nan)
    with pytest.raises(ValueError, match="method 'gn'"):
        graph.optimize("lm", step=dense_step)
    graph.fixed = {0, 5}
    with pytest.raises(ValueError, match="node 0"):
        graph.optimize(step=dense_step)

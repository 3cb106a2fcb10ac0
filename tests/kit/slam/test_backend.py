"""The SLAM back end on a synthetic loop: closures wait for one that agrees, a closure
nothing confirms expires, a wrong pair is outvoted by a larger group that agrees with the
rest of the graph, a match edge the rest of the graph disagrees with leaves it, closures still
waiting when the run ends are settled; and the pairwise agreement test of two closures."""

from __future__ import annotations

import numpy as np
import pytest

from kit import geometry
from kit.slam.backend import Backend
from kit.slam.config import SlamConfig
from kit.slam.loops import LoopClosure, agree

N = 60
"""Nodes around the loop: 0.5 m apart on a circle of 60 / (2π) · 0.5 ≈ 4.8 m radius."""


def circle() -> np.ndarray:
    truth = np.zeros((N, 3))
    for k in range(1, N):
        truth[k] = geometry.compose(truth[k - 1], [0.5, 0.0, 2 * np.pi / N])
    return truth


def backend(truth: np.ndarray, drift: float = 0.0015, variance: float = 1e-5) -> Backend:
    """The map before any closure: nodes where scan matching put them — every match turned
    ``drift`` [rad] too far, within what its covariance allows — joined by those match edges
    and by the odometry's edges (which turn the other way); ``variance`` [m²] is the
    matches' positional variance (a tenth of it in rad² for the heading)."""
    b = Backend(SlamConfig())
    pose = truth[0].copy()
    b.graph.add_node(pose)
    for k in range(1, N):
        z = geometry.relative(truth[k - 1], truth[k])
        matched = z + np.array([0.0, 0.0, drift])
        pose = geometry.compose(pose, matched)
        b.graph.add_node(pose)
        b.add_odometry(k - 1, k, z - np.array([0.0, 0.0, drift]), 0.05, np.radians(1.0))
        b.add_match(k - 1, k, matched, np.diag([variance, variance, variance / 10]))
    return b


def closure(truth: np.ndarray, node: int, reference: int, error=(0.0, 0.0, 0.0)
            ) -> LoopClosure:
    record = LoopClosure(node, reference, reference=reference)
    record.measurement = geometry.compose(geometry.relative(truth[reference], truth[node]),
                                          np.asarray(error, dtype=float))
    record.covariance = np.diag([1e-4, 1e-4, 1e-5])
    return record


def test_a_lone_closure_waits_for_one_that_agrees_and_both_enter_together():
    truth = circle()
    b = backend(truth)
    start = np.hypot(*(b.graph.poses[N - 1, :2] - truth[N - 1, :2]))
    first, second = closure(truth, N - 2, 1), closure(truth, N - 1, 2)
    assert not b.propose(first)
    assert not first.accepted and first.reason.startswith("pending")
    assert b.graph.num_edges == 2 * (N - 1)          # nothing entered yet
    assert b.propose(second)
    assert first.accepted and second.accepted and first.group == second.group
    assert b.loop_closures == [(1, N - 2), (2, N - 1)]
    end = np.hypot(*(b.graph.poses[N - 1, :2] - truth[N - 1, :2]))
    assert first.surprise <= SlamConfig().loop_gate   # one confirmation is enough
    assert start > 0.3 and end < 0.05                 # the loop is closed
    assert first.chi2 < SlamConfig().closure_chi2


def test_a_closure_nothing_agrees_with_expires():
    truth = circle()
    b = backend(truth)
    lonely = closure(truth, 30, 5)
    b.propose(lonely)
    other = closure(truth, 30 + SlamConfig().loop_pending_nodes + 1, 10, (0.8, 0.0, 0.0))
    b.propose(other)
    assert not lonely.accepted
    assert lonely.reason.startswith("no other closure agreed")


def test_a_wrong_group_is_outvoted_by_a_larger_group_that_agrees_with_the_rest():
    """Three closures that agree with each other but are 0.6 m off (a place that looks
    like another: surprising, so each waited for two more) enter first; the right ones that
    come later disagree with them where the graph between them is local, wait until they
    outnumber them, then replace them (the rejected named why)."""
    truth = circle()
    b = backend(truth)
    wrong = [closure(truth, n, n - 28, (0.6, 0.0, 0.0)) for n in (40, 41, 42)]
    for record in wrong:
        b.propose(record)
    assert all(r.accepted for r in wrong) and wrong[0].surprise > SlamConfig().loop_gate
    right = [closure(truth, n, n - 28) for n in (44, 45, 46, 47)]
    for record in right[:3]:
        b.propose(record)
    assert all(r.accepted for r in wrong)          # three against three: nothing changes
    assert "disagrees with 3 closure(s)" in right[2].reason
    b.propose(right[3])
    assert sum(r.accepted for r in right) >= 3
    assert not any(r.accepted for r in wrong)
    assert all(r.reason.startswith("conflicts with the closures") for r in wrong)
    error = np.hypot(*(geometry.relative(b.graph.poses[12], b.graph.poses[40])[:2] -
                       geometry.relative(truth[12], truth[40])[:2]))
    assert error < 0.1                             # the wrong ones asked for 0.6 m


def test_at_the_runs_end_an_expected_lone_closure_enters_and_a_surprising_one_does_not():
    """The log ends before a closure's partner comes: :meth:`Backend.settle` lets in the
    one the graph already expects (Mahalanobis² within ``loop_gate``), which closes the
    loop; one that asks the map to move 0.8 m past where the graph has it stays out, with
    the reason."""
    truth = circle()
    b = backend(truth)
    start = np.hypot(*(b.graph.poses[N - 1, :2] - truth[N - 1, :2]))
    last = closure(truth, N - 1, 1)
    assert not b.propose(last) and last.reason.startswith("pending")
    assert b.settle() == 1
    assert last.accepted and last.reason == ""
    assert last.surprise <= SlamConfig().loop_gate
    assert start > 0.3 and np.hypot(*(b.graph.poses[N - 1, :2] - truth[N - 1, :2])) < 0.05
    assert b.settle() == 0                                      # nothing waits any more

    other = backend(truth)
    wrong = closure(truth, N - 1, 1, (0.8, 0.0, 0.0))
    other.propose(wrong)
    edges = other.graph.num_edges
    assert other.settle() == 0
    assert not wrong.accepted and wrong.surprise > SlamConfig().loop_gate
    assert wrong.reason.startswith("the run ended before another closure agreed")
    assert other.graph.num_edges == edges


def test_a_match_edge_the_closures_disagree_with_leaves_the_graph():
    """A match that put node 30 0.8 m off (with a confident covariance): once closures pin
    both sides of it, its χ² stands out and it is dropped; the odometry's edge beside it
    keeps the chain, and the nodes after it come back."""
    truth = circle()
    b = Backend(SlamConfig())
    pose = truth[0].copy()
    b.graph.add_node(pose)
    for k in range(1, N):
        z = geometry.relative(truth[k - 1], truth[k])
        measured = z + np.array([0.8, 0.0, 0.0]) if k == 30 else z
        pose = geometry.compose(pose, measured)
        b.graph.add_node(pose)
        b.add_odometry(k - 1, k, z, 0.05, np.radians(1.0))
        b.add_match(k - 1, k, measured, np.diag([1e-5, 1e-5, 1e-6]))
    for node, reference in ((N - 2, 1), (N - 1, 2), (45, 15), (46, 16)):
        b.propose(closure(truth, node, reference))
    assert 30 in b.replaced_matches
    error = np.hypot(*(b.graph.poses[45, :2] - truth[45, :2]))
    assert error < 0.05


def test_two_closures_agree_when_their_loop_closes():
    truth = circle()
    a, same = closure(truth, 40, 12), closure(truth, 44, 16)
    shifted = closure(truth, 44, 16, (0.3, 0.0, 0.0))
    tolerance = SlamConfig().loop_consistency
    assert agree(a, same, truth, tolerance)
    assert not agree(a, shifted, truth, tolerance)
    turned = closure(truth, 44, 16, (0.0, 0.0, np.radians(5)))
    assert not agree(a, turned, truth, tolerance)


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="closure_chi2"):
        SlamConfig(closure_chi2=0)
    with pytest.raises(ValueError, match="dynamic_margin"):
        SlamConfig(dynamic_margin=-0.1)

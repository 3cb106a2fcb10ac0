"""The SLAM back end: the pose graph, what each of its edges is, and the checks that keep a
bad edge from bending the map.

Every pair of consecutive nodes is joined by the odometry's edge and, when the scan matched,
by the match's; loop closures join old nodes to new ones. All three kinds sit under a
Cauchy kernel. Closures enter in groups: a closure waits (``loop_pending_nodes``) until
another closure agrees with it (:func:`kit.slam.loops.agree`), two others when it is
*surprising* — its Mahalanobis distance² from the graph's estimate, under the graph's
marginal covariance of the two nodes' relative pose plus its own, above ``loop_gate``.

After every solve each edge's χ² is checked: the worst edge over its bound leaves the graph
(a closure over ``closure_chi2`` is rejected; a match edge over ``match_chi2`` is dropped,
the odometry's edge beside it keeps the chain) and the graph is solved again, until every
edge agrees with the rest. A new group that leaves closures accepted earlier over their
bound means one side is wrong — a place that looks like another — and the side with more
closures agreeing with the rest of the graph stays (:meth:`Backend.resolve`), the sense of
Olson's single-cluster graph partitioning and of pairwise-consistency maximisation.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry
from kit.slam.loops import LoopClosure, agree
from kit.slam.pose_graph import PoseGraph

if TYPE_CHECKING:
    from kit.slam.config import SlamConfig

__all__ = ["Backend", "solve"]

FloatArray = NDArray[np.float64]


def solve(graph: PoseGraph, iterations: int, tolerance: float) -> None:
    """Gauss–Newton first with every kernel off (plain least squares, whose basin is wide
    enough for a closure that moves the map far), then with the kernels on."""
    graph.optimize("gn", max_iterations=iterations, tolerance=tolerance, robust=False)
    graph.optimize("gn", max_iterations=iterations, tolerance=tolerance)


class Backend:
    """The graph of a :class:`kit.slam.Slam` and the bookkeeping of its edges.

    Attributes
    ----------
    graph : PoseGraph
    closures : list of LoopClosure
        Every loop-closure attempt, accepted or not, in the order they were made.
    replaced_matches : list of int
        Nodes whose match edge was dropped after a solve (its χ² over ``match_chi2``).
    """

    def __init__(self, config: SlamConfig) -> None:
        self.config = config
        self.graph = PoseGraph()
        self.closures: list[LoopClosure] = []
        self.replaced_matches: list[int] = []
        self._kind: list[str] = []       # per graph edge: "match", "odometry" or "closure"
        self._closure: list[int] = []    # its index in self.closures (closures), else −1
        self._pending: list[LoopClosure] = []
        self._groups = 0

    # ------------------------------------------------------------------ edges
    def information(self, covariance: ArrayLike) -> FloatArray:
        """``(k Σ + diag(floor²))⁻¹``: a matcher's covariance scaled by
        ``match_covariance_scale`` and its standard deviations floored at
        ``min_edge_sigma``."""
        sd_xy, sd_th = self.config.min_edge_sigma
        k = self.config.match_covariance_scale
        c = np.asarray(covariance, dtype=np.float64)
        cov = 0.5 * k * (c + c.T) + np.diag([sd_xy**2, sd_xy**2, sd_th**2])
        return np.asarray(np.linalg.inv(cov))

    def add_match(self, i: int, j: int, measurement: ArrayLike, covariance: ArrayLike) -> None:
        """Node ``j`` seen from node ``i`` as the scan match says (covariance in ``i``'s
        frame)."""
        self.graph.add_edge(i, j, measurement, self.information(covariance), kernel="cauchy",
                            delta=self.config.match_kernel_delta)
        self._kind.append("match")
        self._closure.append(-1)

    def add_odometry(self, i: int, j: int, measurement: ArrayLike, sd_xy: float,
                     sd_theta: float) -> None:
        """Node ``j`` seen from node ``i`` as the odometry says, trusted to ``sd_xy`` [m]
        and ``sd_theta`` [rad]."""
        self.graph.add_edge(i, j, measurement,
                            np.diag([1 / sd_xy**2, 1 / sd_xy**2, 1 / sd_theta**2]),
                            kernel="cauchy", delta=self.config.odometry_kernel_delta)
        self._kind.append("odometry")
        self._closure.append(-1)

    # ------------------------------------------------------------------ closures
    @property
    def loop_closures(self) -> list[tuple[int, int]]:
        """``(reference node, node)`` of every closure in the graph now."""
        return [(c.reference, c.node) for c in self.closures if c.accepted]

    def propose(self, record: LoopClosure) -> bool:
        """A closure that passed the matcher's gates (``record.reference``,
        ``measurement`` and ``covariance`` set): it waits for agreeing closures, then enters
        the graph with them and the graph is solved. Returns whether the graph was solved
        (``record.accepted`` says whether the closure stayed in it)."""
        cfg = self.config
        self.closures.append(record)
        estimate, spread = self.graph.relative_marginal(record.reference, record.node)
        e = geometry.relative(estimate, record.measurement)
        own = np.linalg.inv(self.information(record.covariance))
        record.surprise = float(e @ np.linalg.solve(spread + own, e))
        for p in self._pending:
            if record.node - p.node > cfg.loop_pending_nodes:
                p.reason = (f"no other closure agreed within {cfg.loop_pending_nodes} nodes "
                            f"(Mahalanobis² {p.surprise:.0f})")
        self._pending = [p for p in self._pending
                         if record.node - p.node <= cfg.loop_pending_nodes]
        poses = self.graph.poses
        group = [p for p in self._pending
                 if agree(p, record, poses, cfg.loop_consistency)] + [record]
        needed = cfg.loop_confirmations + int(record.surprise > cfg.loop_gate)
        if len(group) <= needed:
            record.reason = (f"pending: awaits {needed} closure(s) that agree (Mahalanobis² "
                             f"{record.surprise:.0f})")
            self._pending.append(record)
            return False
        self._groups += 1
        for c in group:
            c.accepted, c.reason, c.group = True, "", self._groups
            if any(c is p for p in self._pending):
                self._pending = [p for p in self._pending if p is not c]
            self.graph.add_edge(c.reference, c.node, c.measurement,
                                self.information(c.covariance), kernel="cauchy",
                                delta=cfg.loop_kernel_delta)
            self._kind.append("closure")
            self._closure.append(next(k for k, x in enumerate(self.closures) if x is c))
        self.optimise(10, 1e-6, group)
        return True

    # ------------------------------------------------------------------ solving
    def optimise(self, iterations: int, tolerance: float,
                 group: list[LoopClosure] | None = None) -> None:
        """Solve the graph, then drop the worst edge over its χ² bound and solve again,
        until none is; a new ``group`` of closures is first weighed against older ones it
        conflicts with (:meth:`resolve`)."""
        cfg = self.config
        solve(self.graph, iterations, tolerance)
        if group:
            self.resolve(group, iterations, tolerance)
        for _ in range(len(self._kind)):
            chi = self.graph.edge_chi2()
            bound = self._bounds()
            worst = int(np.argmax(chi / bound))
            if chi[worst] <= bound[worst]:
                break
            j = int(self.graph.edges()[1][worst])
            kind = self._kind[worst]
            self._drop([worst], f"χ² {chi[worst]:.1f} > {cfg.closure_chi2:.1f} after "
                                f"optimisation", chi)
            if kind == "match":  # the odometry's edge beside it holds the chain
                self.replaced_matches.append(j)
            self.graph.optimize("gn", max_iterations=iterations, tolerance=tolerance)
        chi = self.graph.edge_chi2()
        for k, c in enumerate(self._closure):
            if c >= 0:
                self.closures[c].chi2 = float(chi[k])

    def _bounds(self) -> FloatArray:
        kinds = np.array(self._kind)
        return np.where(kinds == "closure", self.config.closure_chi2,
                        np.where(kinds == "match", self.config.match_chi2, np.inf))

    def _drop(self, edges: list[int], reason: str, chi: FloatArray) -> None:
        """Remove graph edges (positions) with their bookkeeping; closures among them are
        marked rejected for ``reason``."""
        self.graph.remove_edges(edges)
        for k in sorted(edges, reverse=True):
            self._kind.pop(k)
            closure = self._closure.pop(k)
            if closure >= 0:
                record = self.closures[closure]
                record.accepted, record.chi2, record.reason = False, float(chi[k]), reason

    def resolve(self, group: list[LoopClosure], iterations: int, tolerance: float) -> None:
        """The new ``group`` left closures accepted earlier over their bound: one side is
        wrong. Solve the graph without the older groups those closures came with; keep
        whichever graph has more closures within their bound (the consensus), the present
        one when they tie."""
        chi = self.graph.edge_chi2()
        bound = self._bounds()
        ids = np.array(self._closure)
        new = {id(c) for c in group}
        over = [int(k) for k in np.flatnonzero((ids >= 0) & (chi > bound))
                if id(self.closures[ids[k]]) not in new]
        if not over:
            return
        groups = {self.closures[ids[k]].group for k in over}
        old = [int(k) for k in np.flatnonzero(ids >= 0)
               if self.closures[ids[k]].group in groups]
        trial = self.graph.copy()
        trial.remove_edges(old)
        solve(trial, iterations, tolerance)
        kept_now = int(np.sum((ids >= 0) & (chi <= bound)))
        rest = np.delete(np.arange(len(ids)), old)
        kept_trial = int(np.sum((ids[rest] >= 0) & (trial.edge_chi2() <= bound[rest])))
        if kept_trial > kept_now:
            self._drop(old, f"conflicts with the closures at nodes {group[0].node}-"
                            f"{group[-1].node}, which more closures agree with", chi)
            self.graph = trial

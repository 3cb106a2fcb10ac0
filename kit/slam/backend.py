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
closures agreeing with the rest of the graph stays (:meth:`Backend.propose`), the sense of
Olson's single-cluster graph partitioning and of pairwise-consistency maximisation. When the
run ends, the closures still waiting that the graph already expects enter as a last group
(:meth:`Backend.settle`).
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
        record.surprise = self._surprise(record)
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
        rivals = self._rivals(group, poses)
        if rivals:
            supporters = len(group) + sum(
                any(agree(p, c, poses, cfg.loop_consistency) for c in group)
                for p in self._pending if all(p is not c for c in group))
            if supporters <= len(rivals):  # they wait for more closures to agree with them
                for c in group:
                    c.reason = (f"pending: disagrees with {len(rivals)} closure(s) accepted "
                                f"before (nodes {rivals[0].node}-{rivals[-1].node}) and no more"
                                f" closures agree with it than with them")
                if all(p is not record for p in self._pending):
                    self._pending.append(record)
                return False
            self._drop_rivals(group, rivals)
        self._enter(group)
        return True

    def settle(self) -> int:
        """The run has ended, so no closure still waiting will be confirmed: those the graph
        already expects — Mahalanobis distance² from its estimate now (:meth:`_surprise`)
        at most ``loop_gate``, so that a place that merely looks like another would have to
        lie where the graph already puts it — enter the graph as one last group, checked by
        χ² after the solve like every group; the rest are turned down with the reason.
        Returns how many entered. (A log that ends where it started otherwise ends with its
        last loop open whenever the last closure's partner missed a gate by a hair.)"""
        cfg = self.config
        waiting, self._pending = self._pending, []
        group = []
        for p in waiting:  # never accepted: _enter takes a closure out of the waiting list
            p.surprise = self._surprise(p)
            if p.surprise <= cfg.loop_gate:
                group.append(p)
            else:
                p.reason = (f"the run ended before another closure agreed (Mahalanobis² "
                            f"{p.surprise:.0f})")
        if not group:
            return 0
        rivals = self._rivals(group, self.graph.poses)
        if rivals and len(group) <= len(rivals):
            for c in group:
                c.reason = (f"the run ended with it disagreeing with {len(rivals)} closure(s) "
                            f"accepted before (nodes {rivals[0].node}-{rivals[-1].node})")
            return 0
        if rivals:
            self._drop_rivals(group, rivals)
        self._enter(group)
        return sum(c.accepted for c in group)

    def _surprise(self, record: LoopClosure) -> float:
        """Mahalanobis distance² of ``record`` from the graph's estimate now, under the
        graph's marginal covariance of the two nodes' relative pose plus its own."""
        estimate, spread = self.graph.relative_marginal(record.reference, record.node)
        e = geometry.relative(estimate, record.measurement)
        own = np.linalg.inv(self.information(record.covariance))
        return float(e @ np.linalg.solve(spread + own, e))

    def _drop_rivals(self, group: list[LoopClosure], rivals: list[LoopClosure]) -> None:
        """``rivals`` out of the graph, rejected in favour of ``group``."""
        self._drop([k for k, c in enumerate(self._closure)
                    if c >= 0 and any(self.closures[c] is r for r in rivals)],
                   f"conflicts with the closures at nodes {group[0].node}-"
                   f"{group[-1].node}, which more closures agree with",
                   self.graph.edge_chi2())

    def _enter(self, group: list[LoopClosure]) -> None:
        """``group`` into the graph as one group, then the graph solved and checked."""
        cfg = self.config
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
        self.optimise(10, 1e-6)

    def _rivals(self, group: list[LoopClosure], poses: FloatArray) -> list[LoopClosure]:
        """Closures in the graph that a closure of ``group`` disagrees with while both
        their new nodes and their old nodes lie within ``loop_pending_nodes`` of each other
        (where the graph's estimate between them is local, so :func:`agree` can be trusted),
        with every closure of their groups."""
        cfg = self.config
        near = cfg.loop_pending_nodes
        groups = {c.group for c in self.closures if c.accepted and any(
            abs(c.node - n.node) <= near and abs(c.reference - n.reference) <= near and
            not agree(c, n, poses, cfg.loop_consistency) for n in group)}
        return [c for c in self.closures if c.accepted and c.group in groups]

    # ------------------------------------------------------------------ solving
    def optimise(self, iterations: int, tolerance: float) -> None:
        """Solve the graph; while edges are over their χ² bound, drop the one whose removal
        leaves the fewest over theirs (:meth:`_culprit`) and solve again."""
        solve(self.graph, iterations, tolerance)
        for _ in range(len(self._kind)):
            chi = self.graph.edge_chi2()
            bound = self._bounds()
            if np.all(chi <= bound):
                break
            worst, trial = self._culprit(chi, bound, iterations, tolerance)
            j = int(self.graph.edges()[1][worst])
            kind = self._kind[worst]
            self._drop([worst], f"χ² {chi[worst]:.1f} > {bound[worst]:.1f} after optimisation"
                       if chi[worst] > bound[worst] else
                       f"the closures disagree with it (χ² {chi[worst]:.1f})", chi)
            self.graph = trial
            if kind == "match":  # the odometry's edge beside it holds the chain
                self.replaced_matches.append(j)
        chi = self.graph.edge_chi2()
        for k, c in enumerate(self._closure):
            if c >= 0:
                self.closures[c].chi2 = float(chi[k])

    def _culprit(self, chi: FloatArray, bound: FloatArray, iterations: int, tolerance: float
                 ) -> tuple[int, PoseGraph]:
        """Which edge to drop when some are over their bound, and the graph solved without
        it. Tried: the three edges most over their bound, and the three match edges inside
        the loops of the closures over theirs that disagree most with the odometry's edge
        beside them (a wrong match the graph trusts can leave the closures over their bound
        and itself within); kept: the removal that leaves the fewest edges over their bound,
        then the lowest cost."""
        ratio = chi / bound
        kinds = np.array(self._kind)
        over = np.flatnonzero(ratio > 1.0)
        candidates = [int(k) for k in over[np.argsort(-ratio[over])][:3]]
        i, j = self.graph.edges()[:2]
        spans = [(int(min(i[k], j[k])), int(max(i[k], j[k]))) for k in over
                 if kinds[k] == "closure"]
        if spans:
            lo, hi = min(a for a, _ in spans), max(b for _, b in spans)
            candidates += self._suspicious_matches(lo, hi)[:3]
        best: tuple[tuple[int, float], int, PoseGraph] | None = None
        for k in dict.fromkeys(candidates):
            trial = self.graph.copy()
            trial.remove_edges([k])
            solve(trial, iterations, tolerance)
            rest = np.delete(bound, k)
            key = (int(np.sum(trial.edge_chi2() > rest)), trial.cost())
            if best is None or key < best[0]:
                best = (key, k, trial)
        assert best is not None
        return best[1], best[2]

    def _suspicious_matches(self, lo: int, hi: int) -> list[int]:
        """Match edges between nodes ``lo`` and ``hi`` whose measurement the odometry's edge
        beside them contradicts (Mahalanobis distance² over ``match_gate`` under both
        covariances), most contradicted first."""
        i, j, z, omega = self.graph.edges()
        odometry = {(int(a), int(b)): k for k, (a, b, kind)
                    in enumerate(zip(i, j, self._kind, strict=True)) if kind == "odometry"}
        scored = []
        for k, kind in enumerate(self._kind):
            o = odometry.get((int(i[k]), int(j[k])))
            if kind != "match" or o is None or not lo <= i[k] < hi:
                continue
            e = geometry.relative(z[o], z[k])
            d2 = float(e @ np.linalg.solve(np.linalg.inv(omega[k]) + np.linalg.inv(omega[o]), e))
            if d2 > self.config.match_gate:
                scored.append((d2, k))
        return [k for _, k in sorted(scored, reverse=True)]

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

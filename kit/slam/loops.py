"""Loop closure: is the robot back where it has been, and where exactly?

A candidate is an old node near the new one's estimate that was passed long enough ago. The
new node's scan is searched for around its estimate against the scans around the candidate,
and the answer must pass every gate before it may enter the pose graph:

1. **fit** — the correlative search's response (mean likelihood of the scan's points) and
   the spread of the responses around its best pose (Karto's covariance);
2. **a second matcher** — point-to-line ICP started from the correlative answer must
   converge and stay within ``loop_agreement`` of it;
3. **agreement with the map** — the refined pose must put most of the scan's points on the
   reference (*support*), and the same correction applied to the last few nodes' scans must
   put most of *their* points on it too: one scan can look like another place, a stretch of
   the trajectory rarely does;
4. **agreement with odometry** — the correction may be no larger than the drift scan
   matching can have gathered over the driving between the candidate and the node, by the
   shortest way through the graph (closures accepted before tie their nodes together).

Every attempt, accepted or not, is kept as a :class:`LoopClosure` with its figures and the
reason, so a failure can be traced (``kit slam`` writes them to ``closures.csv``); the back
end may still reject an accepted closure when, after optimisation, its χ² says the rest of
the graph disagrees with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from kit import geometry
from kit.slam import correlative
from kit.slam import scan_matching as sm

if TYPE_CHECKING:
    from kit.slam.config import SlamConfig

__all__ = ["LoopClosure", "LoopReference", "agree", "covered_support", "match_loop", "support"]

FloatArray = NDArray[np.float64]


@dataclass(eq=False)
class LoopClosure:
    """One loop-closure attempt and what became of it."""

    node: int
    """The new node (graph index)."""
    candidate: int
    """The old node it was searched around."""
    accepted: bool = False
    reason: str = ""
    """Why it was rejected ("" when accepted), e.g. ``"response 0.31 < 0.45"``."""
    response: float = math.nan
    """Correlative response at the best pose (0…1)."""
    support: float = math.nan
    """Share of the scan's points within 0.1 m of the reference at the refined pose, among
    those within 1 m of it (:func:`covered_support`)."""
    recent_support: float = math.nan
    """The same for the last nodes' scans moved by the same correction."""
    shift: FloatArray = field(default_factory=lambda: np.full(3, math.nan))
    """The correction the closure asks of the node, ``T_estimate_closure`` (x, y [m], θ)."""
    reference: int = -1
    """The old node the edge joins (the candidate's neighbour nearest the refined pose)."""
    surprise: float = math.nan
    """Mahalanobis distance² of the closure from the graph's estimate before it entered."""
    chi2: float = math.nan
    """The edge's ``eᵀ Ω e`` after the last optimisation it took part in."""
    group: int = -1
    """Closures that confirmed each other enter the graph together, as one group."""
    measurement: FloatArray = field(default_factory=lambda: np.zeros(3))
    """The edge's relative pose ``T_reference_node``."""
    covariance: FloatArray = field(default_factory=lambda: np.eye(3))
    """Its covariance in the reference node's frame."""


def support(points: FloatArray, ref: sm.PointCloudReference, pose: FloatArray,
            within: float = 0.1) -> float:
    """Share of ``points`` placed at ``pose`` that lie within ``within`` metres of the
    reference's points."""
    if ref.tree is None or len(points) == 0:
        return 0.0
    d, _ = ref.tree.query(geometry.transform_points(pose, points), k=1,
                          distance_upper_bound=within)
    return float(np.mean(d < np.inf))


def covered_support(points: FloatArray, ref: sm.PointCloudReference, pose: FloatArray,
                    within: float = 0.1, cover: float = 1.0) -> tuple[float, float]:
    """``(support, overlap)``: of ``points`` placed at ``pose``, the share lying within
    ``cover`` metres of the reference (the part of the scan the reference has seen at all),
    and among those the share within ``within`` metres. A scan reaching beyond the old
    scans around a candidate is judged on what they overlap."""
    if ref.tree is None or len(points) == 0:
        return 0.0, 0.0
    d, _ = ref.tree.query(geometry.transform_points(pose, points), k=1,
                          distance_upper_bound=cover)
    covered = d < np.inf
    if not covered.any():
        return 0.0, 0.0
    return float(np.mean(d[covered] <= within)), float(np.mean(covered))


class LoopReference:
    """The scans around a loop-closure candidate (points in ``map``, ``(M, 2)``) and what the
    two matchers make of them — the likelihood field and the ICP reference — each built when
    first needed and kept: successive nodes often search the same candidate's scans."""

    def __init__(self, points: FloatArray, cfg: SlamConfig) -> None:
        self.points = points
        self.config = cfg
        self._field: correlative.LikelihoodField | None = None
        self._icp: sm.PointCloudReference | None = None

    def field(self) -> correlative.LikelihoodField:
        """The correlative search's likelihood field (``loop_resolution``)."""
        if self._field is None:
            cfg = self.config
            self._field = correlative.likelihood_field(
                self.points, cfg.loop_resolution, cfg.loop_resolution,
                margin=cfg.loop_linear_window + 0.5)
        return self._field

    def icp(self) -> sm.PointCloudReference:
        """The points with their normals and k-d tree, for ICP and the support tests."""
        if self._icp is None:
            self._icp = sm.PointCloudReference(self.points, self.config.icp)
        return self._icp


def match_loop(record: LoopClosure, source: FloatArray, reference: FloatArray | LoopReference,
               estimate: FloatArray, recent: FloatArray, travel: float, cfg: SlamConfig
               ) -> sm.MatchResult | None:
    """Search ``source`` (the node's points, ``base``) around ``estimate`` (its ``T_map_base``)
    against ``reference`` (the candidate's scans, ``map``: points or a :class:`LoopReference`
    made with the same ``cfg``), through the gates above; fills ``record`` and returns the
    refined match, or ``None`` with ``record.reason`` set.

    ``recent`` are the last nodes' points in ``map`` (moved by the estimate's correction for
    the map test); ``travel`` is the driving [m] along which drift can lie between the node
    and the candidate (the shortest way through the graph, across accepted closures).
    """
    loop_ref = reference if isinstance(reference, LoopReference) else \
        LoopReference(reference, cfg)
    field_ = loop_ref.field()
    coarse = correlative.correlative_match(source, field_, estimate, cfg.loop_linear_window,
                                           cfg.loop_angular_window, math.radians(0.5),
                                           coarse_factor=8, penalty=0.1)
    record.response = coarse.response
    spread = max(coarse.covariance[0, 0], coarse.covariance[1, 1])
    if coarse.response < cfg.loop_min_response:
        record.reason = f"response {coarse.response:.2f} < {cfg.loop_min_response}"
        return None
    if spread > cfg.loop_max_variance:
        record.reason = f"variance {spread:.3f} m² > {cfg.loop_max_variance}"
        return None
    ref = loop_ref.icp()
    if len(ref.points) == 0:
        record.reason = "no reference surfaces"
        return None
    fine = sm.icp(source, ref, coarse.pose)
    apart = geometry.relative(coarse.pose, fine.pose)
    record.shift = geometry.relative(estimate, fine.pose)
    if not fine.converged and fine.rmse > cfg.poor_rmse:
        record.reason = f"ICP did not converge (rms {fine.rmse:.3f} m)"
        return None
    if math.hypot(apart[0], apart[1]) > cfg.loop_agreement[0] or \
            abs(apart[2]) > cfg.loop_agreement[1]:
        record.reason = (f"ICP and correlative disagree by {math.hypot(apart[0], apart[1]):.2f}"
                         f" m, {math.degrees(abs(apart[2])):.1f}°")
        return None
    record.support, overlap = covered_support(source, ref, fine.pose)
    if overlap < cfg.loop_min_overlap:
        record.reason = f"overlap {overlap:.2f} < {cfg.loop_min_overlap}"
        return None
    if record.support < cfg.loop_min_support:
        record.reason = f"support {record.support:.2f} < {cfg.loop_min_support}"
        return None
    correction = geometry.compose(fine.pose, geometry.inverse(estimate))  # T_map'_map
    record.recent_support = covered_support(recent, ref, correction)[0] if len(recent) \
        else 1.0
    if record.recent_support < cfg.loop_min_recent_support:
        record.reason = (f"the last nodes' support {record.recent_support:.2f} < "
                         f"{cfg.loop_min_recent_support}")
        return None
    shift = record.shift
    if math.hypot(shift[0], shift[1]) > cfg.loop_max_shift[0] + cfg.loop_max_shift[1] * travel \
            or abs(shift[2]) > cfg.loop_max_turn[0] + cfg.loop_max_turn[1] * travel:
        record.reason = (f"correction {math.hypot(shift[0], shift[1]):.2f} m, "
                         f"{math.degrees(abs(shift[2])):.1f}° beyond the drift of {travel:.0f} m")
        return None
    return fine


def agree(a: LoopClosure, b: LoopClosure, poses: FloatArray, tolerance: tuple[float, float]
          ) -> bool:
    """Do closures ``a`` and ``b`` agree? Going from ``a``'s new node to ``b``'s by way of
    ``a``'s closure, the graph's estimate between the two old nodes and ``b``'s closure must
    land where the graph's estimate between the two new nodes does (Olson's and Mangelson's
    pairwise consistency), within ``tolerance`` (m, rad)."""
    via_closures = geometry.compose(geometry.compose(
        geometry.inverse(a.measurement), geometry.relative(poses[a.reference],
                                                           poses[b.reference])),
        b.measurement)
    direct = geometry.relative(poses[a.node], poses[b.node])
    d = geometry.relative(direct, via_closures)
    return bool(math.hypot(d[0], d[1]) <= tolerance[0] and abs(d[2]) <= tolerance[1])

"""The SLAM front end, in SLAM Toolbox's design (Macenski & Jambrecic, JOSS 2021; Karto),
built so that no single bad match can break the map.

For every scan, with the odometry pose it was taken at:

1. **Predict** the scan's pose in ``map`` from the last corrected scan and the odometry since.
2. **Drop what moves**: returns that land where the recent scans have seen free space
   (:class:`kit.slam.free_space.FreeSpace`) are people and other moving things; they neither
   drive the match nor enter the map.
3. **Match** the rest against the local map — the scans of the last ``local_map_nodes`` nodes
   at their current poses — by point-to-line ICP held by the odometry as a prior
   (:func:`kit.slam.scan_matching.icp`). A match must pass its gates: enough points paired,
   small residuals, and a correction the odometry could have made (the Mahalanobis distance
   of ``match − prediction`` under the odometry's covariance at most ``match_gate``). When it
   fails them, a correlative search (:mod:`kit.slam.correlative`, which a wrong start cannot
   trap) looks wider and ICP refines its answer; that answer is taken only if the two
   matchers agree and it puts clearly more of the scan on the map (``far_match_gain``) than
   the best fit near the odometry. Otherwise the scan keeps the odometry's prediction.
4. **Add a node** when the robot has travelled ``min_travel`` metres or turned
   ``min_heading`` radians since the last one: the node's pose is the corrected pose, and an
   edge to the previous node carries the match's relative pose and information (under a
   Cauchy kernel) — or, when the match was rejected, the odometry's.
5. **Close loops** from a new node (:mod:`kit.slam.loops`: fit, a second matcher, agreement
   with the map and with the drift odometry allows), then optimise the graph (Gauss–Newton),
   and check every edge's χ² afterwards: the worst closure above ``closure_chi2`` is removed,
   the worst match edge above ``match_chi2`` is replaced by the odometry's edge, and the graph
   is solved again, until every edge agrees with the rest.

Every scan's pose is kept relative to the node before it, so the trajectory follows the
optimised graph; :meth:`Slam.occupancy_map` rebuilds the map from the nodes' scans at their
optimised poses, without the returns found to move. ``map`` coincides with ``odom`` at the
first scan.

Frames: the graph holds ``T_map_base``; scans become points in ``base`` through the fixed
``T_base_laser`` (the URDF's laser joint) and, when beam times and odometry are known, are
de-skewed to the scan's stamp.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, mapping, msgs, perception
from kit.slam import correlative
from kit.slam import scan_matching as sm
from kit.slam.backend import Backend
from kit.slam.free_space import FreeSpace, laser_beams
from kit.slam.loops import LoopClosure, match_loop, support
from kit.slam.pose_graph import PoseGraph

__all__ = ["LoopClosure", "ScanRecord", "Slam", "SlamConfig", "map_beams", "relative_covariance",
           "scan_points"]

FloatArray = NDArray[np.float64]
CHI2_3DOF_999 = 16.27
"""χ² with 3 degrees of freedom that a consistent 3-vector exceeds with probability 0.1 %."""


@dataclass(frozen=True)
class SlamConfig:
    """Front-end settings (SI units). Defaults follow SLAM Toolbox's where they exist."""

    min_travel: float = 0.3
    """New node after this much travel [m] (SLAM Toolbox: ``minimum_travel_distance``)."""
    min_heading: float = 0.3
    """… or this much turning [rad] (``minimum_travel_heading``)."""
    local_map_nodes: int = 5
    """Scans in the local map matched against (``scan_buffer_size``)."""
    max_range: float = 25.0
    """Returns farther than this [m] are not used for matching."""
    point_spacing: float = 0.02
    """Scan points are thinned to one per cell of this size [m]."""
    icp: sm.IcpConfig = field(default_factory=sm.IcpConfig)
    min_inliers: float = 0.3
    """A match pairing fewer of its points than this fraction is not trusted."""
    poor_rmse: float = 0.08
    """A match whose residuals' RMS exceeds this [m] is not trusted."""
    match_gate: float = CHI2_3DOF_999
    """A match may move the prediction by at most this Mahalanobis distance² under the
    odometry's covariance, or it must be confirmed by the wider search."""
    far_match_gain: float = 0.1
    """A match far from the odometry is taken only if it puts this much larger a share of
    the scan's points within 0.1 m of the local map than the best fit near the odometry."""
    search_linear_window: float = 0.3
    """Half-width [m] of the correlative search around the prediction."""
    search_angular_window: float = math.radians(20.0)
    """Half-width [rad] of that search (odometry's heading can jump this much)."""
    search_prior_scale: float = 0.01
    """The odometry prior's information is scaled by this for the ICP after the search."""
    odometry_noise: tuple[float, float, float, float] = (0.1, 0.02, 0.2, math.radians(1.0))
    """(α_xy, σ_xy, α_θ, σ_θ): the odometry between two scans is trusted to
    ``α_xy d + σ_xy`` [m] and ``α_θ |Δθ| + σ_θ`` [rad] (d the distance driven); an assumption."""
    min_edge_sigma: tuple[float, float] = (0.005, math.radians(0.2))
    """Floor on an edge's standard deviation (m, rad): matches are not perfect."""
    match_covariance_scale: float = 10.0
    """ICP's covariance counts every point's residual as an independent measurement;
    neighbouring points on one wall are not, so a match's (and a closure's) covariance is
    scaled by this before it weighs an edge (an assumption: on the Intel log the matches err
    2.4–4 times the unscaled standard deviations)."""
    match_kernel_delta: float = 3.0
    """Cauchy kernel width on match edges (in √χ² units)."""
    odometry_kernel_delta: float = 3.0
    """Cauchy kernel width on the odometry's edges, which every pair of consecutive nodes
    has beside the match's (wheel odometry slips and jumps)."""
    match_chi2: float = 10 * CHI2_3DOF_999
    """After an optimisation a match edge whose χ² exceeds this is replaced by the
    odometry's edge."""
    dynamic_margin: float = 0.15
    """A return is taken for something moving when every cell within this [m] of it has
    been seen free by the last scans (0 turns the test off)."""
    dynamic_nodes: int = 20
    """Nodes whose beams make up the free space."""
    dynamic_range: float = 10.0
    """Beams clear free space up to this range [m]."""
    loop_search_radius: float = 4.0
    """Loop-closure candidates lie within this distance [m] (``loop_search_maximum_distance``)."""
    loop_min_travel: float = 10.0
    """… and were passed at least this much driving [m] ago."""
    loop_chain: int = 10
    """Nodes on each side of the candidate whose scans form the loop's reference."""
    loop_linear_window: float = 2.0
    """Half-width of the correlative search [m]: the drift since the candidate (SLAM
    Toolbox's ``loop_search_space_dimension`` of 8 m spans ±4 m)."""
    loop_angular_window: float = 0.3
    """Half-width of the correlative search [rad]."""
    loop_resolution: float = 0.05
    """Correlative grid cell [m]."""
    loop_min_response: float = 0.45
    """Minimum mean likelihood (``loop_match_minimum_response_fine``)."""
    loop_max_variance: float = 0.05
    """Maximum positional variance [m²] of an accepted match."""
    loop_min_support: float = 0.7
    """Share of the scan's points the refined match must put within 0.1 m of the reference,
    among those it puts within 1 m of it (the part the reference has seen)."""
    loop_min_overlap: float = 0.3
    """… and the share it puts within 1 m must reach this."""
    loop_recent_nodes: int = 4
    """Nodes before the new one whose scans must agree with the closure too."""
    loop_min_recent_support: float = 0.5
    """Share of their points the closure's correction must put within 0.1 m of the
    reference (among those within 1 m of it)."""
    loop_agreement: tuple[float, float] = (0.1, math.radians(2.0))
    """ICP from the correlative answer must stay within this (m, rad) of it."""
    loop_max_shift: tuple[float, float] = (0.3, 0.03)
    """A closure may move the node by at most ``a + b · d`` metres, ``d`` the driving [m]
    since the candidate: the drift scan matching can have accumulated (an assumption)."""
    loop_max_turn: tuple[float, float] = (math.radians(3.0), math.radians(0.3))
    """… and turn it by at most ``a + b · d`` radians."""
    loop_gate: float = CHI2_3DOF_999
    """A closure whose Mahalanobis distance² from the graph's current estimate (under the
    graph's marginal covariance of the two nodes' relative pose plus the closure's own)
    exceeds this is *surprising*: it waits for another closure that agrees with it."""
    loop_consistency: tuple[float, float] = (0.15, math.radians(2.0))
    """Two closures agree when the loop they make with the graph's estimates between their
    new nodes and between their old ones closes within this (m, rad)."""
    loop_confirmations: int = 1
    """Agreeing closures a closure needs (one more when it is surprising) before all enter
    the graph together: one scan can look like another place, two in a row rarely do."""
    loop_pending_nodes: int = 25
    """Nodes a closure waits for its confirmation."""
    loop_kernel_delta: float = 3.0
    """Cauchy kernel width on loop edges (in √χ² units)."""
    closure_chi2: float = 2 * CHI2_3DOF_999
    """After an optimisation a closure whose χ² exceeds this is removed."""
    loop_every: int = 1
    """Look for a loop at every n-th node."""
    loop_cooldown: int = 10
    """Nodes after an accepted closure before the next is looked for."""

    def __post_init__(self) -> None:
        if self.min_travel <= 0 or self.min_heading <= 0 or self.local_map_nodes < 1:
            raise ValueError("min_travel, min_heading and local_map_nodes must be positive")
        if self.max_range <= 0 or self.point_spacing < 0 or not 0 <= self.min_inliers <= 1:
            raise ValueError("max_range must be positive, point_spacing >= 0, min_inliers in "
                             "[0, 1]")
        if self.match_gate <= 0 or self.match_chi2 <= 0 or self.closure_chi2 <= 0:
            raise ValueError("match_gate, match_chi2 and closure_chi2 must be positive")
        if self.dynamic_margin < 0 or self.dynamic_nodes < 1 or self.dynamic_range <= 0:
            raise ValueError("dynamic_margin must be >= 0, dynamic_nodes and dynamic_range "
                             "positive")


@dataclass(frozen=True)
class ScanRecord:
    """A scan's place in the trajectory: its pose relative to the node before it."""

    stamp: float
    anchor: int
    offset: FloatArray
    """``T_anchor_base`` of this scan."""
    odometry: FloatArray
    """``T_odom_base`` of this scan."""
    matched: str = "icp"
    """How its pose was found: ``"icp"``, ``"search"`` (the wider correlative search),
    ``"odometry"`` (every match was rejected), or ``"first"``."""
    moving: int = 0
    """Returns dropped as moving things."""


def thin(points: FloatArray, spacing: float) -> FloatArray:
    """One point per ``spacing`` grid cell (the first in scan order), order kept."""
    if spacing <= 0 or len(points) == 0:
        return points
    cells = np.floor(points / spacing).astype(np.int64)
    _, first = np.unique(cells, axis=0, return_index=True)
    return points[np.sort(first)]


def scan_points(scan: msgs.LaserScan, base_to_laser: ArrayLike = (0.0, 0.0, 0.0),
                beam_motion: FloatArray | None = None, max_range: float = math.inf
                ) -> FloatArray:
    """The scan's valid returns within ``max_range`` as points in ``base`` at the scan's
    stamp, shape ``(M, 2)``.

    Parameters
    ----------
    base_to_laser
        ``T_base_laser`` (x, y, θ).
    beam_motion : (N, 3), optional
        ``T_base(stamp)_base(beam)`` for every beam (from odometry): where the base was when
        each beam was measured, seen from where it was at the stamp. Without it, all beams are
        taken as simultaneous.
    """
    valid = perception.valid_returns(scan)
    r = np.asarray(scan.ranges, dtype=np.float64)
    valid &= r <= max_range
    a = perception.beam_angles(scan)[valid]
    local = np.column_stack([r[valid] * np.cos(a), r[valid] * np.sin(a)])
    mount = geometry.check_pose(base_to_laser)
    if beam_motion is None:
        return geometry.transform_points(mount, local)
    motion = np.asarray(beam_motion, dtype=np.float64)
    if motion.shape != (len(r), 3):
        raise ValueError(f"beam_motion needs one pose per beam, shape ({len(r)}, 3); got "
                         f"{motion.shape}")
    sensor = geometry.compose(motion[valid], mount)       # T_base(stamp)_laser(beam)
    c, s = np.cos(sensor[:, 2]), np.sin(sensor[:, 2])
    return np.column_stack([sensor[:, 0] + c * local[:, 0] - s * local[:, 1],
                            sensor[:, 1] + s * local[:, 0] + c * local[:, 1]])


def relative_covariance(anchor: ArrayLike, covariance: ArrayLike) -> FloatArray:
    """A ``map``-frame pose covariance expressed in the frame of ``anchor`` (x, y, θ):
    ``Rᵀ Σ R`` with ``R = diag(R(θ_anchor), 1)``."""
    th = float(geometry.check_pose(anchor)[2])
    c, s = math.cos(th), math.sin(th)
    R = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return np.asarray(R.T @ np.asarray(covariance, dtype=np.float64) @ R)


@dataclass
class _Node:
    scan_index: int
    points: FloatArray
    """Thinned points in ``base``, without the returns found to move."""
    travelled: float
    """Distance driven from the start to this node [m]."""
    scan: msgs.LaserScan | None
    beam_motion: FloatArray | None
    odometry: FloatArray = field(default_factory=lambda: np.zeros(3))
    """``T_odom_base`` at this node."""
    turned: float = 0.0
    """Turning [rad] from the start to this node, summed."""
    moving: NDArray[np.bool_] | None = None
    """Per beam of ``scan``: a return found to move (kept out of the map)."""
    beams: tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_]] | None = None
    """Every beam's end in ``base``, and which are valid returns and max-range beams."""
    normals: FloatArray | None = None
    """Normals of the usable ``points[usable]`` (estimated once, from this scan alone)."""
    usable: NDArray[np.bool_] | None = None

    def surface(self, config: sm.IcpConfig) -> tuple[FloatArray, FloatArray]:
        """The points with usable normals, and the normals (``base`` frame)."""
        if self.normals is None or self.usable is None:
            if len(self.points) >= 3:
                self.normals, self.usable = sm.estimate_normals(
                    self.points, config.neighbours, max_spread=config.max_spread)
            else:
                self.normals, self.usable = np.zeros((0, 2)), np.zeros(len(self.points), bool)
            self.normals = self.normals[self.usable] if len(self.normals) else self.normals
        return self.points[self.usable], self.normals


@dataclass(frozen=True)
class _Match:
    pose: FloatArray
    covariance: FloatArray
    how: str
    """"icp", "search" or "odometry"."""
    prior: FloatArray | None = None
    """The odometry prior's information the match was held by (its covariance includes
    it)."""

    def scan_covariance(self) -> FloatArray:
        """The covariance of what the scan alone says: the prior's information taken back
        out of the match's (``(Σ⁻¹ − Ω_p)⁻¹``), kept positive definite."""
        info = np.linalg.inv(self.covariance)
        if self.prior is not None:
            info = info - self.prior
        info = 0.5 * (info + info.T)
        w, v = np.linalg.eigh(info)
        w = np.maximum(w, 1e-6)
        return np.asarray((v / w) @ v.T, dtype=np.float64)


def _beam_ends(scan: msgs.LaserScan, base_to_laser: ArrayLike, beam_motion: FloatArray | None
               ) -> tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_]]:
    """Every beam's end in ``base`` at the scan's stamp (``(N, 2)``, de-skewed like
    :func:`scan_points`): at its range for a valid return, at ``range_max`` for a beam that
    saw nothing (REP-117), NaN otherwise; and the masks of valid and max-range beams."""
    r = np.asarray(scan.ranges, dtype=np.float64)
    valid = perception.valid_returns(scan)
    clear = perception.max_range_beams(scan)
    length = np.where(valid, np.nan_to_num(r), np.where(clear, float(scan.range_max), np.nan))
    a = perception.beam_angles(scan)
    local = np.column_stack([length * np.cos(a), length * np.sin(a)])
    mount = geometry.check_pose(base_to_laser)
    if beam_motion is None:
        return geometry.transform_points(mount, local), valid, clear
    motion = np.asarray(beam_motion, dtype=np.float64)
    if motion.shape != (len(r), 3):
        raise ValueError(f"beam_motion needs one pose per beam, shape ({len(r)}, 3); got "
                         f"{motion.shape}")
    sensor = geometry.compose(motion, mount)
    c, s = np.cos(sensor[:, 2]), np.sin(sensor[:, 2])
    ends = np.column_stack([sensor[:, 0] + c * local[:, 0] - s * local[:, 1],
                            sensor[:, 1] + s * local[:, 0] + c * local[:, 1]])
    return ends, valid, clear


class Slam:
    """Online graph SLAM: feed :meth:`add_scan` one scan and its odometry at a time.

    Parameters
    ----------
    base_to_laser
        ``T_base_laser`` (x, y, θ) of the scanner on the robot.
    config
        :class:`SlamConfig`.

    Attributes
    ----------
    graph : PoseGraph
        The nodes (``T_map_base`` of the scans that became nodes) and their edges.
    records : list of ScanRecord
        Every scan's place in the trajectory, and how its pose was found.
    closures : list of LoopClosure
        Every loop-closure attempt, accepted or not, with its figures and reason.
    replaced_matches : list of int
        Nodes whose match edge the back end replaced by the odometry's after an
        optimisation (its χ² above ``match_chi2``).
    """

    MOVING_SHARE = 0.3
    """When more of a scan than this looks like moving things, the pose it was tested at is
    more likely off than the world full of people: nothing is dropped."""

    def __init__(self, base_to_laser: ArrayLike = (0.0, 0.0, 0.0),
                 config: SlamConfig | None = None) -> None:
        self.config = config or SlamConfig()
        cfg = self.config
        self.base_to_laser = geometry.check_pose(base_to_laser, "base_to_laser").copy()
        self.backend = Backend(cfg)
        self.records: list[ScanRecord] = []
        self.nodes: list[_Node] = []
        self._last_pose: FloatArray | None = None   # T_map_base of the last scan
        self._last_odom: FloatArray | None = None
        self._travelled = 0.0
        self._turned = 0.0
        self._reference: sm.PointCloudReference | None = None
        self._reference_key: tuple[int, int] = (-1, -1)
        self._field: tuple[tuple[int, int], FloatArray, correlative.LikelihoodField] | None = None
        self._optimisations = 0
        self._last_closure = -(10**9)
        self._free = FreeSpace(0.05, cfg.dynamic_margin, 0.25, cfg.dynamic_range) \
            if cfg.dynamic_margin > 0 else None

    @property
    def graph(self) -> PoseGraph:
        """The pose graph (:class:`kit.slam.backend.Backend` keeps its edges' kinds)."""
        return self.backend.graph

    @property
    def closures(self) -> list[LoopClosure]:
        """Every loop-closure attempt, accepted or not, with its figures and reason."""
        return self.backend.closures

    @property
    def replaced_matches(self) -> list[int]:
        """Nodes whose match edge the back end dropped after a solve."""
        return self.backend.replaced_matches

    @property
    def loop_closures(self) -> list[tuple[int, int]]:
        """``(reference node, node)`` of every closure in the graph now."""
        return self.backend.loop_closures

    # ------------------------------------------------------------------ the loop
    def add_scan(self, scan: msgs.LaserScan, odometry: ArrayLike, stamp: float | None = None,
                 beam_motion: FloatArray | None = None) -> FloatArray:
        """Process one scan taken at ``odometry`` = ``T_odom_base``; returns its corrected
        pose ``T_map_base``.

        ``stamp`` defaults to the scan's header stamp [s]; ``beam_motion`` is optional
        de-skewing (see :func:`scan_points`).
        """
        odom = geometry.check_pose(odometry, "odometry")
        if odom.shape != (3,):
            raise ValueError(f"odometry is one pose (x, y, θ); got shape {odom.shape}")
        t = scan.header.stamp.to_sec() if stamp is None else float(stamp)
        cfg = self.config
        ends, valid, clear = _beam_ends(scan, self.base_to_laser, beam_motion)
        r = np.asarray(scan.ranges, dtype=np.float64)
        usable = valid & (np.nan_to_num(r) <= cfg.max_range)
        full = ends[usable]
        if self._last_pose is None or self._last_odom is None:
            return self._first(scan, odom, t, (ends, valid, clear), beam_motion)
        step = geometry.relative(self._last_odom, odom)
        self._travelled += float(np.hypot(step[0], step[1]))
        self._turned += abs(float(step[2]))
        predicted = geometry.compose(self._last_pose, step)
        moving = self._moving(full, predicted)
        points = thin(full[~moving], cfg.point_spacing)
        match = self._match(points, predicted, step)
        again = self._moving(full, match.pose)
        if np.any(again & ~moving):
            moving |= again
            points = thin(full[~moving], cfg.point_spacing)
            match = self._refine(points, match, step)
        anchor = len(self.nodes) - 1
        since = geometry.relative(self.graph.poses[anchor], match.pose)
        pose = match.pose
        if math.hypot(since[0], since[1]) >= cfg.min_travel or abs(since[2]) >= cfg.min_heading:
            beam_moving = np.zeros(len(r), dtype=bool)
            beam_moving[np.flatnonzero(usable)[moving]] = True
            anchor = self._add_node(scan, match, points, (ends, valid, clear), beam_moving,
                                    beam_motion, odom, anchor)
            pose = self.graph.poses[anchor]
            since = np.zeros(3)
        self.records.append(ScanRecord(t, anchor, since, odom.copy(), match.how,
                                       int(moving.sum())))
        self._last_pose, self._last_odom = pose, odom.copy()
        return pose

    def _first(self, scan: msgs.LaserScan, odom: FloatArray, t: float,
               beams: tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_]],
               beam_motion: FloatArray | None) -> FloatArray:
        ends, valid, _ = beams
        r = np.nan_to_num(np.asarray(scan.ranges, dtype=np.float64))
        points = thin(ends[valid & (r <= self.config.max_range)], self.config.point_spacing)
        self.graph.add_node(odom)
        self.nodes.append(_Node(0, points, 0.0, scan, beam_motion, odom.copy(), 0.0,
                                np.zeros(len(r), dtype=bool), beams))
        self._insert_free(0)
        self.records.append(ScanRecord(t, 0, np.zeros(3), odom.copy(), "first"))
        self._last_pose, self._last_odom = odom.copy(), odom.copy()
        return odom.copy()

    def _prior_information(self, step: FloatArray) -> FloatArray:
        a_xy, s_xy, a_th, s_th = self.config.odometry_noise
        d = float(np.hypot(step[0], step[1]))
        sd_xy, sd_th = a_xy * d + s_xy, a_th * abs(float(step[2])) + s_th
        # isotropic in x and y, so the same in the map frame as in the robot's
        return np.diag([1 / sd_xy**2, 1 / sd_xy**2, 1 / sd_th**2])

    def _fits(self, result: sm.MatchResult) -> bool:
        """The fit gates: enough points paired, residuals small (an ICP that ends moving back
        and forth between two pairings by less than a millimetre still fits)."""
        return result.inlier_fraction >= self.config.min_inliers and \
            result.rmse <= self.config.poor_rmse and result.iterations > 0

    def _match(self, points: FloatArray, predicted: FloatArray, step: FloatArray) -> _Match:
        """The scan's pose: ICP held by the odometry when it passes the gates, else the wider
        search's answer when both matchers agree and it fits clearly better than the
        odometry, else the odometry's prediction."""
        cfg = self.config
        omega = self._prior_information(step)
        odometry = _Match(predicted, np.asarray(np.linalg.inv(omega)), "odometry")
        ref = self._local_reference()
        if ref is None or len(points) < 10:
            return odometry
        near = sm.icp(points, ref, predicted, omega)
        d = near.pose - predicted
        d[2] = float(geometry.wrap_angle(d[2]))
        if self._fits(near) and float(d @ omega @ d) <= cfg.match_gate:
            return _Match(near.pose, near.covariance, "icp", omega)
        field_ = self._local_field(ref, predicted)
        if field_ is None:
            return odometry
        linear, angular = cfg.search_linear_window, cfg.search_angular_window
        coarse = correlative.correlative_match(points, field_, predicted, linear, angular,
                                               math.radians(0.5), penalty=0.1)
        off = coarse.pose - predicted
        if max(abs(off[0]), abs(off[1])) >= linear - 1.5 * field_.resolution or \
                abs(float(geometry.wrap_angle(off[2]))) >= angular - math.radians(1.0):
            # the best on the window's edge may lie beyond it (odometry can jump 0.7 m and
            # 70° between two scans): look three times as far and four times as wide
            coarse = correlative.correlative_match(points, field_, predicted, 3 * linear,
                                                   min(4 * angular, math.pi),
                                                   math.radians(0.5), penalty=0.1)
        far = sm.icp(points, ref, coarse.pose, omega * cfg.search_prior_scale)
        apart = geometry.relative(coarse.pose, far.pose)
        if math.hypot(apart[0], apart[1]) > 2.5 * field_.resolution or \
                abs(apart[2]) > math.radians(2.0):
            # ICP walked off: a second correlative look where it ended must find it there
            coarse = correlative.correlative_match(points, field_, far.pose,
                                                   4 * field_.resolution, math.radians(4.0),
                                                   math.radians(0.5))
            apart = geometry.relative(coarse.pose, far.pose)
        agree = math.hypot(apart[0], apart[1]) <= 2.5 * field_.resolution and \
            abs(apart[2]) <= math.radians(2.0)
        # a match away from the odometry must explain the scan clearly better than the
        # odometry's own prediction does (and the search's answer better than ICP's too)
        gain = cfg.far_match_gain
        bar = support(points, ref, predicted) + gain
        s_near = support(points, ref, near.pose) if self._fits(near) else -1.0
        s_far = support(points, ref, far.pose) if self._fits(far) and agree else -1.0
        if s_far >= max(bar, s_near + gain):
            return _Match(far.pose, far.covariance, "search", omega * cfg.search_prior_scale)
        if s_near >= bar:
            return _Match(near.pose, near.covariance, "icp", omega)
        return odometry

    def _refine(self, points: FloatArray, match: _Match, step: FloatArray) -> _Match:
        """ICP again from ``match`` once more returns were found to move."""
        ref = self._local_reference()
        if match.how == "odometry" or ref is None or len(points) < 10:
            return match
        omega = self._prior_information(step)
        if match.how == "search":
            omega = omega * self.config.search_prior_scale
        result = sm.icp(points, ref, match.pose, omega)
        return _Match(result.pose, result.covariance, match.how, omega) \
            if self._fits(result) else match

    def _moving(self, points: FloatArray, pose: FloatArray) -> NDArray[np.bool_]:
        """Which ``points`` (``base``) at ``pose`` lie in free space the recent scans saw."""
        if self._free is None or len(points) == 0:
            return np.zeros(len(points), dtype=bool)
        moving = self._free.moving(geometry.transform_points(pose, points))
        if moving.mean() > self.MOVING_SHARE:
            return np.zeros(len(points), dtype=bool)
        return moving

    # ------------------------------------------------------------------ the local map
    def _local_field(self, ref: sm.PointCloudReference, around: FloatArray
                     ) -> correlative.LikelihoodField | None:
        """The local map's likelihood field within ``max_range`` of ``around`` (cached while
        the local map stays)."""
        cached = self._field
        if cached is not None and cached[0] == self._reference_key and \
                np.hypot(*(cached[1] - around[:2])) < 2.0:
            return cached[2]
        cfg = self.config
        near = ref.points[np.hypot(*(ref.points - around[:2]).T) <= cfg.max_range]
        if len(near) < 10:
            return None
        field_ = correlative.likelihood_field(near, cfg.loop_resolution, cfg.loop_resolution,
                                              margin=cfg.search_linear_window + 0.5)
        self._field = (self._reference_key, around[:2].copy(), field_)
        return field_

    def _local_reference(self) -> sm.PointCloudReference | None:
        key = (len(self.nodes), self._optimisations)
        if key != self._reference_key:
            first = max(0, len(self.nodes) - self.config.local_map_nodes)
            self._reference = self._reference_for(range(first, len(self.nodes)))
            self._reference_key = key
        return self._reference

    def _reference_for(self, nodes: Iterable[int]) -> sm.PointCloudReference | None:
        """The nodes' scans at their current poses, with the normals each node's own scan
        gave (rotated along), as one ICP reference."""
        poses = self.graph.poses
        points, normals = [], []
        for k in nodes:
            pts, nrm = self.nodes[k].surface(self.config.icp)
            if len(pts):
                c, s = math.cos(poses[k, 2]), math.sin(poses[k, 2])
                rot = np.array([[c, s], [-s, c]])
                points.append(pts @ rot + poses[k, :2])
                normals.append(nrm @ rot)
        if not points:
            return None
        ref = sm.PointCloudReference(np.vstack(points), self.config.icp, np.vstack(normals))
        return ref if ref.tree is not None else None

    def _insert_free(self, index: int) -> None:
        """Node ``index``'s beams into the free space (its moving returns only clear)."""
        free, node = self._free, self.nodes[index]
        if free is None or node.beams is None:
            return
        if free.scans >= 2 * self.config.dynamic_nodes:  # forget the older nodes
            self._rebuild_free()
            return
        ends, valid, clear = node.beams
        used = valid | clear
        moving = node.moving if node.moving is not None else np.zeros(len(valid), bool)
        sensor, in_map = laser_beams(self.graph.poses[index], self.base_to_laser, ends[used])
        free.insert(sensor, in_map, (valid & ~moving)[used])

    def _rebuild_free(self) -> None:
        if self._free is None:
            return
        self._free.clear()
        first = max(0, len(self.nodes) - self.config.dynamic_nodes)
        for k in range(first, len(self.nodes)):
            self._insert_free(k)

    # ------------------------------------------------------------------ the graph
    def _add_node(self, scan: msgs.LaserScan, match: _Match, points: FloatArray,
                  beams: tuple[FloatArray, NDArray[np.bool_], NDArray[np.bool_]],
                  moving: NDArray[np.bool_], beam_motion: FloatArray | None,
                  odom: FloatArray, previous: int) -> int:
        cfg = self.config
        prev_pose = self.graph.poses[previous]
        index = self.graph.add_node(match.pose)
        self.nodes.append(_Node(len(self.records), points, self._travelled, scan, beam_motion,
                                odom.copy(), self._turned, moving, beams))
        self._add_odometry_edge(previous, index)
        if match.how != "odometry":
            self.backend.add_match(previous, index, geometry.relative(prev_pose, match.pose),
                                   relative_covariance(prev_pose, match.scan_covariance()))
        self._insert_free(index)
        due = index % max(cfg.loop_every, 1) == 0 and \
            index - self._last_closure > cfg.loop_cooldown
        if due and self._close_loop(index):
            self._last_closure = index
        return index

    def _add_odometry_edge(self, i: int, j: int) -> None:
        """The odometry's relative pose between nodes ``i`` and ``j``, trusted to the
        odometry model over the driving and turning between them."""
        a_xy, s_xy, a_th, s_th = self.config.odometry_noise
        ni, nj = self.nodes[i], self.nodes[j]
        sd_xy = a_xy * (nj.travelled - ni.travelled) + s_xy
        sd_th = a_th * (nj.turned - ni.turned) + s_th
        self.backend.add_odometry(i, j, geometry.relative(ni.odometry, nj.odometry), sd_xy,
                                  sd_th)

    # ------------------------------------------------------------------ loop closure
    def loop_candidate(self, index: int) -> int | None:
        """The nearest node within ``loop_search_radius`` of node ``index`` that was passed
        at least ``loop_min_travel`` metres of driving ago (``None`` if there is none)."""
        cfg = self.config
        poses = self.graph.poses
        travelled = np.array([n.travelled for n in self.nodes[:index]])
        old = np.flatnonzero(travelled <= self.nodes[index].travelled - cfg.loop_min_travel)
        if len(old) == 0:
            return None
        d = np.hypot(*(poses[old, :2] - poses[index, :2]).T)
        k = int(np.argmin(d))
        return int(old[k]) if d[k] <= cfg.loop_search_radius else None

    def _close_loop(self, index: int) -> bool:
        """Search for a closure from node ``index`` (:func:`kit.slam.loops.match_loop`);
        an accepted one enters the graph under a Cauchy kernel and the graph is solved."""
        cfg = self.config
        candidate = self.loop_candidate(index)
        if candidate is None or len(self.nodes[index].points) < 20:
            return False
        chain = range(max(0, candidate - cfg.loop_chain),
                      min(index - 1, candidate + cfg.loop_chain + 1))
        poses = self.graph.poses
        clouds = [geometry.transform_points(poses[k], self.nodes[k].points) for k in chain]
        reference = thin(np.vstack(clouds), cfg.point_spacing)
        if len(reference) < 20:
            return False
        record = LoopClosure(index, candidate)
        recent = [geometry.transform_points(poses[k], self.nodes[k].points)
                  for k in range(max(candidate + 1, index - cfg.loop_recent_nodes), index)]
        travel = self.nodes[index].travelled - self.nodes[candidate].travelled
        fine = match_loop(record, self.nodes[index].points, reference, poses[index],
                          np.vstack(recent) if recent else np.zeros((0, 2)), travel, cfg)
        if fine is None:
            self.backend.closures.append(record)
            return False
        nearest = min(chain, key=lambda k: float(np.hypot(*(poses[k, :2] - fine.pose[:2]))))
        record.reference = nearest
        record.measurement = geometry.relative(poses[nearest], fine.pose)
        record.covariance = relative_covariance(poses[nearest], fine.covariance)
        if self.backend.propose(record):
            self._optimised()
        return record.accepted

    # ------------------------------------------------------------------ results
    def optimize(self, iterations: int = 20) -> None:
        """A final solve of the whole graph (after the last scan), with the edges' χ²
        checked as after every closure."""
        if self.graph.num_edges:
            self.backend.optimise(iterations, 1e-9)
            self._optimised()

    def _optimised(self) -> None:
        """After a solve: the local map and the free space follow the new poses."""
        self._optimisations += 1
        self._rebuild_free()

    def trajectory(self) -> tuple[FloatArray, FloatArray]:
        """``(stamps (N,), poses (N, 3))``: every scan's ``T_map_base`` from the current
        graph."""
        poses = self.graph.poses
        stamps = np.array([r.stamp for r in self.records])
        if not self.records:
            return stamps, np.zeros((0, 3))
        anchors = np.array([r.anchor for r in self.records])
        offsets = np.array([r.offset for r in self.records])
        return stamps, geometry.compose(poses[anchors], offsets)

    def occupancy_map(self, resolution: float = 0.05,
                      model: mapping.InverseSensorModel | None = None,
                      progress: Callable[[int], object] | None = None
                      ) -> mapping.OccupancyGridMap:
        """The map rebuilt from every node's scan (de-skewed) at its optimised pose; returns
        found to move only clear the cells their beams crossed."""
        grid = mapping.OccupancyGridMap(resolution, model=model)
        poses = self.graph.poses
        for k, node in enumerate(self.nodes):
            if node.scan is not None:
                ends, hits = map_beams(node.scan, self.base_to_laser, node.beam_motion,
                                       grid.model.max_clear_range)
                if node.moving is not None:
                    used = perception.valid_returns(node.scan) | \
                        perception.max_range_beams(node.scan)
                    hits = hits & ~node.moving[used]
                laser = geometry.compose(poses[k], self.base_to_laser)
                grid.insert_points(laser[:2], geometry.transform_points(poses[k], ends), hits)
            if progress is not None:
                progress(1)
        return grid


def map_beams(scan: msgs.LaserScan, base_to_laser: ArrayLike, beam_motion: FloatArray | None,
              max_clear_range: float = math.inf) -> tuple[FloatArray, NDArray[np.bool_]]:
    """End points in ``base`` (de-skewed like :func:`scan_points`) of the beams a map update
    uses, and whether each is a hit: valid returns end where they hit (clearing only, if
    beyond ``max_clear_range``), max-range beams end at ``range_max`` (REP-117)."""
    r = np.asarray(scan.ranges, dtype=np.float64)
    valid = perception.valid_returns(scan)
    clear = perception.max_range_beams(scan)
    reach = min(float(scan.range_max), max_clear_range)
    used = valid | clear
    length = np.where(valid, np.minimum(np.nan_to_num(r), reach), reach)[used]
    a = perception.beam_angles(scan)[used]
    local = np.column_stack([length * np.cos(a), length * np.sin(a)])
    mount = geometry.check_pose(base_to_laser)
    sensor = geometry.compose(np.asarray(beam_motion)[used], mount) if beam_motion is not None \
        else np.broadcast_to(mount, (len(a), 3))
    c, s = np.cos(sensor[:, 2]), np.sin(sensor[:, 2])
    ends = np.column_stack([sensor[:, 0] + c * local[:, 0] - s * local[:, 1],
                            sensor[:, 1] + s * local[:, 0] + c * local[:, 1]])
    hits = np.asarray((valid & (np.nan_to_num(r) <= reach))[used], dtype=np.bool_)
    return np.asarray(ends, dtype=np.float64), hits

"""The SLAM front end, in SLAM Toolbox's design (Macenski & Jambrecic, JOSS 2021; Karto).

For every scan, with the odometry pose it was taken at:

1. **Predict** the scan's pose in ``map`` from the last corrected scan and the odometry since.
2. **Match** it against the local map — the scans of the last ``local_map_nodes`` nodes at
   their current poses — by point-to-line ICP with the prediction as a prior
   (:func:`kit.slam.scan_matching.icp`); a poor match keeps the prediction.
3. **Add a node** when the robot has travelled ``min_travel`` metres or turned
   ``min_heading`` radians since the last one: the node's pose is the corrected pose, and an
   edge to the previous node carries the match's relative pose and information.
4. **Close loops** from a new node: nodes within ``loop_search_radius`` that were passed at
   least ``loop_min_travel`` metres of driving ago are candidates; the scans around the
   nearest one form a reference, the correlative matcher searches a window around the
   current estimate, and a match whose *response* reaches ``loop_min_response`` and whose
   covariance stays under ``loop_max_variance`` is refined by ICP and added as an edge (under
   a Cauchy kernel, so one wrong closure cannot bend the map). The graph is then optimised
   (Gauss–Newton) and every pose after it follows.

Every scan's pose is kept relative to the node before it, so the trajectory follows the
optimised graph; :meth:`Slam.occupancy_map` rebuilds the map from the nodes' scans at their
optimised poses. ``map`` coincides with ``odom`` at the first scan.

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
from kit.slam import scan_matching as sm
from kit.slam.pose_graph import PoseGraph

__all__ = ["ScanRecord", "Slam", "SlamConfig", "map_beams", "relative_covariance", "scan_points"]

FloatArray = NDArray[np.float64]


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
    """An ICP match that did not converge, or whose residuals' RMS exceeds this [m], is
    searched again correlatively; the search's answer is kept when it puts 5 % more of the
    scan's points within 0.1 m of the local map."""
    search_linear_window: float = 0.3
    """Half-width [m] of that correlative search around the prediction."""
    search_angular_window: float = math.radians(20.0)
    """Half-width [rad] of that search (odometry's heading can jump this much)."""
    search_prior_scale: float = 0.01
    """The odometry prior's information is scaled by this for the ICP after the search."""
    odometry_noise: tuple[float, float, float, float] = (0.1, 0.02, 0.2, math.radians(1.0))
    """(α_xy, σ_xy, α_θ, σ_θ): the odometry between two scans is trusted to
    ``α_xy d + σ_xy`` [m] and ``α_θ |Δθ| + σ_θ`` [rad] (d the distance driven); an assumption."""
    min_edge_sigma: tuple[float, float] = (0.005, math.radians(0.2))
    """Floor on an edge's standard deviation (m, rad): matches are not perfect."""
    loop_search_radius: float = 4.0
    """Loop-closure candidates lie within this distance [m] (``loop_search_maximum_distance``)."""
    loop_min_travel: float = 10.0
    """… and were passed at least this much driving [m] ago."""
    loop_chain: int = 10
    """Nodes on each side of the candidate whose scans form the loop's reference."""
    loop_linear_window: float = 1.0
    """Half-width of the correlative search [m]."""
    loop_angular_window: float = 0.3
    """Half-width of the correlative search [rad]."""
    loop_resolution: float = 0.05
    """Correlative grid cell [m]."""
    loop_min_response: float = 0.45
    """Minimum mean likelihood (``loop_match_minimum_response_fine``)."""
    loop_max_variance: float = 0.05
    """Maximum positional variance [m²] of an accepted match."""
    loop_min_support: float = 0.7
    """Share of the scan's points the refined match must put within 0.1 m of the reference."""
    loop_max_shift: tuple[float, float] = (0.3, 0.03)
    """A closure may move the node by at most ``a + b · d`` metres, ``d`` the driving [m]
    since the candidate: the drift scan matching can have accumulated (an assumption)."""
    loop_max_turn: tuple[float, float] = (math.radians(3.0), math.radians(0.3))
    """… and turn it by at most ``a + b · d`` radians."""
    loop_kernel_delta: float = 3.0
    """Cauchy kernel width on loop edges (in √χ² units)."""
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


@dataclass(frozen=True)
class ScanRecord:
    """A scan's place in the trajectory: its pose relative to the node before it."""

    stamp: float
    anchor: int
    offset: FloatArray
    """``T_anchor_base`` of this scan."""
    odometry: FloatArray
    """``T_odom_base`` of this scan."""


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
    """Thinned points in ``base``."""
    travelled: float
    """Distance driven from the start to this node [m]."""
    scan: msgs.LaserScan | None
    beam_motion: FloatArray | None
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


class Slam:
    """Online graph SLAM: feed :meth:`add_scan` one scan and its odometry at a time.

    Parameters
    ----------
    base_to_laser
        ``T_base_laser`` (x, y, θ) of the scanner on the robot.
    config
        :class:`SlamConfig`.
    """

    def __init__(self, base_to_laser: ArrayLike = (0.0, 0.0, 0.0),
                 config: SlamConfig | None = None) -> None:
        self.config = config or SlamConfig()
        self.base_to_laser = geometry.check_pose(base_to_laser, "base_to_laser").copy()
        self.graph = PoseGraph()
        self.records: list[ScanRecord] = []
        self.nodes: list[_Node] = []
        self.loop_closures: list[tuple[int, int]] = []
        self._last_pose: FloatArray | None = None   # T_map_base of the last scan
        self._last_odom: FloatArray | None = None
        self._travelled = 0.0
        self._reference: sm.PointCloudReference | None = None
        self._reference_key: tuple[int, int] = (-1, -1)
        self._field: tuple[tuple[int, int], FloatArray, sm.LikelihoodField] | None = None
        self._optimisations = 0
        self._last_closure = -(10**9)

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
        points = thin(scan_points(scan, self.base_to_laser, beam_motion, cfg.max_range),
                      cfg.point_spacing)
        if self._last_pose is None or self._last_odom is None:
            return self._first(scan, odom, t, points, beam_motion)
        step = geometry.relative(self._last_odom, odom)
        self._travelled += float(np.hypot(step[0], step[1]))
        predicted = geometry.compose(self._last_pose, step)
        pose, covariance = self._match(points, predicted, step)
        anchor = len(self.nodes) - 1
        node_pose = self.graph.poses[anchor]
        since = geometry.relative(node_pose, pose)
        if math.hypot(since[0], since[1]) >= cfg.min_travel or abs(since[2]) >= cfg.min_heading:
            anchor = self._add_node(scan, pose, covariance, points, beam_motion, anchor)
            pose = self.graph.poses[anchor]
            since = np.zeros(3)
        self.records.append(ScanRecord(t, anchor, since, odom.copy()))
        self._last_pose, self._last_odom = pose, odom.copy()
        return pose

    def _first(self, scan: msgs.LaserScan, odom: FloatArray, t: float, points: FloatArray,
               beam_motion: FloatArray | None) -> FloatArray:
        self.graph.add_node(odom)
        self.nodes.append(_Node(0, points, 0.0, scan, beam_motion))
        self.records.append(ScanRecord(t, 0, np.zeros(3), odom.copy()))
        self._last_pose, self._last_odom = odom.copy(), odom.copy()
        return odom.copy()

    def _prior_information(self, step: FloatArray) -> FloatArray:
        a_xy, s_xy, a_th, s_th = self.config.odometry_noise
        d = float(np.hypot(step[0], step[1]))
        sd_xy, sd_th = a_xy * d + s_xy, a_th * abs(float(step[2])) + s_th
        # isotropic in x and y, so the same in the map frame as in the robot's
        return np.diag([1 / sd_xy**2, 1 / sd_xy**2, 1 / sd_th**2])

    def _match(self, points: FloatArray, predicted: FloatArray, step: FloatArray
               ) -> tuple[FloatArray, FloatArray]:
        """ICP of the scan against the local map, from and held by the prediction; when that
        match looks poor, a correlative search around the prediction (which a wrong start
        cannot trap) followed by ICP from its answer, keeping the better of the two."""
        omega = self._prior_information(step)
        ref = self._local_reference()
        fallback = (predicted, np.asarray(np.linalg.inv(omega), dtype=np.float64))
        if ref is None or len(points) < 10:
            return fallback
        result = sm.icp(points, ref, predicted, omega)
        if result.converged and result.rmse <= self.config.poor_rmse:
            return result.pose, result.covariance
        support = _support(points, ref, result.pose)
        field = self._local_field(ref, predicted)
        if field is not None:
            cfg = self.config
            coarse = sm.correlative_match(points, field, predicted, cfg.search_linear_window,
                                          cfg.search_angular_window, math.radians(0.5))
            second = sm.icp(points, ref, coarse.pose, omega * cfg.search_prior_scale)
            if _support(points, ref, second.pose) > support + 0.05:
                result = second
        if result.inlier_fraction < self.config.min_inliers:
            return fallback
        return result.pose, result.covariance

    def _local_field(self, ref: sm.PointCloudReference, around: FloatArray
                     ) -> sm.LikelihoodField | None:
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
        field = sm.likelihood_field(near, cfg.loop_resolution, cfg.loop_resolution,
                                    margin=cfg.search_linear_window + 0.5)
        self._field = (self._reference_key, around[:2].copy(), field)
        return field

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

    def _add_node(self, scan: msgs.LaserScan, pose: FloatArray, covariance: FloatArray,
                  points: FloatArray, beam_motion: FloatArray | None, previous: int) -> int:
        cfg = self.config
        prev_pose = self.graph.poses[previous]
        index = self.graph.add_node(pose)
        self.nodes.append(_Node(len(self.records), points, self._travelled, scan, beam_motion))
        info = self._edge_information(relative_covariance(prev_pose, covariance))
        self.graph.add_edge(previous, index, geometry.relative(prev_pose, pose), info)
        due = index % max(cfg.loop_every, 1) == 0 and \
            index - self._last_closure > cfg.loop_cooldown
        if due and self._close_loop(index):
            self._last_closure = index
            self.graph.optimize("gn", max_iterations=10, tolerance=1e-6)
            self._optimisations += 1
        return index

    def _edge_information(self, covariance: FloatArray) -> FloatArray:
        """``Σ⁻¹``, with the standard deviations floored at ``min_edge_sigma``."""
        sd_xy, sd_th = self.config.min_edge_sigma
        cov = 0.5 * (covariance + covariance.T) + np.diag([sd_xy**2, sd_xy**2, sd_th**2])
        return np.asarray(np.linalg.inv(cov))

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
        source = self.nodes[index].points
        field = sm.likelihood_field(reference, cfg.loop_resolution, cfg.loop_resolution,
                                    margin=cfg.loop_linear_window + 0.5)
        coarse = sm.correlative_match(source, field, poses[index], cfg.loop_linear_window,
                                      cfg.loop_angular_window,
                                      angular_step=math.radians(0.5))
        if coarse.response < cfg.loop_min_response or \
                max(coarse.covariance[0, 0], coarse.covariance[1, 1]) > cfg.loop_max_variance:
            return False
        ref = sm.PointCloudReference(reference, cfg.icp)
        if ref.tree is None:
            return False
        fine = sm.icp(source, ref, coarse.pose)
        if not fine.converged or _support(source, ref, fine.pose) < cfg.loop_min_support:
            return False
        # the correction must be one the drift since the candidate could have caused
        travel = self.nodes[index].travelled - self.nodes[candidate].travelled
        shift = geometry.relative(poses[index], fine.pose)
        if math.hypot(shift[0], shift[1]) > cfg.loop_max_shift[0] + cfg.loop_max_shift[1] * \
                travel or abs(shift[2]) > cfg.loop_max_turn[0] + cfg.loop_max_turn[1] * travel:
            return False
        nearest = min(chain, key=lambda k: float(np.hypot(*(poses[k, :2] - fine.pose[:2]))))
        info = self._edge_information(relative_covariance(poses[nearest], fine.covariance))
        self.graph.add_edge(nearest, index, geometry.relative(poses[nearest], fine.pose), info,
                            kernel="cauchy", delta=cfg.loop_kernel_delta)
        self.loop_closures.append((nearest, index))
        return True

    # ------------------------------------------------------------------ results
    def optimize(self, iterations: int = 20) -> None:
        """A final solve of the whole graph (after the last scan)."""
        if self.graph.num_edges:
            self.graph.optimize("gn", max_iterations=iterations, tolerance=1e-9)
            self._optimisations += 1

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
                      progress: Callable[[int], object] | None = None,
                      update: Callable[..., ArrayLike] | None = None
                      ) -> mapping.OccupancyGridMap:
        """The map rebuilt from every node's scan (de-skewed) at its optimised pose
        (``update``: see :class:`kit.mapping.OccupancyGridMap`)."""
        grid = mapping.OccupancyGridMap(resolution, model=model, update=update)
        poses = self.graph.poses
        for k, node in enumerate(self.nodes):
            if node.scan is not None:
                ends, hits = map_beams(node.scan, self.base_to_laser, node.beam_motion,
                                       grid.model.max_clear_range)
                laser = geometry.compose(poses[k], self.base_to_laser)
                grid.insert_points(laser[:2], geometry.transform_points(poses[k], ends), hits)
            if progress is not None:
                progress(1)
        return grid


def _support(points: FloatArray, ref: sm.PointCloudReference, pose: FloatArray,
             within: float = 0.1) -> float:
    """Share of ``points`` placed at ``pose`` that lie within ``within`` metres of the
    reference: how well two candidate matches agree with the local map."""
    assert ref.tree is not None
    d, _ = ref.tree.query(geometry.transform_points(pose, points), k=1,
                          distance_upper_bound=within)
    return float(np.mean(d < np.inf))


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

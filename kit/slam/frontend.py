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
from kit.slam.config import SlamConfig
from kit.slam.free_space import FreeSpace, laser_beams
from kit.slam.loops import LoopClosure, LoopReference, match_loop
from kit.slam.matching import Match, match_scan, prior_information, refine
from kit.slam.pose_graph import PoseGraph

__all__ = ["LoopClosure", "ScanRecord", "Slam", "SlamConfig", "map_beams", "relative_covariance",
           "scan_points"]

FloatArray = NDArray[np.float64]
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
    # return_index gives each cell's first point (np.unique sorts stably for it)
    _, first = np.unique(correlative.cell_keys(cells), return_index=True)
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
        self._held: tuple[FloatArray, FloatArray] | None = None
        """(odometry, T_map_base) of the scan before the odometry began repeating itself."""
        self._travelled = 0.0
        self._turned = 0.0
        self._reference: sm.PointCloudReference | None = None
        self._reference_key: tuple[int, int] = (-1, -1)
        self._field: tuple[tuple[int, int], FloatArray, correlative.LikelihoodField] | None = None
        self._optimisations = 0
        self._loop_cache: tuple[range, FloatArray, LoopReference] | None = None
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
        repeated = bool(np.all(np.abs(step) < 1e-9))
        if repeated and self._held is None:
            self._held = (self._last_odom.copy(), self._last_pose.copy())
        elif not repeated and self._held is not None:
            # The odometry moves again after repeating one reading: a robot standing still,
            # or odometry that stalled while the scans went on moving (CSAIL's log repeats
            # one reading for four scans of a 75°/s turn, then jumps 85.5°). The jump holds
            # all the motion since the reading it repeated, some of which the scans in
            # between have already found: predicted from the scan before the repeats, the
            # guess is right in both cases; from the last scan, it counts that motion twice.
            held_odom, held_pose = self._held
            step = geometry.relative(held_odom, odom)
            predicted = geometry.compose(held_pose, step)
            self._held = None
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

    def _match(self, points: FloatArray, predicted: FloatArray, step: FloatArray) -> Match:
        """The scan's pose against the local map (:func:`kit.slam.matching.match_scan`)."""
        omega = prior_information(step, self.config.odometry_noise)
        ref = self._local_reference()
        return match_scan(points, predicted, omega, ref,
                          lambda: self._local_field(ref, predicted) if ref else None,
                          self.config)

    def _refine(self, points: FloatArray, match: Match, step: FloatArray) -> Match:
        """ICP again from ``match`` once more returns were found to move."""
        omega = prior_information(step, self.config.odometry_noise)
        return refine(points, match, omega, self._local_reference(), self.config)

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
        return ref if len(ref.points) else None

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
    def _add_node(self, scan: msgs.LaserScan, match: Match, points: FloatArray,
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
        reference = self._loop_reference(chain, poses)
        if len(reference.points) < 20:
            return False
        record = LoopClosure(index, candidate)
        recent = [geometry.transform_points(poses[k], self.nodes[k].points)
                  for k in range(max(candidate + 1, index - cfg.loop_recent_nodes), index)]
        travel = self._drift_path(index, candidate)
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

    def _drift_path(self, index: int, candidate: int) -> float:
        """The driving [m] along which drift can lie between node ``index`` and an older
        ``candidate``: the shortest way between them through the graph, along the chain of
        nodes and across the closures accepted so far (each of which ties its two nodes
        together). A robot that was just tied to the old part of the map cannot have drifted
        from it by the whole way round since the candidate."""
        from scipy.sparse import csr_array
        from scipy.sparse.csgraph import dijkstra

        closures = self.backend.loop_closures
        if not closures:
            return self.nodes[index].travelled - self.nodes[candidate].travelled
        keys = sorted({index, candidate, *(k for pair in closures for k in pair)})
        at = {k: n for n, k in enumerate(keys)}
        travelled = np.array([self.nodes[k].travelled for k in keys])
        ways = np.abs(travelled[:, None] - travelled[None, :])     # along the chain
        for a, b in closures:
            ways[at[a], at[b]] = ways[at[b], at[a]] = 1e-9        # across a closure
        # sparse, as a dense matrix's tiny entries would be read as no way at all
        return float(dijkstra(csr_array(ways), indices=at[index])[at[candidate]])

    def _loop_reference(self, chain: range, poses: FloatArray) -> LoopReference:
        """The scans of the nodes ``chain`` at ``poses``, thinned, as a loop's reference; the
        last one is reused (with its likelihood field and ICP reference) while its nodes and
        their poses stay the same."""
        cached = self._loop_cache
        if cached is not None and cached[0] == chain and np.array_equal(cached[1], poses[chain]):
            return cached[2]
        clouds = [geometry.transform_points(poses[k], self.nodes[k].points) for k in chain]
        reference = LoopReference(thin(np.vstack(clouds), self.config.point_spacing),
                                  self.config)
        self._loop_cache = (chain, poses[chain].copy(), reference)
        return reference

    # ------------------------------------------------------------------ results
    def optimize(self, iterations: int = 20) -> None:
        """The run's end (after the last scan): the closures still waiting for another to
        agree are settled (:meth:`kit.slam.backend.Backend.settle`), then a final solve of
        the whole graph, with the edges' χ² checked as after every closure."""
        if self.graph.num_edges:
            self.backend.settle()
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
                      progress: Callable[[int], object] | None = None,
                      update: Callable[..., ArrayLike] | None = None
                      ) -> mapping.OccupancyGridMap:
        """The map rebuilt from every node's scan (de-skewed) at its optimised pose; returns
        found to move only clear the cells their beams crossed (``update``: see
        :class:`kit.mapping.OccupancyGridMap`)."""
        grid = mapping.OccupancyGridMap(resolution, model=model, update=update)
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

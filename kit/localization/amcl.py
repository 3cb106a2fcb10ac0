"""The AMCL node: Nav2's parameters, update thresholds, pose output and ``map → odom``.

:class:`Amcl` runs the particle filter of :mod:`kit.localization.particles` with a sensor
model of :mod:`kit.localization.likelihood_field` the way Nav2's ``amcl`` node does:

* a scan updates the filter only after the odometry has moved more than ``update_min_d`` in x
  or in y, or turned more than ``update_min_a`` since the last update (the first scan after an
  initialisation always updates);
* ``max_beams`` beams are used, their bearings taken into ``base_frame_id`` through the
  scanner's mounting (a scanner rotated or upside down is handled), ranges beyond
  ``laser_max_range``/below ``laser_min_range`` clipped as AMCL does;
* the estimate is the heaviest cluster's mean with the set's covariance, published as a
  ``PoseWithCovarianceStamped`` in ``global_frame_id`` (6 × 6 covariance over x, y, z, roll,
  pitch, yaw: the x–y block and the yaw variance filled);
* the localizer does not move the robot's odometry: it publishes the correction
  ``T_map_odom = T_map_base · T_odom_base⁻¹`` stamped ``transform_tolerance`` after the scan, so
  that ``map → odom → base_link`` places the robot in the map.

:func:`load_parameters` reads a Nav2 parameter file as it is (``amcl: ros__parameters:``, or
the bare mapping). :func:`localize` runs the node over a time-ordered message stream — a ROS 2
bag's ``/scan``, ``/tf``, ``/tf_static`` — through a :class:`kit.tf.TransformTree`, so the
same code localizes the simulator's bags and real ones.

Beyond Nav2 (each a kit parameter, named here): ``ess_threshold`` — resample only when the
effective sample size falls below this share of the particles (1.0 resamples on every
``resample_interval``-th update, as Nav2); ``deskew`` (default on) — each beam is placed where
the scanner was at that beam's own time, by the odometry (:func:`kit.perception.
scan_to_points_tf`), where Nav2 takes a whole scan from the pose at its stamp: a 5.5 Hz
RPLidar on a robot turning at 1 rad/s bends its scan by 10° from first to last beam;
``beam_lookup`` — the beam model's expected ranges as AMCL measures them (``cells``, the
default) or from the scanner's exact position (``exact``). Not
implemented: ``do_beamskip`` (refused) and the omnidirectional motion model (refused).
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs
from kit.localization.likelihood_field import (
    BeamModel,
    LikelihoodField,
    LikelihoodFieldModel,
    Lookup,
    beam_endpoints,
    beam_model_weights,
    likelihood_field_weights,
)
from kit.localization.particles import ParticleFilter, Sampler, uniform_free_poses
from kit.perception import reverse_beam_order, scan_to_points_tf
from kit.tf import ExtrapolationError, RigidTransform, TransformTree

__all__ = [
    "SCAN_TIMINGS",
    "Amcl",
    "AmclParameters",
    "LocalizationStep",
    "load_parameters",
    "localize",
]

FloatArray = NDArray[np.float64]
_DIFFERENTIAL = ("nav2_amcl::DifferentialMotionModel", "differential")


@dataclass(frozen=True)
class AmclParameters:
    """Nav2 ``amcl`` parameters, by Nav2's names, with Nav2's defaults.

    Parameters that concern ROS plumbing only (topics, QoS, saving the pose to a file) are
    kept so that a Nav2 file loads unchanged, and have no effect here.
    """

    alpha1: float = 0.2
    alpha2: float = 0.2
    alpha3: float = 0.2
    alpha4: float = 0.2
    alpha5: float = 0.2
    base_frame_id: str = "base_footprint"
    beam_skip_distance: float = 0.5
    beam_skip_error_threshold: float = 0.9
    beam_skip_threshold: float = 0.3
    do_beamskip: bool = False
    global_frame_id: str = "map"
    lambda_short: float = 0.1
    laser_likelihood_max_dist: float = 2.0
    laser_max_range: float = 100.0
    laser_min_range: float = -1.0
    laser_model_type: str = "likelihood_field"
    set_initial_pose: bool = False
    initial_pose_x: float = 0.0
    initial_pose_y: float = 0.0
    initial_pose_z: float = 0.0
    initial_pose_yaw: float = 0.0
    max_beams: int = 60
    max_particles: int = 2000
    min_particles: int = 500
    odom_frame_id: str = "odom"
    pf_err: float = 0.05
    pf_z: float = 0.99
    recovery_alpha_fast: float = 0.0
    recovery_alpha_slow: float = 0.0
    resample_interval: int = 1
    robot_model_type: str = "nav2_amcl::DifferentialMotionModel"
    save_pose_rate: float = 0.5
    sigma_hit: float = 0.2
    tf_broadcast: bool = True
    transform_tolerance: float = 1.0
    update_min_a: float = 0.2
    update_min_d: float = 0.25
    z_hit: float = 0.5
    z_max: float = 0.05
    z_rand: float = 0.5
    z_short: float = 0.05
    always_reset_initial_pose: bool = False
    first_map_only: bool = False
    freespace_downsampling: bool = False
    initialize_at_saved_pose: bool = False
    saved_pose_filepath: str = "/tmp/amcl_saved_pose"
    scan_topic: str = "scan"
    map_topic: str = "map"
    allow_parameter_qos_overrides: bool = True
    random_seed: int = -1
    use_sim_time: bool = False
    ess_threshold: float = 0.5
    """kit: resample when N_eff < ess_threshold · N (Nav2 has no such test)."""
    recovery_reset: bool = True
    """kit: restart the recovery averages after random particles were drawn (Nav2's rule);
    False keeps them, as *Probabilistic Robotics*' table 8.3 does."""
    deskew: bool = True
    """kit: place each beam where the scanner was at that beam's time (the odometry through
    tf), instead of taking the whole scan from the pose at its stamp as Nav2 does."""
    beam_lookup: Lookup = "cells"
    """kit: the beam model's expected range — ``cells``, AMCL's ``map_calc_range`` (between
    cell centres, along Bresenham's line), or ``exact`` (from the scanner to where the ray
    enters the first blocked cell); see :func:`kit.localization.expected_ranges`."""

    def __post_init__(self) -> None:
        for name in ("alpha1", "alpha2", "alpha3", "alpha4", "alpha5", "z_hit", "z_rand",
                     "z_short", "z_max", "lambda_short", "update_min_d", "update_min_a"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"amcl parameter {name} must be >= 0; got {getattr(self, name)}")
        if not (self.sigma_hit > 0 and self.laser_likelihood_max_dist > 0 and self.pf_err > 0):
            raise ValueError("sigma_hit, laser_likelihood_max_dist and pf_err must be positive")
        if not 1 <= self.min_particles <= self.max_particles:
            raise ValueError(f"need 1 <= min_particles <= max_particles; got "
                             f"{self.min_particles}, {self.max_particles}")
        if self.max_beams < 2:
            raise ValueError(f"max_beams must be at least 2; got {self.max_beams}")
        if self.resample_interval < 1:
            raise ValueError(f"resample_interval must be >= 1; got {self.resample_interval}")
        if not (0 <= self.recovery_alpha_slow <= 1 and 0 <= self.recovery_alpha_fast <= 1):
            raise ValueError("recovery_alpha_slow and recovery_alpha_fast lie in [0, 1]")
        if not 0 < self.ess_threshold <= 1:
            raise ValueError(f"ess_threshold lies in (0, 1]; got {self.ess_threshold}")
        if self.laser_model_type not in ("likelihood_field", "likelihood_field_prob", "beam"):
            raise ValueError(f"laser_model_type is likelihood_field, likelihood_field_prob or "
                             f"beam; got {self.laser_model_type!r}")
        if self.beam_lookup not in ("cells", "exact"):
            raise ValueError(f"beam_lookup is cells or exact; got {self.beam_lookup!r}")
        if self.robot_model_type not in _DIFFERENTIAL:
            raise ValueError(f"only the differential-drive motion model is implemented; got "
                             f"robot_model_type {self.robot_model_type!r}")
        if self.do_beamskip:
            raise ValueError("do_beamskip: true is not implemented by the kit's AMCL")

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> AmclParameters:
        """Parameters from Nav2's ``ros__parameters`` mapping (``initial_pose`` nested or as
        ``initial_pose.x`` …). Unknown names are ignored with a warning, as a ROS node ignores
        undeclared parameters; a value of the wrong type raises ``TypeError``."""
        flat: dict[str, Any] = {}
        for key, value in values.items():
            if key == "initial_pose" and isinstance(value, Mapping):
                for sub, v in value.items():
                    flat[f"initial_pose_{sub}"] = v
            else:
                flat[str(key).replace(".", "_")] = value
        fields = {f.name: f for f in dataclasses.fields(cls)}
        known: dict[str, Any] = {}
        for key, value in flat.items():
            if key not in fields:
                warnings.warn(f"amcl parameter {key!r} is not one the kit knows; ignored",
                              stacklevel=2)
                continue
            known[key] = _typed(key, value, type(getattr(cls(), key)))
        return cls(**known)

    @property
    def alphas(self) -> FloatArray:
        return np.array([self.alpha1, self.alpha2, self.alpha3, self.alpha4])

    @property
    def initial_pose(self) -> FloatArray:
        return np.array([self.initial_pose_x, self.initial_pose_y, self.initial_pose_yaw])


def _typed(name: str, value: Any, kind: type) -> Any:
    if kind is bool:
        if not isinstance(value, bool):
            raise TypeError(f"amcl parameter {name} is a bool; got {value!r}")
        return value
    if kind is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise TypeError(f"amcl parameter {name} is an integer; got {value!r}")
        return value
    if kind is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise TypeError(f"amcl parameter {name} is a number; got {value!r}")
        return float(value)
    if not isinstance(value, str):
        raise TypeError(f"amcl parameter {name} is a string; got {value!r}")
    return value


def load_parameters(path: str | Path, node: str = "amcl") -> AmclParameters:
    """Read a Nav2 parameter file: ``{node: {ros__parameters: {...}}}`` (also under a
    ``/**`` or namespaced key), or a bare mapping of parameters."""
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    p = Path(path)
    try:
        data = YAML(typ="safe", pure=True).load(p.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ValueError(f"{p}: no such parameter file") from None
    except (YAMLError, UnicodeDecodeError) as exc:
        raise ValueError(f"{p}: not valid YAML ({exc})") from None
    if not isinstance(data, dict):
        raise ValueError(f"{p}: a parameter file is a YAML mapping")
    section = _find_section(data, node)
    if section is None:
        if any(isinstance(v, dict) and "ros__parameters" in v for v in data.values()):
            raise ValueError(f"{p}: no '{node}' node with ros__parameters in the file")
        section = data
    return AmclParameters.from_mapping(section)


def _find_section(data: Mapping[str, Any], node: str) -> Mapping[str, Any] | None:
    for key, value in data.items():
        if not isinstance(value, Mapping):
            continue
        if str(key).strip("/").split("/")[-1] == node and "ros__parameters" in value:
            return value["ros__parameters"] or {}
        if "ros__parameters" not in value:
            found = _find_section(value, node)
            if found is not None:
                return found
    return None


@dataclass(frozen=True)
class _LaserGeometry:
    position: FloatArray
    bearings: FloatArray


def laser_geometry(scan: msgs.LaserScan, T_base_laser: RigidTransform) -> _LaserGeometry:
    """The scanner's ``(x, y)`` in base and every beam's bearing in base: the beam direction
    rotated through the full 3-D mounting (as AMCL transforms ``angle_min`` and the
    increment)."""
    a = scan.angles()
    directions = np.column_stack([np.cos(a), np.sin(a), np.zeros_like(a)])
    in_base = geometry.quaternion_rotate(T_base_laser.rotation[None, :], directions)
    return _LaserGeometry(T_base_laser.translation[:2].copy(),
                          np.arctan2(in_base[:, 1], in_base[:, 0]))


class Amcl:
    """Monte Carlo localization as Nav2's ``amcl`` node does it (see the module docstring).

    Parameters
    ----------
    grid : msgs.OccupancyGrid
        The map, in ``global_frame_id``.
    params : AmclParameters, optional
        Nav2's parameters.
    seed : int, optional
        Seeds the filter's random numbers (else ``params.random_seed`` if >= 0, else fresh).
    odometry_control, log_likelihoods, normalize, should_resample, sampler : callable, optional
        Pieces of the filter written elsewhere (a lab's exercises), each used in place of
        the kit's own; ``None`` keeps the kit's. ``odometry_control(odom_previous,
        odom_current) -> (δrot1, δtrans, δrot2)``; ``log_likelihoods(poses (N, 3),
        endpoints (M, 2) in base, distance (H, W) [m], resolution [m], origin (x, y) [m],
        z_hit, z_rand, sigma_hit, range_max) -> (N,)``, the product of the beams' likelihood
        field summed as logs (so ``laser_model_type`` must be ``likelihood_field_prob``, and
        the map's origin must not be rotated); ``normalize(log_weights) -> weights``;
        ``should_resample(weights, ess_threshold) -> bool``, in place of
        ``N_eff < ess_threshold · N``; ``sampler(weights, n, r) -> indices``, a low-variance
        sampler given its offset ``r`` (:data:`kit.localization.particles.Sampler`).
    """

    def __init__(self, grid: msgs.OccupancyGrid, params: AmclParameters | None = None,
                 seed: int | None = None, *,
                 odometry_control: Callable[..., ArrayLike] | None = None,
                 log_likelihoods: Callable[..., ArrayLike] | None = None,
                 normalize: Callable[[FloatArray], ArrayLike] | None = None,
                 should_resample: Callable[[FloatArray, float], bool] | None = None,
                 sampler: Sampler | None = None) -> None:
        self.params = params or AmclParameters()
        self.field = LikelihoodField.from_grid(grid, self.params.laser_likelihood_max_dist)
        if log_likelihoods is not None and (
                self.params.laser_model_type != "likelihood_field_prob" or self.field.origin[2]):
            raise ValueError("a log_likelihoods function computes the likelihood field's "
                             "product: it needs laser_model_type 'likelihood_field_prob' and a "
                             "map whose origin is not rotated")
        self.odometry_control = odometry_control
        self.log_likelihoods = log_likelihoods
        self.normalize = normalize
        self.should_resample = should_resample
        self.sampler = sampler
        if seed is None and self.params.random_seed >= 0:
            seed = self.params.random_seed
        self.rng = np.random.default_rng(seed)
        self.filter: ParticleFilter | None = None
        self._odom_last: FloatArray | None = None
        self._force_update = False
        self._resample_count = 0
        self._geometry: tuple[tuple[Any, ...], _LaserGeometry] | None = None
        self.estimate: tuple[FloatArray, FloatArray] | None = None
        """(mean (3,), covariance (3, 3)) in ``map`` after the last update."""
        self.map_to_odom: FloatArray | None = None
        """``T_map_odom`` (x, y, θ) after the last update."""
        self.stamp: msgs.Time | None = None
        self.updates = 0

    # ------------------------------------------------------------------ initialisation
    def initialize(self, pose: ArrayLike, covariance: ArrayLike | None = None) -> None:
        """Start from a pose estimate (``/initialpose``): ``max_particles`` particles drawn
        from a normal distribution; ``covariance`` (3, 3) over (x, y, θ) defaults to Nav2's
        0.5², 0.5², (π/12)²."""
        cov = np.diag([0.25, 0.25, (math.pi / 12) ** 2]) if covariance is None else \
            np.asarray(covariance, dtype=np.float64)
        self.filter = ParticleFilter.gaussian(pose, cov, self.params.max_particles, self.rng)
        self._restart()

    def initialize_global(self, particles: int | None = None) -> None:
        """Global localization (Nav2's ``reinitialize_global_localization``): particles spread
        uniformly over the map's free cells with uniform headings; ``particles`` defaults to
        ``max_particles``."""
        n = self.params.max_particles if particles is None else int(particles)
        self.filter = ParticleFilter.from_poses(uniform_free_poses(self.field, n, self.rng),
                                                self.rng)
        self._restart()

    def _restart(self) -> None:
        self._odom_last = None
        self._resample_count = 0
        self.estimate = None

    def _random_poses(self, n: int) -> FloatArray:
        return uniform_free_poses(self.field, n, self.rng)

    # ------------------------------------------------------------------ the update
    def should_update(self, odom_pose: ArrayLike) -> bool:
        """Nav2's ``shouldUpdateFilter``: moved > ``update_min_d`` in x or y, or turned >
        ``update_min_a`` since the last update (or the first scan)."""
        if self._odom_last is None or self._force_update:
            return True
        p = geometry.check_pose(odom_pose, "odom_pose")
        d = p - self._odom_last
        return bool(abs(d[0]) > self.params.update_min_d or abs(d[1]) > self.params.update_min_d
                    or abs(float(geometry.wrap_angle(d[2]))) > self.params.update_min_a)

    def _laser(self, scan: msgs.LaserScan, T_base_laser: RigidTransform) -> _LaserGeometry:
        key = (scan.header.frame_id, len(scan.ranges), scan.angle_min, scan.angle_increment,
               tuple(T_base_laser.translation), tuple(T_base_laser.rotation))
        if self._geometry is None or self._geometry[0] != key:
            self._geometry = (key, laser_geometry(scan, T_base_laser))
        return self._geometry[1]

    def _log_likelihoods(self, scan: msgs.LaserScan, laser: _LaserGeometry,
                         points: FloatArray | None) -> tuple[FloatArray, int]:
        """Log-likelihood of every particle, and the number of beams used."""
        assert self.filter is not None
        p = self.params
        if not scan.range_max > 0:
            raise ValueError(f"scan range_max must be positive; got {scan.range_max}")
        range_max = min(scan.range_max, p.laser_max_range) if p.laser_max_range > 0 \
            else scan.range_max
        range_min = max(scan.range_min, p.laser_min_range) if p.laser_min_range > 0 \
            else scan.range_min
        ranges = np.asarray(scan.ranges, dtype=np.float64)
        if p.laser_model_type == "beam":
            step = max(1, (len(ranges) - 1) // (p.max_beams - 1))
            r = np.where(ranges <= range_min, range_max, ranges)[::step]
            model = BeamModel(p.z_hit, p.z_short, p.z_max, p.z_rand, p.sigma_hit,
                              p.lambda_short, p.beam_lookup)
            return beam_model_weights(self.filter.poses, r, laser.bearings[::step],
                                      laser.position, self.field, model, range_max), \
                int(np.count_nonzero(~np.isnan(r)))
        endpoints = beam_endpoints(ranges, laser.bearings, laser.position, range_min,
                                   range_max, p.max_beams, points)
        if self.log_likelihoods is not None:
            f = self.field
            ll = np.asarray(self.log_likelihoods(self.filter.poses.copy(), endpoints, f.distance,
                                                 f.resolution, f.origin[:2].copy(), p.z_hit,
                                                 p.z_rand, p.sigma_hit, range_max), dtype=float)
            if ll.shape != (len(self.filter),):
                raise ValueError(f"log_likelihoods must return one value per particle, shape "
                                 f"({len(self.filter)},); got {ll.shape}")
            return ll, len(endpoints)
        lf = LikelihoodFieldModel(p.z_hit, p.z_rand, p.sigma_hit,
                                  "amcl" if p.laser_model_type == "likelihood_field" else "product")
        return likelihood_field_weights(self.filter.poses, endpoints, self.field, lf,
                                        range_max), len(endpoints)

    def process(self, scan: msgs.LaserScan, odom_pose: ArrayLike,
                T_base_laser: RigidTransform, points: ArrayLike | None = None) -> bool:
        """Feed one scan with the odometry pose ``T_odom_base`` (x, y, θ) at its stamp and the
        scanner's mounting ``T_base_laser``; returns whether the filter was updated.

        ``points`` (N, 2): every beam's endpoint in base at the stamp, de-skewed (NaN for
        beams without a return); without them the beams are taken from the stamp's pose
        (the beam model always does that)."""
        if self.filter is None:
            raise RuntimeError("AMCL has no initial pose: call initialize(pose) or "
                               "initialize_global() first")
        odom = geometry.check_pose(odom_pose, "odom_pose")
        if not self.should_update(odom):
            return False
        p = self.params
        if self._odom_last is not None:
            self.filter.predict(self._odom_last, odom, p.alphas, self.odometry_control)
        given = None if points is None else np.asarray(points, dtype=np.float64)
        ll, beams = self._log_likelihoods(scan, self._laser(scan, T_base_laser), given)
        self.filter.weigh(ll, p.recovery_alpha_slow, p.recovery_alpha_fast,
                          max(1, beams) if p.laser_model_type == "likelihood_field_prob" else 1,
                          self.normalize)
        recovering = (p.recovery_alpha_slow > 0 or p.recovery_alpha_fast > 0) and \
            self.filter.random_share() > 0
        self._resample_count += 1
        degenerate = (bool(self.should_resample(self.filter.weights.copy(), p.ess_threshold))
                      if self.should_resample is not None else
                      self.filter.effective_sample_size() < p.ess_threshold * len(self.filter))
        if self._resample_count % p.resample_interval == 0 and (recovering or degenerate):
            self.filter.resample(p.pf_err, p.pf_z, p.min_particles, p.max_particles,
                                 self._random_poses if recovering else None, p.recovery_reset,
                                 self.sampler)
        self._odom_last = odom
        self._force_update = False
        self.estimate = self.filter.estimate()
        self.map_to_odom = geometry.compose(self.estimate[0], geometry.inverse(odom))
        self.stamp = scan.header.stamp
        self.updates += 1
        return True

    def force_update(self) -> None:
        """Nav2's ``request_nomap``-free "no-motion update": the next scan updates."""
        self._force_update = True

    # ------------------------------------------------------------------ outputs
    def pose_in_map(self, odom_pose: ArrayLike) -> FloatArray:
        """``T_map_base`` for an odometry pose, through the last ``map → odom``."""
        if self.map_to_odom is None:
            raise RuntimeError("no map -> odom yet: the filter has not been updated")
        return geometry.compose(self.map_to_odom, geometry.check_pose(odom_pose, "odom_pose"))

    def pose_message(self) -> msgs.PoseWithCovarianceStamped:
        """The last estimate as AMCL publishes it on ``amcl_pose``."""
        if self.estimate is None or self.stamp is None:
            raise RuntimeError("no estimate yet: the filter has not been updated")
        mean, cov = self.estimate
        c6 = np.zeros((6, 6))
        c6[:2, :2] = cov[:2, :2]
        c6[5, 5] = cov[2, 2]
        q = geometry.yaw_to_quaternion(mean[2])
        return msgs.PoseWithCovarianceStamped(
            msgs.Header(self.stamp, self.params.global_frame_id),
            msgs.PoseWithCovariance(msgs.Pose(msgs.Point(float(mean[0]), float(mean[1]), 0.0),
                                              msgs.Quaternion(*map(float, q))), c6.ravel()))

    def transform_message(self) -> msgs.TransformStamped:
        """``map → odom`` as AMCL broadcasts it: stamped ``transform_tolerance`` after the
        scan, so that it stays usable until then."""
        if self.map_to_odom is None or self.stamp is None:
            raise RuntimeError("no map -> odom yet: the filter has not been updated")
        stamp = msgs.Time.from_sec(self.stamp.to_sec() + self.params.transform_tolerance)
        t = RigidTransform.from_pose2d(self.map_to_odom)
        return msgs.TransformStamped(msgs.Header(stamp, self.params.global_frame_id),
                                     self.params.odom_frame_id, t.to_msg())


_Found = tuple[FloatArray, RigidTransform, FloatArray | None]


@dataclass(frozen=True)
class LocalizationStep:
    """What :func:`localize` reports for one scan."""

    scan: msgs.LaserScan
    pose: FloatArray
    """``T_map_base`` (x, y, θ) at the scan's stamp; NaN while unknown (no odometry yet)."""
    std: FloatArray
    """Standard deviations of the last estimate (x [m], y [m], θ [rad]); NaN while unknown."""
    odom_pose: FloatArray
    """``T_odom_base`` at the stamp (NaN without odometry)."""
    T_base_laser: RigidTransform | None
    updated: bool
    particles: FloatArray | None = field(default=None, repr=False)
    """The particles after an update (None when the filter did not update)."""


SCAN_TIMINGS = ("ros", "rplidar_ros")


def localize(messages: Iterable[tuple[str, msgs.Message]], node: Amcl, *,
             scan_topic: str = "/scan", tf_topic: str = "/tf",
             tf_static_topic: str = "/tf_static",
             scan_timing: str = "ros") -> Iterator[LocalizationStep]:
    """Run ``node`` over time-ordered ``(topic, message)`` pairs (a bag's messages).

    ``scan_timing`` says when the scanner measured each beam: ``"ros"`` as the
    ``LaserScan`` convention has it (beam ``i`` at ``stamp + i * time_increment``);
    ``"rplidar_ros"`` as the RPLidar's ROS driver publishes (the beams in the reverse order
    of measurement and the stamp at the end of the revolution). Such scans are first put in
    measurement order with :func:`kit.perception.reverse_beam_order`, so each step's scan, its
    stamp and its pose are those of the scan's first measured beam.

    Transforms go into a :class:`TransformTree`; a scan waits (as behind tf2's message filter)
    until the odometry covers its stamp, then goes through :meth:`Amcl.process`. One
    :class:`LocalizationStep` per scan, in order; a scan the odometry never covers (before its
    first sample, or after its last) is reported with NaN poses.
    """
    if scan_timing not in SCAN_TIMINGS:
        raise ValueError(f"scan_timing is one of {', '.join(SCAN_TIMINGS)}; got {scan_timing!r}")
    p = node.params
    tree = TransformTree(cache_time=30.0)
    waiting: deque[msgs.LaserScan] = deque()
    newest = -math.inf  # the newest dynamic transform's stamp [s]

    def odom_at(scan: msgs.LaserScan) -> _Found:
        t = scan.header.stamp
        odom = tree.lookup_pose2d(p.odom_frame_id, p.base_frame_id, t)
        mount = tree.lookup_transform(p.base_frame_id, scan.header.frame_id, t)
        points = None
        if p.deskew and p.laser_model_type != "beam" and scan.time_increment > 0 and \
                node.should_update(odom):
            points = scan_to_points_tf(scan, tree, p.base_frame_id, p.odom_frame_id,
                                       all_beams=True)
        return odom, mount, points

    def attempt(scan: msgs.LaserScan) -> tuple[str, _Found | None]:
        try:
            return "now", odom_at(scan)
        except ExtrapolationError:
            last = scan.header.stamp.to_sec() + scan.time_increment * (len(scan.ranges) - 1)
            return ("later" if last >= newest else "never"), None
        except LookupError:  # frames not yet known: /tf_static or odometry still to come
            return "later", None

    for topic, message in messages:
        if topic == tf_static_topic and isinstance(message, msgs.TFMessage):
            tree.add_message(message, static=True)
        elif topic == tf_topic and isinstance(message, msgs.TFMessage):
            tree.add_message(message)
            newest = max([newest, *(t.header.stamp.to_sec() for t in message.transforms)])
        elif topic == scan_topic and isinstance(message, msgs.LaserScan):
            waiting.append(message if scan_timing == "ros" else
                           reverse_beam_order(message, stamped_at_end=True))
        while waiting:
            state, found = attempt(waiting[0])
            if state == "later":
                break
            yield _step(node, waiting.popleft(), found)
    for scan in waiting:
        yield _step(node, scan, None)


def _step(node: Amcl, scan: msgs.LaserScan, found: _Found | None) -> LocalizationStep:
    nan3 = np.full(3, np.nan)
    if found is None:
        return LocalizationStep(scan, nan3, nan3, nan3, None, False)
    odom, T_base_laser, points = found
    updated = node.process(scan, odom, T_base_laser, points)
    if node.map_to_odom is None or node.estimate is None:
        return LocalizationStep(scan, nan3, nan3, odom, T_base_laser, updated)
    cov = node.estimate[1]
    std = np.sqrt(np.maximum(np.diag(cov), 0.0))
    particles = node.filter.poses.copy() if updated and node.filter is not None else None
    return LocalizationStep(scan, node.pose_in_map(odom), std, odom, T_base_laser, updated,
                            particles)

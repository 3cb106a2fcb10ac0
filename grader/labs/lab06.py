"""Lab 06 — perception (see): the exercises, their cases and their known mistakes.

Students write a scan's beam angles, its valid returns (REP-117), its points in another frame,
one beam de-skewed to the scan's reference time, and a depth camera's range along the ray;
:mod:`kit.perception` is the reference for each.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import geometry, msgs, perception

_BLOCKED = tuple(f"kit.perception:{name}" for name in (
    "beam_angles", "valid_returns", "max_range_beams", "scan_to_points", "beam_to_point",
    "deskew_beam", "scan_to_points_tf", "depth_to_range", "depth_image_to_scan"))


def _scan(ranges: Any, angle_min: float = 0.0, angle_increment: float = 0.1,
          range_min: float = 0.0, range_max: float = 1e9) -> msgs.LaserScan:
    r = np.asarray(ranges, dtype=np.float32)
    return msgs.LaserScan(angle_min=angle_min,
                          angle_max=angle_min + angle_increment * max(len(r) - 1, 0),
                          angle_increment=angle_increment, range_min=range_min,
                          range_max=range_max, ranges=r)


# ---------------------------------------------------------------- beam angles

def _angles(angle_min: float, angle_increment: float, n: int) -> Any:
    return perception.beam_angles(_scan(np.zeros(int(n)), angle_min, angle_increment))


def _angles_linspace(angle_min: float, angle_increment: float, n: int) -> Any:
    """n points from angle_min to angle_min + n · angle_increment, both ends included: they
    are n · angle_increment / (n − 1) apart."""
    return np.linspace(angle_min, angle_min + angle_increment * n, int(n))


def _angles_from_one(angle_min: float, angle_increment: float, n: int) -> Any:
    return angle_min + angle_increment * np.arange(1, int(n) + 1)


def _angles_degrees(angle_min: float, angle_increment: float, n: int) -> Any:
    return np.degrees(angle_min + angle_increment * np.arange(int(n)))


beam_angles = Exercise(
    id="lab06.beam_angles", function="beam_angles", title="The angle of every beam",
    reference=_angles, points=1,
    public=(Case("an RPLidar turn of 360 beams", (-math.pi, 2 * math.pi / 360, 360)),
            Case("the TurtleBot 4's 720 beams", (-3.1241393, 0.0087145, 720)),
            Case("a SICK LMS291 in 0.5° steps", (-math.pi / 2, math.radians(0.5), 361))),
    hidden=lambda rng: [Case(f"random {i}", (float(rng.uniform(-3.1, -0.5)),
                                             float(rng.uniform(0.002, 0.05)),
                                             int(rng.integers(50, 800)))) for i in range(3)],
    rtol=1e-6, atol=1e-6,
    diagnostics=(
        Diagnostic("linspace up to angle_min + n · angle_increment", _angles_linspace,
                   "np.linspace includes its end point: n angles from angle_min to angle_min + "
                   "n · angle_increment are n · angle_increment / (n − 1) apart, not "
                   "angle_increment — the last beam is at angle_min + (n − 1) · "
                   "angle_increment (or use np.arange(n))"),
        Diagnostic("beams counted from 1", _angles_from_one,
                   "the first beam (i = 0) is at angle_min itself: beam i is at angle_min + "
                   "i · angle_increment for i = 0 … n − 1"),
        Diagnostic("degrees", _angles_degrees, "a LaserScan's angles are radians (REP-103)"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- valid returns

def _valid(ranges: Any, range_min: float, range_max: float) -> Any:
    return perception.valid_returns(_scan(ranges, range_min=range_min, range_max=range_max))


def _valid_finite_only(ranges: Any, range_min: float, range_max: float) -> Any:
    return np.isfinite(np.asarray(ranges, dtype=np.float32))


def _valid_positive(ranges: Any, range_min: float, range_max: float) -> Any:
    with np.errstate(invalid="ignore"):
        return np.asarray(ranges, dtype=np.float32) > 0


def _valid_exclusive(ranges: Any, range_min: float, range_max: float) -> Any:
    r = np.asarray(ranges, dtype=np.float32)
    with np.errstate(invalid="ignore"):
        return np.isfinite(r) & (r > range_min) & (r < range_max)


_MIXED = np.array([1.0, np.inf, -np.inf, np.nan, 0.1, 6.5, 3.2, 12.0])


def _valid_hidden(rng: np.random.Generator) -> list[Case]:
    """Every case holds each kind of non-return (REP-117's +inf, -inf and NaN, a finite
    reading on either side of the limits) and a reading exactly on each limit; the limits and
    readings are float32 numbers, as a LaserScan carries them, so "on the limit" is exact."""
    cases = []
    for i in range(3):
        range_min = float(rng.integers(2, 5)) / 16          # 0.125 … 0.25 m
        range_max = float(rng.integers(24, 49)) / 4         # 6 … 12 m
        r = rng.uniform(0.0, 15.0, 30).astype(np.float32).astype(float)
        r[rng.random(30) < 0.1] = np.inf
        r[rng.random(30) < 0.05] = np.nan
        r[rng.random(30) < 0.05] = -np.inf
        special = [range_min, range_max, np.inf, -np.inf, np.nan, range_min / 2,
                   range_max + float(rng.uniform(0.5, 2.0)), float(rng.uniform(1.0, 5.0))]
        r[rng.choice(30, len(special), replace=False)] = np.asarray(
            special, dtype=np.float32).astype(float)
        cases.append(Case(f"random {i}", (r, range_min, range_max)))
    return cases


valid_returns = Exercise(
    id="lab06.valid_returns", function="valid_returns", title="Valid returns (REP-117)",
    reference=_valid, points=2,
    public=(Case("every kind of reading", (_MIXED, 0.15, 12.0)),
            Case("an RPLidar's limits", (_MIXED, 0.15, 6.0))),
    hidden=_valid_hidden,
    diagnostics=(
        Diagnostic("range limits ignored", _valid_finite_only,
                   "a reading below range_min or above range_max is not a measurement: keep "
                   "range_min <= r <= range_max"),
        Diagnostic("inf taken for a return", _valid_positive,
                   "REP-117: +inf means nothing was seen within range_max, -inf an object "
                   "too close, NaN no reading — none of them is a point"),
        Diagnostic("the limits excluded", _valid_exclusive,
                   "a reading exactly at range_min or range_max is a return: keep "
                   "range_min <= r <= range_max (<=, not <)"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- points in a frame

def _points(ranges: Any, angle_min: float, angle_increment: float, range_min: float,
            range_max: float, T_target_laser: Any) -> Any:
    return perception.scan_to_points(_scan(ranges, angle_min, angle_increment, range_min,
                                           range_max), T_target_laser)


def _points_in_laser(ranges: Any, angle_min: float, angle_increment: float, range_min: float,
                     range_max: float, T_target_laser: Any) -> Any:
    return _points(ranges, angle_min, angle_increment, range_min, range_max, None)


def _points_inverted(ranges: Any, angle_min: float, angle_increment: float, range_min: float,
                     range_max: float, T_target_laser: Any) -> Any:
    return _points(ranges, angle_min, angle_increment, range_min, range_max,
                   geometry.inverse(geometry.check_pose(T_target_laser)))


def _points_translated(ranges: Any, angle_min: float, angle_increment: float,
                       range_min: float, range_max: float, T_target_laser: Any) -> Any:
    T = geometry.check_pose(T_target_laser)
    return _points(ranges, angle_min, angle_increment, range_min, range_max,
                   [T[0], T[1], 0.0])


def _points_rotated_back(ranges: Any, angle_min: float, angle_increment: float,
                         range_min: float, range_max: float, T_target_laser: Any) -> Any:
    """Rᵀ in place of R: the points turned by −θ, then t added."""
    T = geometry.check_pose(T_target_laser)
    laser = _points(ranges, angle_min, angle_increment, range_min, range_max, None)
    return geometry.transform_points([0.0, 0.0, -T[2]], laser) + T[:2]


def _points_hidden(rng: np.random.Generator) -> list[Case]:
    """A mounting turned by about ±90°, one turned by about 180° (its angle given just
    across ±π) and a random one; every mounting is offset from base_link."""
    thetas = [float(rng.choice([-1.0, 1.0])) * math.pi / 2 + float(rng.uniform(-0.1, 0.1)),
              float(rng.choice([-1.0, 1.0])) * (math.pi - float(rng.uniform(0.01, 0.1))),
              float(rng.uniform(-math.pi, math.pi))]
    cases = []
    for i, theta in enumerate(thetas):
        r = rng.uniform(0.2, 8.0, 24)
        r[rng.random(24) < 0.15] = np.inf
        r[int(rng.integers(24))] = np.nan
        T = [float(rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.3)),
             float(rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.2)), theta]
        cases.append(Case(f"random {i}", (r, -math.pi, 2 * math.pi / 24, 0.15, 12.0, T)))
    return cases


scan_to_points = Exercise(
    id="lab06.scan_to_points", function="scan_to_points", title="Beams into base_link",
    reference=_points, points=3,
    public=(Case("the Uiabot's RPLidar, 10 cm ahead", (np.array([1.0, 2.0, np.inf, 1.5]),
                                                       -math.pi, math.pi / 2, 0.15, 12.0,
                                                       [0.1, 0.0, 0.0])),
            Case("the TurtleBot 4's lidar, turned +90°",
                 (np.array([1.0, 1.0, 1.0, np.nan]), 0.0, math.pi / 2, 0.15, 12.0,
                  [0.0039, 0.0, math.pi / 2]))),
    hidden=_points_hidden, rtol=1e-6, atol=1e-6,
    diagnostics=(
        Diagnostic("points left in the laser's frame", _points_in_laser,
                   "apply the mounting T_target_laser: p = R(θ) p_laser + t"),
        Diagnostic("the mounting applied inverted", _points_inverted,
                   "T_target_laser takes laser coordinates into the target frame: rotate by "
                   "+θ and add t, not the inverse"),
        Diagnostic("the mounting's rotation ignored", _points_translated,
                   "the lidar may be mounted turned (the TurtleBot 4's is at +90°): rotate "
                   "the points by the mounting's θ too"),
        Diagnostic("Rᵀ in place of R", _points_rotated_back,
                   "the points turned by −θ: R(θ) = [[cos θ, −sin θ], [sin θ, cos θ]] takes "
                   "laser coordinates into the target frame (x' = x cos θ − y sin θ)"),
    ),
    blocked=_BLOCKED,
    uses=("beam_angles", "valid_returns"),
)


# ---------------------------------------------------------------- de-skewing one beam

def _deskew(r: float, angle: float, laser_at_beam: Any, laser_at_reference: Any) -> Any:
    return perception.deskew_beam(r, angle, laser_at_beam, laser_at_reference)


def _deskew_none(r: float, angle: float, laser_at_beam: Any, laser_at_reference: Any) -> Any:
    return np.array([r * math.cos(angle), r * math.sin(angle)])


def _deskew_reversed(r: float, angle: float, laser_at_beam: Any,
                     laser_at_reference: Any) -> Any:
    return perception.deskew_beam(r, angle, laser_at_reference, laser_at_beam)


def _deskew_not_transposed(r: float, angle: float, laser_at_beam: Any,
                           laser_at_reference: Any) -> Any:
    """T(t_ref)⁻¹ written with R(θ_ref) where its transpose belongs."""
    world = perception.beam_to_point(r, angle, laser_at_beam)
    ref = geometry.check_pose(laser_at_reference)
    return geometry.transform_points([0.0, 0.0, ref[2]], (world - ref[:2])[None, :])[0]


def _deskew_negated(r: float, angle: float, laser_at_beam: Any, laser_at_reference: Any) -> Any:
    """T(t_ref)⁻¹ taken as the pose (−x, −y, −θ): R(−θ_ref) p − t_ref."""
    world = perception.beam_to_point(r, angle, laser_at_beam)
    return geometry.transform_points(-geometry.check_pose(laser_at_reference),
                                     world[None, :])[0]


def _deskew_hidden(rng: np.random.Generator) -> list[Case]:
    """The reference pose away from the origin in every case, its heading near ±π/2 in one,
    the scanner's heading across ±π between the two times in another."""
    headings = [float(rng.choice([-1.0, 1.0])) * math.pi / 2 + float(rng.uniform(-0.3, 0.3)),
                float(rng.choice([-1.0, 1.0])) * (math.pi - float(rng.uniform(0.0, 0.1))),
                float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3))]
    cases = []
    for i, heading in enumerate(headings):
        ref = [float(rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 2)),
               float(rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 2)), heading]
        turn = float(rng.uniform(-0.2, 0.2))
        if i == 1:       # turned through ±π: given wrapped, as odometry reports it
            turn = -float(np.sign(heading)) * float(rng.uniform(0.12, 0.2))
        beam = [ref[0] + float(rng.uniform(-0.05, 0.05)), ref[1] + float(rng.uniform(-0.05, 0.05)),
                float(geometry.wrap_angle(heading - turn if i == 1 else heading + turn))]
        cases.append(Case(f"random {i}", (float(rng.uniform(0.5, 8.0)),
                                          float(rng.uniform(-math.pi, math.pi)), beam, ref)))
    return cases


deskew_beam = Exercise(
    id="lab06.deskew_beam", function="deskew_beam", title="One beam, de-skewed",
    reference=_deskew, points=2,
    public=(Case("turned 0.1 rad since the reference", (1.0, 0.0, [0.0, 0.0, 0.1],
                                                         [0.0, 0.0, 0.0])),
            Case("moved and turned", (3.0, 1.2, [2.05, 1.0, 0.6], [2.0, 1.0, 0.5]))),
    hidden=_deskew_hidden, rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("not de-skewed", _deskew_none,
                   "the beam was measured from where the scanner was at its own time: place "
                   "it with T(t_i), then look at it from T(t_ref): T(t_ref)⁻¹ T(t_i) p"),
        Diagnostic("the two poses swapped", _deskew_reversed,
                   "p_ref = T(t_ref)⁻¹ T(t_i) p: the beam's own pose places the point, the "
                   "reference pose's inverse brings it back"),
        Diagnostic("R in place of Rᵀ in the inverse", _deskew_not_transposed,
                   "T(t_ref)⁻¹ p = R(θ_ref)ᵀ (p − t_ref): the inverse rotates by −θ_ref"),
        Diagnostic("the inverse taken as (−x, −y, −θ)", _deskew_negated,
                   "a pose's inverse is not its negation: T⁻¹ = (−Rᵀ t, −θ), so T(t_ref)⁻¹ p "
                   "= Rᵀ (p − t_ref) — subtract t_ref before rotating back "
                   "(geometry.inverse does it)"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- depth to range

def _range(depth: Any, u: Any, fx: float, cx: float) -> Any:
    return perception.depth_to_range(depth, u, fx, cx)


def _range_is_depth(depth: Any, u: Any, fx: float, cx: float) -> Any:
    return np.asarray(depth, dtype=float) + 0.0 * np.asarray(u, dtype=float)


def _range_x_only(depth: Any, u: Any, fx: float, cx: float) -> Any:
    return np.abs((np.asarray(u, dtype=float) - cx) * np.asarray(depth, dtype=float) / fx)


def _range_times_cos(depth: Any, u: Any, fx: float, cx: float) -> Any:
    """z · cos α where z / cos α belongs (α the ray's angle off the optical axis)."""
    alpha = np.arctan2(np.asarray(u, dtype=float) - cx, fx)
    return np.asarray(depth, dtype=float) * np.cos(alpha)


def _range_offset_unscaled(depth: Any, u: Any, fx: float, cx: float) -> Any:
    """The sideways offset (u − cx) / fx without the depth."""
    return np.hypot((np.asarray(u, dtype=float) - cx) / fx, np.asarray(depth, dtype=float))


def _range_hidden(rng: np.random.Generator) -> list[Case]:
    """Rows of pixels across the whole image, the edges included, at random depths."""
    cases = []
    for i in range(3):
        u = np.concatenate([[0.0, 639.0], rng.uniform(0, 639, 4)])
        cases.append(Case(f"random {i}", (rng.uniform(0.5, 4.5, 6), u, 525.0, 319.5)))
    return cases


depth_to_range = Exercise(
    id="lab06.depth_to_range", function="depth_to_range",
    title="A depth pixel's range along its ray", reference=_range, points=2,
    public=(Case("on the optical axis", (2.0, 319.5, 525.0, 319.5)),
            Case("a row of Eddie's Kinect looking at a wall 2 m away",
                 (np.full(5, 2.0), np.array([0.0, 160.0, 319.5, 480.0, 639.0]), 525.0, 319.5))),
    hidden=_range_hidden, rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("depth along the optical axis taken as the range", _range_is_depth,
                   "a depth camera reports z, the distance along its optical axis; the range "
                   "along the pixel's ray is hypot((u − cx) z / fx, z)"),
        Diagnostic("only the sideways offset", _range_x_only,
                   "the range is the ray's length: hypot of the sideways offset "
                   "(u − cx) z / fx and the depth z"),
        Diagnostic("z · cos α", _range_times_cos,
                   "the ray is longer than z, not shorter: r = z / cos α with "
                   "tan α = (u − cx) / fx, which is hypot((u − cx) z / fx, z)"),
        Diagnostic("the offset (u − cx) / fx without z", _range_offset_unscaled,
                   "(u − cx) / fx is the tangent of the ray's angle; the pixel lies "
                   "(u − cx) z / fx metres beside the axis: multiply by the depth z"),
    ),
    blocked=_BLOCKED,
)


SPEC = LabSpec(name="lab06", title="Perception",
               exercises=(beam_angles, valid_returns, scan_to_points, deskew_beam,
                          depth_to_range))

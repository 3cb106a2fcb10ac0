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
    return np.linspace(angle_min, angle_min + angle_increment * n, int(n))


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
        Diagnostic("linspace over n + 1 points", _angles_linspace,
                   "beam i is at angle_min + i · angle_increment, i = 0 … n − 1: the last beam "
                   "is at angle_min + (n − 1) · angle_increment, not at n increments"),
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


_MIXED = np.array([1.0, np.inf, -np.inf, np.nan, 0.1, 6.5, 3.2, 12.0])


def _valid_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        r = rng.uniform(0.0, 15.0, 30)
        r[rng.random(30) < 0.1] = np.inf
        r[rng.random(30) < 0.05] = np.nan
        r[rng.random(30) < 0.05] = -np.inf
        cases.append(Case(f"random {i}", (r, float(rng.uniform(0.1, 0.3)),
                                          float(rng.uniform(6.0, 12.0)))))
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


def _points_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        r = rng.uniform(0.2, 8.0, 24)
        r[rng.random(24) < 0.15] = np.inf
        T = [float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-0.2, 0.2)),
             float(rng.choice([0.0, math.pi / 2, math.pi, -math.pi / 2]) +
                   rng.uniform(-0.1, 0.1))]
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
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- de-skewing one beam

def _deskew(r: float, angle: float, laser_at_beam: Any, laser_at_reference: Any) -> Any:
    return perception.deskew_beam(r, angle, laser_at_beam, laser_at_reference)


def _deskew_none(r: float, angle: float, laser_at_beam: Any, laser_at_reference: Any) -> Any:
    return np.array([r * math.cos(angle), r * math.sin(angle)])


def _deskew_reversed(r: float, angle: float, laser_at_beam: Any,
                     laser_at_reference: Any) -> Any:
    return perception.deskew_beam(r, angle, laser_at_reference, laser_at_beam)


def _deskew_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(4):
        ref = [float(rng.uniform(-2, 2)), float(rng.uniform(-2, 2)), float(rng.uniform(-3, 3))]
        beam = [ref[0] + float(rng.uniform(-0.05, 0.05)), ref[1] + float(rng.uniform(-0.05, 0.05)),
                ref[2] + float(rng.uniform(-0.2, 0.2))]
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


depth_to_range = Exercise(
    id="lab06.depth_to_range", function="depth_to_range",
    title="A depth pixel's range along its ray", reference=_range, points=2,
    public=(Case("on the optical axis", (2.0, 319.5, 525.0, 319.5)),
            Case("a row of Eddie's Kinect looking at a wall 2 m away",
                 (np.full(5, 2.0), np.array([0.0, 160.0, 319.5, 480.0, 639.0]), 525.0, 319.5))),
    hidden=lambda rng: [Case(f"random {i}", (rng.uniform(0.5, 4.5, 6),
                                             rng.uniform(0, 639, 6), 525.0, 319.5))
                        for i in range(3)],
    rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("depth along the optical axis taken as the range", _range_is_depth,
                   "a depth camera reports z, the distance along its optical axis; the range "
                   "along the pixel's ray is hypot((u − cx) z / fx, z)"),
        Diagnostic("only the sideways offset", _range_x_only,
                   "the range is the ray's length: hypot of the sideways offset "
                   "(u − cx) z / fx and the depth z"),
    ),
    blocked=_BLOCKED,
)


SPEC = LabSpec(name="lab06", title="Perception",
               exercises=(beam_angles, valid_returns, scan_to_points, deskew_beam,
                          depth_to_range))

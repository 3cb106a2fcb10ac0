"""Lab 02 — odometry (see): the exercises, their cases and their known mistakes."""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import geometry, msgs
from kit import odometry as odo

_BLOCKED = (
    *(f"kit.odometry:{name}" for name in (
        "conversion_factor", "tick_delta", "ticks_to_travel", "odometry_step",
        "eddie_odometry_step", "integrate_odometry", "odom_transform", "odometry_message")),
    "kit.geometry:yaw_to_quaternion", "kit.geometry:compose")

EDDIE_L = 0.39


# ---------------------------------------------------------------- conversion factor

def _cm_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (float(rng.uniform(0.05, 0.4)), float(rng.choice([1, 5, 20, 50])),
                                 int(rng.choice([100, 144, 400, 1024, 8192]))))
            for i in range(4)]


def _cm_no_pi(d: float, n: float, ce: float) -> Any:
    return d / (n * ce)


def _cm_radius(d: float, n: float, ce: float) -> Any:
    return math.pi * d / 2 / (n * ce)


def _cm_no_gear(d: float, n: float, ce: float) -> Any:
    return math.pi * d / ce


conversion_factor = Exercise(
    id="lab02.conversion_factor", function="conversion_factor", title="Ticks to metres",
    reference=odo.conversion_factor, points=2,
    public=(Case("Eddie", (0.1524, 1.0, 144)), Case("Uiabot", (0.1, 20.0, 20480)),
            Case("IGV", (0.32, 1.0, 400))),
    hidden=_cm_hidden,
    diagnostics=(
        Diagnostic("the formula as printed, c_m = D / (n C_e)", _cm_no_pi,
                   "one wheel turn rolls pi * D: the factor needs pi"),
        Diagnostic("the radius in place of the diameter", _cm_radius,
                   "D is the wheel diameter"),
        Diagnostic("forgetting the gear ratio", _cm_no_gear,
                   "an encoder on the motor counts n C_e per wheel turn: divide by the gear "
                   "ratio n too"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- counter roll-over

def _ticks_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(5):
        bits = int(rng.choice([16, 32]))
        start = int(rng.integers(0, 2**bits))
        step = int(rng.integers(-(2 ** (bits - 2)), 2 ** (bits - 2)))
        cases.append(Case(f"random {i}", (start, (start + step) % 2**bits, bits)))
    return cases


def _ticks_plain(prev: int, cur: int, bits: int = 16) -> Any:
    return cur - prev


def _ticks_never_negative(prev: int, cur: int, bits: int = 16) -> Any:
    return (cur - prev) % 2**bits


tick_delta = Exercise(
    id="lab02.tick_delta", function="tick_delta", title="Encoder counter roll-over",
    reference=odo.tick_delta, points=2,
    public=(Case("forward", (100, 250, 16)), Case("backward", (250, 100, 16)),
            Case("forward through 65535", (65530, 4, 16)),
            Case("backward through 0", (3, 65533, 16)), Case("32-bit", (2**32 - 1, 9, 32))),
    hidden=_ticks_hidden,
    diagnostics=(Diagnostic("a plain difference", _ticks_plain,
                            "the counter wraps modulo 2**counter_bits: take the increment of "
                            "smallest magnitude"),
                 Diagnostic("the increment modulo 2**bits, never negative",
                            _ticks_never_negative,
                            "a wheel turning backwards counts down: an increment of more than "
                            "half the range is a negative one (subtract 2**counter_bits)")),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- Eddie's update (erratum 7)

def _step_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (np.array([*rng.uniform(-5, 5, 2), rng.uniform(-3, 3)]),
                                 float(rng.uniform(-0.05, 0.1)), float(rng.uniform(-0.05, 0.1)),
                                 float(rng.uniform(0.2, 0.8)))) for i in range(5)]


def _eddie_paper(pose: Any, dr: float, dl: float, sep: float) -> Any:
    """The update as printed, heading += (left - right) / separation: the same as swapping
    the wheels, which flips the heading change and keeps the distance."""
    return odo.eddie_odometry_step(pose, dl, dr, sep)


def _eddie_not_wrapped(pose: Any, dr: float, dl: float, sep: float) -> Any:
    p = np.asarray(pose, float)
    theta = p[2] + (dr - dl) / sep
    ds = (dr + dl) / 2
    return np.array([p[0] + ds * math.cos(theta), p[1] + ds * math.sin(theta), theta])


def _eddie_degrees(pose: Any, dr: float, dl: float, sep: float) -> Any:
    p = np.asarray(pose, float)
    theta = p[2] + math.degrees((dr - dl) / sep)
    ds = (dr + dl) / 2
    return np.array([p[0] + ds * math.cos(theta), p[1] + ds * math.sin(theta), theta])


eddie_odometry_step = Exercise(
    id="lab02.eddie_odometry_step", function="eddie_odometry_step",
    title="Find the bug: Eddie's odometry update (erratum 7)",
    reference=odo.eddie_odometry_step, points=2,
    public=(Case("straight", ([0.0, 0.0, 0.0], 0.1, 0.1, EDDIE_L)),
            Case("right wheel further", ([1.0, 2.0, 0.5], 0.12, 0.08, EDDIE_L)),
            Case("spin", ([0.0, 0.0, 3.0], 0.1, -0.1, EDDIE_L))),
    hidden=_step_hidden,
    diagnostics=(
        Diagnostic("the paper's heading update (erratum 7)", _eddie_paper,
                   "(left - right) / separation is clockwise-positive; REP-103 yaw is "
                   "counter-clockwise: use (right - left)"),
        Diagnostic("an unwrapped heading", _eddie_not_wrapped,
                   "wrap the heading with wrap_angle to [-π, π)"),
        Diagnostic("the heading change in degrees", _eddie_degrees,
                   "(Δs_r − Δs_l) / L is already in radians: no degrees"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- exact arc

def _arc_euler(pose: Any, dr: float, dl: float, sep: float) -> Any:
    return odo.odometry_step(pose, dr, dl, sep, method="euler")


def _arc_midpoint(pose: Any, dr: float, dl: float, sep: float) -> Any:
    return odo.odometry_step(pose, dr, dl, sep, method="midpoint")


def _arc_swapped(pose: Any, dr: float, dl: float, sep: float) -> Any:
    return odo.odometry_step(pose, dl, dr, sep)


def _arc_unwrapped(pose: Any, dr: float, dl: float, sep: float) -> Any:
    p = odo.odometry_step(pose, dr, dl, sep)
    p[2] = float(np.asarray(pose, float)[2]) + (dr - dl) / sep
    return p


def _arc_hidden(rng: np.random.Generator) -> list[Case]:
    cases = _step_hidden(rng)
    cases.append(Case("straight", (np.array([*rng.uniform(-5, 5, 2), rng.uniform(-3, 3)]),
                                   0.2, 0.2, float(rng.uniform(0.2, 0.8)))))
    return cases


exact_arc_step = Exercise(
    id="lab02.exact_arc_step", function="exact_arc_step", title="Integration along the arc",
    reference=functools.partial(odo.odometry_step, method="exact"), points=3,
    public=(Case("quarter circle", ([0.0, 0.0, 0.0], math.pi / 4 * 1.2, math.pi / 4 * 0.8, 0.4)),
            Case("straight (Δθ = 0)", ([1.0, 1.0, 1.0], 0.3, 0.3, EDDIE_L)),
            Case("backwards arc", ([0.0, 0.0, -2.0], -0.2, -0.1, EDDIE_L)),
            Case("spin in place", ([0.0, 0.0, 0.0], 0.2, -0.2, EDDIE_L)),
            Case("turning through ±π", ([0.5, -1.0, 3.0], 0.3, 0.1, EDDIE_L))),
    hidden=_arc_hidden,
    diagnostics=(Diagnostic("Euler integration", _arc_euler,
                            "move along the arc: chord Δs·sin(Δθ/2)/(Δθ/2) at heading θ + Δθ/2"),
                 Diagnostic("the mean heading without the chord factor", _arc_midpoint,
                            "the arc's chord is shorter than Δs: multiply by "
                            "sin(Δθ/2)/(Δθ/2) (np.sinc(Δθ / (2π)))"),
                 Diagnostic("an unwrapped heading", _arc_unwrapped,
                            "wrap θ + Δθ with wrap_angle to [-π, π)"),
                 Diagnostic("the wheels swapped", _arc_swapped,
                            "Δθ = (Δs_r − Δs_l) / L, right minus left: a right wheel that "
                            "rolls further turns the robot counter-clockwise")),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- accumulate (erratum 2)

def _path_reference(d_right: Any, d_left: Any, sep: float) -> Any:
    return odo.integrate_odometry(d_right, d_left, sep, method="exact")


def _path_not_accumulated(d_right: Any, d_left: Any, sep: float) -> Any:
    steps = [odo.odometry_step([0.0, 0.0, 0.0], r, left, sep)
             for r, left in zip(d_right, d_left, strict=True)]
    return np.vstack([np.zeros(3), *steps])


def _path_euler(d_right: Any, d_left: Any, sep: float) -> Any:
    return odo.integrate_odometry(d_right, d_left, sep, method="euler")


def _path_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random drive {i}", (rng.uniform(0.0, 0.05, n), rng.uniform(0.0, 0.05, n),
                                       float(rng.uniform(0.2, 0.8))))
            for i, n in enumerate(rng.integers(5, 40, 3))]


integrate_path = Exercise(
    id="lab02.integrate_path", function="integrate_path",
    title="Find the bug: accumulate the pose (erratum 2)",
    reference=_path_reference, points=3,
    public=(Case("circle", (np.full(20, 0.03), np.full(20, 0.01), EDDIE_L)),
            Case("s-bend", (np.r_[np.full(10, 0.03), np.full(10, 0.01)],
                            np.r_[np.full(10, 0.01), np.full(10, 0.03)], EDDIE_L))),
    hidden=_path_hidden,
    diagnostics=(Diagnostic("the paper's pose update (erratum 2)", _path_not_accumulated,
                            "each step must start from the previous pose: x += ..., θ += ..."),
                 Diagnostic("Euler steps in place of the arc", _path_euler,
                            "accumulate with your exact_arc_step, not a first-order step")),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- quaternion

def _quat_full_angle(theta: float) -> Any:
    return np.array([0.0, 0.0, math.sin(theta), math.cos(theta)])


def _quat_wxyz(theta: float) -> Any:
    return np.array([math.cos(theta / 2), 0.0, 0.0, math.sin(theta / 2)])


def _quat_degrees(theta: float) -> Any:
    half = math.radians(theta) / 2
    return np.array([0.0, 0.0, math.sin(half), math.cos(half)])


yaw_to_quaternion = Exercise(
    id="lab02.yaw_to_quaternion", function="yaw_to_quaternion", title="Heading as a quaternion",
    reference=geometry.yaw_to_quaternion, points=2,
    public=(Case("zero", (0.0,)), Case("quarter turn left", (math.pi / 2,)),
            Case("about face", (-3.0,))),
    hidden=lambda rng: [Case(f"random {i}", (float(t),))
                        for i, t in enumerate(rng.uniform(-math.pi, math.pi, 4))],
    diagnostics=(
        Diagnostic("the full angle", _quat_full_angle, "a quaternion holds sin and cos of θ/2"),
        Diagnostic("(w, x, y, z) order", _quat_wxyz, "ROS orders quaternions (x, y, z, w)"),
        Diagnostic("θ taken as degrees", _quat_degrees,
                   "θ is already in radians: no math.radians"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- odom -> base_link

def _tf_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (np.array([*rng.uniform(-10, 10, 2), rng.uniform(-3, 3)]),
                                 msgs.Time(int(rng.integers(0, 1000)),
                                           int(rng.integers(0, 10**9)))))
            for i in range(3)]


def _tf_reversed(pose: Any, stamp: msgs.Time) -> Any:
    return odo.odom_transform(pose, stamp, frame_id="base_link", child_frame_id="odom")


make_odom_transform = Exercise(
    id="lab02.make_odom_transform", function="make_odom_transform",
    title="The odom → base_link transform",
    reference=odo.odom_transform, points=2,
    public=(Case("at the origin", ([0.0, 0.0, 0.0], msgs.Time(0, 0))),
            Case("somewhere", ([1.5, -2.0, 2.0], msgs.Time(12, 500_000_000)))),
    hidden=_tf_hidden,
    diagnostics=(Diagnostic("parent and child swapped", _tf_reversed,
                            "header.frame_id is the parent 'odom'; child_frame_id 'base_link'"),),
    blocked=_BLOCKED,
)


SPEC = LabSpec(
    name="lab02",
    title="Lab 02 — Odometry",
    exercises=(conversion_factor, tick_delta, eddie_odometry_step, exact_arc_step,
               integrate_path, yaw_to_quaternion, make_odom_transform),
)

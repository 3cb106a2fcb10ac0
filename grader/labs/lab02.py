"""Lab 02 — odometry (see): the exercises, their cases and their known mistakes."""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from grader.labs._hidden import telling
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


def _cm_two_pi(d: float, n: float, ce: float) -> Any:
    return 2 * math.pi * d / (n * ce)


def _cm_gear_multiplied(d: float, n: float, ce: float) -> Any:
    return math.pi * d * n / ce


_CM_MISTAKES = (
    Diagnostic("the formula as printed, c_m = D / (n C_e)", _cm_no_pi,
               "one wheel turn rolls pi * D: the factor needs pi"),
    Diagnostic("the radius in place of the diameter", _cm_radius,
               "D is the wheel diameter"),
    Diagnostic("forgetting the gear ratio", _cm_no_gear,
               "an encoder on the motor counts n C_e per wheel turn: divide by the gear "
               "ratio n too"),
    Diagnostic("2π D for the circumference", _cm_two_pi,
               "a wheel of diameter D rolls π D per turn (2π r = π D): 2π goes with the radius"),
    Diagnostic("the gear ratio multiplied", _cm_gear_multiplied,
               "the encoder turns n times per wheel turn, so each count is a smaller "
               "distance: divide by n C_e"),
)

conversion_factor = Exercise(
    id="lab02.conversion_factor", function="conversion_factor", title="Ticks to metres",
    reference=odo.conversion_factor, points=2,
    public=(Case("Eddie", (0.1524, 1.0, 144)), Case("Uiabot", (0.1, 20.0, 20480)),
            Case("IGV", (0.32, 1.0, 400))),
    hidden=telling(_cm_hidden, odo.conversion_factor, _CM_MISTAKES),
    diagnostics=_CM_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- counter roll-over

def _reading(previous: int, step: int, bits: int) -> tuple[int, int, int]:
    return previous, (previous + step) % 2**bits, bits


def _ticks_draw(rng: np.random.Generator) -> list[Case]:
    """Eddie's 16-bit counters forwards through the roll-over, backwards through 0 and
    backwards without one; a 32-bit counter read seldom (tens of thousands of ticks between
    readings, like an ODrive's 20480-count encoder turning 20 times a second read at 10 Hz);
    and any increment within half the range."""
    k = int(rng.integers(1, 400))
    cases = [Case("forward through the roll-over",
                  _reading(2**16 - k, int(rng.integers(k + 1, k + 3000)), 16))]
    k = int(rng.integers(0, 400))
    cases.append(Case("backward through 0", _reading(k, -int(rng.integers(k + 1, k + 3000)), 16)))
    cases.append(Case("backward", _reading(int(rng.integers(5000, 2**16)),
                                           -int(rng.integers(1, 4000)), 16)))
    step = int(rng.choice([-1, 1]) * rng.integers(2**15, 2**20))
    cases.append(Case("32-bit, fast", _reading(int(rng.integers(0, 2**32)), step, 32)))
    bits = int(rng.choice([16, 32]))
    half = 2 ** (bits - 1)
    cases.append(Case("random", _reading(int(rng.integers(0, 2**bits)),
                                         int(rng.integers(-half + 1, half)), bits)))
    return cases


def _ticks_plain(prev: int, cur: int, bits: int = 16) -> Any:
    return cur - prev


def _ticks_never_negative(prev: int, cur: int, bits: int = 16) -> Any:
    return (cur - prev) % 2**bits


def _ticks_16_bits(prev: int, cur: int, bits: int = 16) -> Any:
    return odo.tick_delta(prev, cur, 16)


_TICK_MISTAKES = (
    Diagnostic("a plain difference", _ticks_plain,
               "the counter wraps modulo 2**counter_bits: take the increment of "
               "smallest magnitude"),
    Diagnostic("the increment modulo 2**bits, never negative", _ticks_never_negative,
               "a wheel turning backwards counts down: an increment of more than "
               "half the range is a negative one (subtract 2**counter_bits)"),
    Diagnostic("16 bits whatever counter_bits says", _ticks_16_bits,
               "use counter_bits: a 32-bit counter wraps at 2**32, and its increments can "
               "exceed 2**15"),
)

tick_delta = Exercise(
    id="lab02.tick_delta", function="tick_delta", title="Encoder counter roll-over",
    reference=odo.tick_delta, points=2,
    public=(Case("forward", (100, 250, 16)), Case("backward", (250, 100, 16)),
            Case("forward through 65535", (65530, 4, 16)),
            Case("backward through 0", (3, 65533, 16)), Case("32-bit", (2**32 - 1, 9, 32)),
            Case("32-bit, 40 000 ticks between readings", (4_294_950_000, 22_704, 32))),
    hidden=telling(_ticks_draw, odo.tick_delta, _TICK_MISTAKES),
    diagnostics=_TICK_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- Eddie's update (erratum 7)

def _step_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (np.array([*rng.uniform(-5, 5, 2), rng.uniform(-3, 3)]),
                                 float(rng.uniform(-0.05, 0.1)), float(rng.uniform(-0.05, 0.1)),
                                 float(rng.uniform(0.2, 0.8)))) for i in range(5)]


def _across_pi(rng: np.random.Generator, most: float = 0.05) -> Case:
    """A heading up to ``most`` short of ±π, turning past it by up to ``most`` again."""
    side = float(rng.choice([-1.0, 1.0]))
    short, past = rng.uniform(0.002, most, 2)
    sep = float(rng.uniform(0.2, 0.8))
    d_left = float(rng.uniform(-0.05, 0.1))
    d_right = d_left + side * float(short + past) * sep
    pose = np.array([*rng.uniform(-5, 5, 2), side * (math.pi - float(short))])
    return Case("across ±π", (pose, d_right, d_left, sep))


def _eddie_draw(rng: np.random.Generator) -> list[Case]:
    return [*_step_hidden(rng)[:4], _across_pi(rng)]


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


def _eddie_move_then_turn(pose: Any, dr: float, dl: float, sep: float) -> Any:
    """Euler's order: along the old heading, then turn."""
    p = np.asarray(pose, float)
    ds = (dr + dl) / 2
    return np.array([p[0] + ds * math.cos(p[2]), p[1] + ds * math.sin(p[2]),
                     float(geometry.wrap_angle(p[2] + (dr - dl) / sep))])


_EDDIE_MISTAKES = (
    Diagnostic("the paper's heading update (erratum 7)", _eddie_paper,
               "(left - right) / separation is clockwise-positive; REP-103 yaw is "
               "counter-clockwise: use (right - left)"),
    Diagnostic("an unwrapped heading", _eddie_not_wrapped,
               "wrap the heading with wrap_angle to [-π, π)"),
    Diagnostic("the heading change in degrees", _eddie_degrees,
               "(Δs_r − Δs_l) / L is already in radians: no degrees"),
    Diagnostic("moving along the old heading", _eddie_move_then_turn,
               "Eddie's update turns first, then moves along the NEW heading: update θ "
               "before the cos and sin"),
)

eddie_odometry_step = Exercise(
    id="lab02.eddie_odometry_step", function="eddie_odometry_step",
    title="Find the bug: Eddie's odometry update (erratum 7)",
    reference=odo.eddie_odometry_step, points=2,
    public=(Case("straight", ([0.0, 0.0, 0.0], 0.1, 0.1, EDDIE_L)),
            Case("right wheel further", ([1.0, 2.0, 0.5], 0.12, 0.08, EDDIE_L)),
            Case("spin", ([0.0, 0.0, 3.0], 0.1, -0.1, EDDIE_L))),
    hidden=telling(_eddie_draw, odo.eddie_odometry_step, _EDDIE_MISTAKES),
    diagnostics=_EDDIE_MISTAKES,
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


def _arc_sinc_without_pi(pose: Any, dr: float, dl: float, sep: float) -> Any:
    """np.sinc(Δθ / 2) taken for sin(Δθ/2)/(Δθ/2): numpy's sinc is sin(πx)/(πx)."""
    p = np.asarray(pose, float)
    ds, dtheta = (dr + dl) / 2, (dr - dl) / sep
    chord, heading = ds * float(np.sinc(dtheta / 2)), p[2] + dtheta / 2
    return np.array([p[0] + chord * math.cos(heading), p[1] + chord * math.sin(heading),
                     float(geometry.wrap_angle(p[2] + dtheta))])


def _arc_hidden(rng: np.random.Generator) -> list[Case]:
    """Eddie's short steps, a straight one, one across ±π and a sharp turn between two
    slow readings (where the chord is clearly shorter than the arc)."""
    cases = _step_hidden(rng)[:4]
    cases.append(Case("straight", (np.array([*rng.uniform(-5, 5, 2), rng.uniform(-3, 3)]),
                                   0.2, 0.2, float(rng.uniform(0.2, 0.8)))))
    cases.append(_across_pi(rng))
    sep, dtheta = float(rng.uniform(0.2, 0.8)), float(rng.choice([-1, 1]) * rng.uniform(0.4, 1.0))
    d_left = float(rng.uniform(0.0, 0.3))
    cases.append(Case("a sharp turn", (np.array([*rng.uniform(-5, 5, 2), rng.uniform(-3, 3)]),
                                       d_left + dtheta * sep, d_left, sep)))
    return cases


_ARC_MISTAKES = (
    Diagnostic("Euler integration", _arc_euler,
               "move along the arc: chord Δs·sin(Δθ/2)/(Δθ/2) at heading θ + Δθ/2"),
    Diagnostic("the mean heading without the chord factor", _arc_midpoint,
               "the arc's chord is shorter than Δs: multiply by "
               "sin(Δθ/2)/(Δθ/2) (np.sinc(Δθ / (2π)))"),
    Diagnostic("an unwrapped heading", _arc_unwrapped,
               "wrap θ + Δθ with wrap_angle to [-π, π)"),
    Diagnostic("the wheels swapped", _arc_swapped,
               "Δθ = (Δs_r − Δs_l) / L, right minus left: a right wheel that "
               "rolls further turns the robot counter-clockwise"),
    Diagnostic("np.sinc(Δθ / 2)", _arc_sinc_without_pi,
               "np.sinc(x) is sin(πx)/(πx), not sin(x)/x: the chord factor sin(Δθ/2)/(Δθ/2) "
               "is np.sinc(Δθ / (2π))"),
)

exact_arc_step = Exercise(
    id="lab02.exact_arc_step", function="exact_arc_step", title="Integration along the arc",
    reference=functools.partial(odo.odometry_step, method="exact"), points=3,
    public=(Case("quarter circle", ([0.0, 0.0, 0.0], math.pi / 4 * 1.2, math.pi / 4 * 0.8, 0.4)),
            Case("straight (Δθ = 0)", ([1.0, 1.0, 1.0], 0.3, 0.3, EDDIE_L)),
            Case("backwards arc", ([0.0, 0.0, -2.0], -0.2, -0.1, EDDIE_L)),
            Case("spin in place", ([0.0, 0.0, 0.0], 0.2, -0.2, EDDIE_L)),
            Case("turning through ±π", ([0.5, -1.0, 3.0], 0.3, 0.1, EDDIE_L))),
    hidden=telling(_arc_hidden, functools.partial(odo.odometry_step, method="exact"),
                   _ARC_MISTAKES),
    diagnostics=_ARC_MISTAKES,
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


def _path_without_start(d_right: Any, d_left: Any, sep: float) -> Any:
    return _path_reference(d_right, d_left, sep)[1:]


def _path_one_array(d_right: Any, d_left: Any, sep: float) -> Any:
    """One pose array updated in place and appended at every step: every row is the last."""
    poses = _path_reference(d_right, d_left, sep)
    return np.tile(poses[-1], (len(poses), 1))


_PATH_MISTAKES = (
    Diagnostic("the paper's pose update (erratum 2)", _path_not_accumulated,
               "each step must start from the previous pose: x += ..., θ += ..."),
    Diagnostic("Euler steps in place of the arc", _path_euler,
               "accumulate with your exact_arc_step, not a first-order step"),
    Diagnostic("the start pose left out", _path_without_start,
               "return N + 1 poses: the start (0, 0, 0) first, then one after each interval"),
    Diagnostic("one array appended again and again", _path_one_array,
               "every row is the final pose: the list holds the same array, changed in place "
               "(pose[:] = … or pose += …) — append a new array for each step"),
)

integrate_path = Exercise(
    id="lab02.integrate_path", function="integrate_path",
    title="Find the bug: accumulate the pose (erratum 2)",
    reference=_path_reference, points=3,
    public=(Case("circle", (np.full(20, 0.03), np.full(20, 0.01), EDDIE_L)),
            Case("s-bend", (np.r_[np.full(10, 0.03), np.full(10, 0.01)],
                            np.r_[np.full(10, 0.01), np.full(10, 0.03)], EDDIE_L))),
    hidden=telling(_path_hidden, _path_reference, _PATH_MISTAKES),
    diagnostics=_PATH_MISTAKES,
    blocked=_BLOCKED,
    uses=("exact_arc_step",),
)


# ---------------------------------------------------------------- quaternion

def _quat_full_angle(theta: float) -> Any:
    return np.array([0.0, 0.0, math.sin(theta), math.cos(theta)])


def _quat_wxyz(theta: float) -> Any:
    return np.array([math.cos(theta / 2), 0.0, 0.0, math.sin(theta / 2)])


def _quat_degrees(theta: float) -> Any:
    half = math.radians(theta) / 2
    return np.array([0.0, 0.0, math.sin(half), math.cos(half)])


_QUAT_MISTAKES = (
    Diagnostic("the full angle", _quat_full_angle, "a quaternion holds sin and cos of θ/2"),
    Diagnostic("(w, x, y, z) order", _quat_wxyz, "ROS orders quaternions (x, y, z, w)"),
    Diagnostic("θ taken as degrees", _quat_degrees,
               "θ is already in radians: no math.radians"),
)

yaw_to_quaternion = Exercise(
    id="lab02.yaw_to_quaternion", function="yaw_to_quaternion", title="Heading as a quaternion",
    reference=geometry.yaw_to_quaternion, points=2,
    public=(Case("zero", (0.0,)), Case("quarter turn left", (math.pi / 2,)),
            Case("about face", (-3.0,))),
    hidden=telling(lambda rng: [Case(f"random {i}", (float(t),))
                                for i, t in enumerate(rng.uniform(-math.pi, math.pi, 4))],
                   geometry.yaw_to_quaternion, _QUAT_MISTAKES),
    diagnostics=_QUAT_MISTAKES,
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


def _tf_slashed(pose: Any, stamp: msgs.Time) -> Any:
    return odo.odom_transform(pose, stamp, frame_id="/odom", child_frame_id="/base_link")


_TF_MISTAKES = (
    Diagnostic("parent and child swapped", _tf_reversed,
               "header.frame_id is the parent 'odom'; child_frame_id 'base_link'"),
    Diagnostic("frame ids with a leading slash", _tf_slashed,
               "ROS 2 frame ids have no leading slash (tf2 refuses them): 'odom' and "
               "'base_link'"),
)


make_odom_transform = Exercise(
    id="lab02.make_odom_transform", function="make_odom_transform",
    title="The odom → base_link transform",
    reference=odo.odom_transform, points=2,
    public=(Case("at the origin", ([0.0, 0.0, 0.0], msgs.Time(0, 0))),
            Case("somewhere", ([1.5, -2.0, 2.0], msgs.Time(12, 500_000_000)))),
    hidden=telling(_tf_hidden, odo.odom_transform, _TF_MISTAKES),
    diagnostics=_TF_MISTAKES,
    blocked=_BLOCKED,
    uses=("yaw_to_quaternion",),
)


SPEC = LabSpec(
    name="lab02",
    title="Lab 02 — Odometry",
    exercises=(conversion_factor, tick_delta, eddie_odometry_step, exact_arc_step,
               integrate_path, yaw_to_quaternion, make_odom_transform),
)

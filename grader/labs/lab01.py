"""Lab 01 — kinematics (act): the exercises, their cases and their known mistakes."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grader.labs._hidden import telling
from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import kinematics as kin

IGV_R, IGV_SEP = 0.16, 0.72
EDDIE_R, EDDIE_SEP = 0.0762, 0.39

_BLOCKED = tuple(f"kit.kinematics:{name}" for name in (
    "constraint_matrices", "forward_kinematics", "inverse_kinematics", "motor_speeds_to_twist",
    "twist_to_motor_speeds", "twist_to_wheel_speeds", "wheel_speeds_to_twist", "igv_wheel_rpm",
    "igv_body_velocity", "rpm_to_drive_units", "drive_units_to_rpm", "turning_radius",
    "turning_radius_from_wheels", "icc_body", "saturate_wheel_speeds"))


def _robot_params(rng: np.random.Generator) -> tuple[float, float]:
    """A random wheel radius [m] and wheel separation [m]."""
    return float(rng.uniform(0.03, 0.2)), float(rng.uniform(0.2, 1.0))


def _degrees_last(values: Any) -> Any:
    """The last component (a rate) converted to degrees per second."""
    out = np.array(values, dtype=float)
    out[..., -1] = np.degrees(out[..., -1])
    return out


# ---------------------------------------------------------------- constraint matrices

def _constraints_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"r={r:.3f}, l={sep:.3f}", (r, sep)) for r, sep in
            (_robot_params(rng) for _ in range(4))]


def _constraints_b_is_separation(r: float, sep: float) -> Any:
    return kin.constraint_matrices(r, 2 * sep)


def _constraints_wheels_swapped(r: float, sep: float) -> Any:
    """The rolling rows in (left, right) order: the left wheel's row first."""
    A, B = kin.constraint_matrices(r, sep)
    return A[[1, 0, 2, 3]], B


def _constraints_transposed(r: float, sep: float) -> Any:
    A, B = kin.constraint_matrices(r, sep)
    return A.T, B.T


def _constraints_slide_plus(r: float, sep: float) -> Any:
    """The no-slide rows written +ẏ = 0: the same constraint, not the matrix asked for."""
    A, B = kin.constraint_matrices(r, sep)
    return A * np.array([[1.0], [1.0], [-1.0], [-1.0]]), B


_CONSTRAINT_MISTAKES = (
    Diagnostic("b = the whole wheel separation", _constraints_b_is_separation,
               "b is half the wheel separation: b = wheel_separation / 2"),
    Diagnostic("the left wheel's rolling row first", _constraints_wheels_swapped,
               "row 1 is the right wheel (y = −b: ẋ + b θ̇ = r φ̇_r), row 2 the left"),
    Diagnostic("A and B transposed", _constraints_transposed,
               "A has shape (4, 3) — one row per constraint, one column per "
               "component of ξ — and B (4, 2)"),
    Diagnostic("the no-slide rows as +ẏ = 0", _constraints_slide_plus,
               "the no-slide rows are −ẏ = 0 as derived, [0, −1, 0]: the same constraint "
               "as +ẏ = 0 for the robot, but not the matrix A asked for"),
)

constraint_matrices = Exercise(
    id="lab01.constraint_matrices", function="constraint_matrices", title="Constraint matrices",
    reference=kin.constraint_matrices, points=2,
    public=(Case("Uiabot", (0.05, 0.361)), Case("IGV", (IGV_R, IGV_SEP))),
    hidden=telling(_constraints_hidden, kin.constraint_matrices, _CONSTRAINT_MISTAKES),
    diagnostics=_CONSTRAINT_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- forward kinematics

FK_PUBLIC = (
    Case("straight ahead", ([10.0, 10.0], 0.05, 0.361)),
    Case("right wheel faster", ([12.0, 8.0], 0.05, 0.361)),
    Case("turn in place", ([-5.0, 5.0], 0.05, 0.361)),
    Case("many speeds at once", (np.array([[1.0, 2.0], [3.0, -1.0], [0.0, 4.0]]), IGV_R,
                                 IGV_SEP)),
)


def _fk_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(4):
        r, b = _robot_params(rng)
        cases.append(Case(f"random robot {i}", (rng.uniform(-20, 20, 2), r, b)))
    r, b = _robot_params(rng)
    cases.append(Case("batch", (rng.uniform(-20, 20, (6, 2)), r, b)))
    return cases


def _fk_turns_right(phi: Any, r: float, sep: float) -> Any:
    """Swapped wheels and the paper's sign (erratum 5) give the same numbers: θ̇ negated."""
    return kin.forward_kinematics(phi, r, sep) * np.array([1.0, 1.0, -1.0])


def _fk_b_is_separation(phi: Any, r: float, sep: float) -> Any:
    return kin.forward_kinematics(phi, r, 2 * sep)


def _fk_degrees(phi: Any, r: float, sep: float) -> Any:
    return _degrees_last(kin.forward_kinematics(phi, r, sep))


def _fk_transposed(phi: Any, r: float, sep: float) -> Any:
    """``phi @ J`` with J = A⁺B of shape (3, 2) cannot multiply; the mistake that runs is
    ``phi @ (B⁺A)``: the inverse's matrix in place of the forward one."""
    A, B = kin.constraint_matrices(r, sep)
    return np.asarray(phi, float) @ (np.linalg.pinv(B) @ A)


def _fk_sum_not_mean(phi: Any, r: float, sep: float) -> Any:
    return kin.forward_kinematics(phi, r, sep) * np.array([2.0, 1.0, 1.0])


def _fk_over_b(phi: Any, r: float, sep: float) -> Any:
    """θ̇ = r (φ̇_r − φ̇_l) / b: half the separation where the whole one belongs."""
    return kin.forward_kinematics(phi, r, sep / 2)


_FK_MISTAKES = (
    Diagnostic("swapped wheels or the paper's turn sign (erratum 5)", _fk_turns_right,
               "wheel arrays are (right, left), and a faster right wheel turns the robot "
               "left: θ̇ = r (φ̇_r − φ̇_l) / l > 0 (REP-103)"),
    Diagnostic("b = the whole wheel separation", _fk_b_is_separation,
               "θ̇ = r (φ̇_r − φ̇_l) / (2 b) with b = wheel_separation / 2"),
    Diagnostic("θ̇ in degrees per second", _fk_degrees,
               "θ̇ is in rad/s: no conversion to degrees"),
    Diagnostic("the inverse kinematics' matrix B⁺A", _fk_transposed,
               "the forward kinematics is ξ = A⁺ B φ̇ (pinv(A) @ B, shape (3, 2))"),
    Diagnostic("ẋ as the sum of the rim speeds", _fk_sum_not_mean,
               "ẋ is the mean of the two rim speeds: r (φ̇_r + φ̇_l) / 2"),
    Diagnostic("θ̇ over b instead of over l = 2b", _fk_over_b,
               "θ̇ = r (φ̇_r − φ̇_l) / l: the whole wheel separation l = 2b below the "
               "difference, not b"),
)

forward_kinematics = Exercise(
    id="lab01.forward_kinematics", function="forward_kinematics", title="Forward kinematics",
    reference=kin.forward_kinematics, points=3, public=FK_PUBLIC,
    hidden=telling(_fk_hidden, kin.forward_kinematics, _FK_MISTAKES),
    diagnostics=_FK_MISTAKES,
    blocked=_BLOCKED,
    uses=("constraint_matrices",),
)


# ---------------------------------------------------------------- inverse kinematics

def _ik_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(4):
        r, b = _robot_params(rng)
        cases.append(Case(f"random twist {i}", (np.array([rng.uniform(-1, 1), 0.0,
                                                           rng.uniform(-2, 2)]), r, b)))
    r, b = _robot_params(rng)
    xi = np.column_stack([rng.uniform(-1, 1, 5), np.zeros(5), rng.uniform(-2, 2, 5)])
    cases.append(Case("batch", (xi, r, b)))
    return cases


def _ik_swapped(xi: Any, r: float, sep: float) -> Any:
    return kin.inverse_kinematics(xi, r, sep)[..., ::-1]


def _ik_forward_transposed(xi: Any, r: float, sep: float) -> Any:
    A, B = kin.constraint_matrices(r, sep)
    return np.asarray(xi, float) @ (np.linalg.pinv(A) @ B)


def _ik_b_is_separation(xi: Any, r: float, sep: float) -> Any:
    return kin.inverse_kinematics(xi, r, 2 * sep)


def _ik_turns_per_second(xi: Any, r: float, sep: float) -> Any:
    return kin.inverse_kinematics(xi, r, sep) / (2 * np.pi)


def _ik_no_radius(xi: Any, r: float, sep: float) -> Any:
    """The rims' speeds ẋ ± b θ̇ [m/s] returned as the wheels' [rad/s]."""
    return kin.inverse_kinematics(xi, r, sep) * r


_IK_MISTAKES = (
    Diagnostic("swapped wheels", _ik_swapped, "return (φ̇_r, φ̇_l), right first"),
    Diagnostic("the transposed forward matrix", _ik_forward_transposed,
               "the inverse is pinv(B) @ A, not the forward matrix transposed"),
    Diagnostic("b = the whole wheel separation", _ik_b_is_separation,
               "φ̇_{r,l} = (ẋ ± b θ̇) / r with b = wheel_separation / 2"),
    Diagnostic("turns per second", _ik_turns_per_second,
               "wheel speeds are in rad/s: no division by 2π"),
    Diagnostic("the rim speed, not the wheel's", _ik_no_radius,
               "ẋ ± b θ̇ is how fast the rim moves [m/s]: divide by the wheel radius r for "
               "the wheel's rad/s"),
)

inverse_kinematics = Exercise(
    id="lab01.inverse_kinematics", function="inverse_kinematics", title="Inverse kinematics",
    reference=kin.inverse_kinematics, points=3,
    public=(Case("forward 0.5 m/s", ([0.5, 0.0, 0.0], 0.05, 0.361)),
            Case("turn in place", ([0.0, 0.0, 1.0], 0.05, 0.361)),
            Case("arc", ([0.4, 0.0, -0.8], EDDIE_R, EDDIE_SEP)),
            Case("sideways is impossible", ([0.0, 0.3, 0.0], 0.05, 0.361))),
    hidden=telling(_ik_hidden, kin.inverse_kinematics, _IK_MISTAKES),
    diagnostics=_IK_MISTAKES,
    blocked=_BLOCKED,
    uses=("constraint_matrices",),
)


# ---------------------------------------------------------------- find the bug: odometry node

def _odometry_node_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (rng.uniform(-40, 40, 2), 0.05, 0.361, 20.0, -1.0))
            for i in range(4)]  # (right, left) motor turns/s, r, l, gear ratio, left sign


def _paper_odometry_node(motor: Any, r: float, sep: float, i: float, left_sign: float) -> Any:
    """Erratum 1's node as printed: v and ω swapped."""
    m = np.asarray(motor, float) * np.array([1.0, left_sign]) * 2 * np.pi / i
    b = sep / 2
    return np.stack([r / (2 * b) * (m[..., 0] - m[..., 1]), 0.5 * r * (m[..., 0] + m[..., 1])],
                    axis=-1)


def _odometry_node_no_gear(motor: Any, r: float, sep: float, i: float, left_sign: float) -> Any:
    return kin.motor_speeds_to_twist(motor, r, sep, 1.0, left_sign)


def _odometry_node_no_2pi(motor: Any, r: float, sep: float, i: float, left_sign: float) -> Any:
    return kin.motor_speeds_to_twist(np.asarray(motor, float) / (2 * np.pi), r, sep, i, left_sign)


def _odometry_node_no_sign(motor: Any, r: float, sep: float, i: float, left_sign: float) -> Any:
    return kin.motor_speeds_to_twist(motor, r, sep, i, 1.0)


def _odometry_node_swapped(motor: Any, r: float, sep: float, i: float, left_sign: float) -> Any:
    """The motors read (left, right): the left one's speed taken for the right wheel."""
    return kin.motor_speeds_to_twist(np.asarray(motor, float)[..., ::-1], r, sep, i, left_sign)


def _odometry_node_degrees(motor: Any, r: float, sep: float, i: float, left_sign: float) -> Any:
    return _degrees_last(kin.motor_speeds_to_twist(motor, r, sep, i, left_sign))


def _odometry_node_b_is_sep(motor: Any, r: float, sep: float, i: float, left_sign: float) -> Any:
    return kin.motor_speeds_to_twist(motor, r, 2 * sep, i, left_sign)


def _odometry_node_gear_multiplied(motor: Any, r: float, sep: float, i: float,
                                   left_sign: float) -> Any:
    """φ̇ = 2π n_motor · i: the gear ratio multiplied where it divides."""
    return kin.motor_speeds_to_twist(np.asarray(motor, float) * i * i, r, sep, i, left_sign)


_ODOMETRY_NODE_MISTAKES = (
    Diagnostic("the paper's odometry equations (erratum 1)", _paper_odometry_node,
               "v is the mean of the wheel speeds and ω their difference over 2b"),
    Diagnostic("forgetting the gearbox", _odometry_node_no_gear,
               "the motor turns 20 times per wheel turn"),
    Diagnostic("turns/s taken as rad/s", _odometry_node_no_2pi,
               "the ODrive reports turns per second: multiply by 2π"),
    Diagnostic("ignoring the mirrored left motor", _odometry_node_no_sign,
               "the left motor reports a forward wheel as negative: multiply its speed "
               "by left_sign before the kinematics"),
    Diagnostic("the motors read (left, right)", _odometry_node_swapped,
               "motor_speeds is (right, left): motor_speeds[0] is the right wheel's"),
    Diagnostic("ω in degrees per second", _odometry_node_degrees,
               "ω is in rad/s: no conversion to degrees"),
    Diagnostic("b = the whole wheel separation", _odometry_node_b_is_sep,
               "ω = r (φ̇_r − φ̇_l) / (2 b) with b = wheel_separation / 2"),
    Diagnostic("the gear ratio multiplied", _odometry_node_gear_multiplied,
               "a wheel turns once per gear_ratio motor turns: divide the motor's speed by "
               "gear_ratio, do not multiply"),
)

odometry_twist = Exercise(
    id="lab01.odometry_twist", function="odometry_twist",
    title="Find the bug: the odometry node (errata 1 and 5)",
    reference=kin.motor_speeds_to_twist, points=2,
    public=(Case("forward", ([10.0, -10.0], 0.05, 0.361, 20.0, -1.0)),
            Case("turning", ([12.0, -6.0], 0.05, 0.361, 20.0, -1.0)),
            Case("spin", ([5.0, 5.0], 0.05, 0.361, 20.0, -1.0))),
    hidden=telling(_odometry_node_hidden, kin.motor_speeds_to_twist, _ODOMETRY_NODE_MISTAKES),
    diagnostics=_ODOMETRY_NODE_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- find the bug: twist node

def _twist_node_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-2, 2)),
                                 0.05, 0.361, 20.0, -1.0)) for i in range(4)]


def _twist_node_forward(v: float, w: float, r: float, sep: float, i: float,
                        left_sign: float) -> Any:
    """Erratum 6 taken literally: the forward-kinematics rows applied to the command."""
    b = sep / 2
    wheel = np.array([r / 2 * v + r / (2 * b) * w, r / 2 * v - r / (2 * b) * w])
    return wheel * i / (2 * np.pi) * np.array([1.0, left_sign])


def _twist_node_no_sign(v: float, w: float, r: float, sep: float, i: float,
                        left_sign: float) -> Any:
    return kin.twist_to_motor_speeds(v, w, r, sep, i, 1.0)


def _twist_node_swapped(v: float, w: float, r: float, sep: float, i: float,
                        left_sign: float) -> Any:
    """(left, right) wheel speeds, the left sign then applied to the first one."""
    wheels = kin.twist_to_wheel_speeds(v, w, r, sep)[..., ::-1]
    return wheels * i / (2 * np.pi) * np.array([1.0, left_sign])


def _twist_node_no_gear(v: float, w: float, r: float, sep: float, i: float,
                        left_sign: float) -> Any:
    return kin.twist_to_motor_speeds(v, w, r, sep, 1.0, left_sign)


def _twist_node_rad_per_s(v: float, w: float, r: float, sep: float, i: float,
                          left_sign: float) -> Any:
    return kin.twist_to_motor_speeds(v, w, r, sep, i, left_sign) * 2 * np.pi


def _twist_node_gear_divided(v: float, w: float, r: float, sep: float, i: float,
                             left_sign: float) -> Any:
    return kin.twist_to_motor_speeds(v, w, r, sep, i, left_sign) / (i * i)


_TWIST_NODE_MISTAKES = (
    Diagnostic("the forward kinematics (erratum 6)", _twist_node_forward,
               "the twist node needs the inverse kinematics: phi = (v ± b ω) / r"),
    Diagnostic("ignoring the mirrored left motor", _twist_node_no_sign,
               "the mirrored left motor must turn backwards for a forward wheel: multiply "
               "its command by left_sign"),
    Diagnostic("swapped wheels", _twist_node_swapped,
               "the commands are (right, left): the right wheel's (v + b ω) / r first, and "
               "left_sign on the second"),
    Diagnostic("forgetting the gearbox", _twist_node_no_gear,
               "the motor turns gear_ratio times per wheel turn: multiply by gear_ratio"),
    Diagnostic("rad/s instead of turns/s", _twist_node_rad_per_s,
               "the ODrive takes turns per second: divide rad/s by 2π"),
    Diagnostic("the gear ratio divided", _twist_node_gear_divided,
               "the motor turns faster than its wheel: multiply the wheel's speed by "
               "gear_ratio, do not divide"),
)

twist_to_motor_speeds = Exercise(
    id="lab01.twist_to_motor_speeds", function="twist_to_motor_speeds",
    title="Find the bug: the twist node (erratum 6)",
    reference=kin.twist_to_motor_speeds, points=2,
    public=(Case("forward", (0.3, 0.0, 0.05, 0.361, 20.0, -1.0)),
            Case("turn left", (0.0, 1.0, 0.05, 0.361, 20.0, -1.0)),
            Case("arc", (0.2, -0.5, 0.05, 0.361, 20.0, -1.0))),
    hidden=telling(_twist_node_hidden, kin.twist_to_motor_speeds, _TWIST_NODE_MISTAKES),
    diagnostics=_TWIST_NODE_MISTAKES,
    blocked=_BLOCKED,
    uses=("inverse_kinematics",),
)


# ---------------------------------------------------------------- IGV RPM

def _igv_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (float(rng.uniform(-1.5, 1.5)), float(rng.uniform(-2, 2))))
            for i in range(4)]


def _igv_swapped(v: float, w: float) -> Any:
    """(u_L, u_R) as the paper writes them; the same numbers as flipping ω's sign."""
    uR, uL = kin.igv_wheel_rpm(v, w)
    return uL, uR


def _igv_rad_per_s(v: float, w: float) -> Any:
    uR, uL = kin.igv_wheel_rpm(v, w)
    return uR * 2 * np.pi / 60, uL * 2 * np.pi / 60


def _igv_per_second(v: float, w: float) -> Any:
    uR, uL = kin.igv_wheel_rpm(v, w)
    return uR / 60, uL / 60


def _igv_whole_separation(v: float, w: float) -> Any:
    """ω · l where each wheel is l / 2 from the centre: 2880 ω in place of 1440 ω."""
    return kin.igv_wheel_rpm(v, 2 * w)


_IGV_MISTAKES = (
    Diagnostic("(u_L, u_R): the paper's order, or ω's sign flipped", _igv_swapped,
               "return (u_R, u_L), right first as every wheel pair in the kit, "
               "with u_R = (4000 v + 1440 ω) / 67"),
    Diagnostic("rad/s instead of RPM", _igv_rad_per_s,
               "the IGV's equations give revolutions per minute: u = 60 φ̇ / (2π)"),
    Diagnostic("revolutions per second, not per minute", _igv_per_second,
               "u is per minute: 60 × the wheel's speed [m/s] / 1.005 m per turn"),
    Diagnostic("ω times the whole separation", _igv_whole_separation,
               "each wheel is l/2 = 0.36 m from the centre: v_R,L = v ± ω l/2, which gives "
               "1440 ω, not 2880 ω"),
)

igv_wheel_rpm = Exercise(
    id="lab01.igv_wheel_rpm", function="igv_wheel_rpm", title="The IGV's wheel RPM",
    reference=kin.igv_wheel_rpm, points=2,
    public=(Case("1 m/s straight", (1.0, 0.0)), Case("spin at 1 rad/s", (0.0, 1.0)),
            Case("arc", (0.5, -0.3))),
    hidden=telling(_igv_hidden, kin.igv_wheel_rpm, _IGV_MISTAKES),
    diagnostics=_IGV_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- DPRALTE units

def _units_draw(rng: np.random.Generator) -> list[Case]:
    """Four speeds up to the motor's 110 RPM either way, and one for a drive with another
    encoder (the function's ``counts_per_rev``)."""
    cases = [Case(f"{rpm:.2f} RPM", (float(rpm),)) for rpm in rng.uniform(-110, 110, 4).round(2)]
    rpm, counts = round(float(rng.uniform(-110, 110)), 2), int(rng.choice([500, 1000, 2048]))
    cases.append(Case(f"{rpm:.2f} RPM, {counts} counts per turn", (rpm, counts)))
    return cases


def _units_truncated(rpm: float, counts_per_rev: int = 400) -> Any:
    return int(rpm * counts_per_rev / 60 * 2**17 / 20000)


def _units_counts_only(rpm: float, counts_per_rev: int = 400) -> Any:
    return round(rpm * counts_per_rev / 60)


def _units_paper_factor(rpm: float, counts_per_rev: int = 400) -> Any:
    return round(rpm * 43.7)


def _units_half_up(rpm: float, counts_per_rev: int = 400) -> Any:
    """C's idiom ``(int)(x + 0.5)``: right forwards, one unit short backwards."""
    return int(rpm * counts_per_rev / 60 * 2**17 / 20000 + 0.5)


def _units_400_counts(rpm: float, counts_per_rev: int = 400) -> Any:
    return kin.rpm_to_drive_units(rpm)


_UNITS_MISTAKES = (
    Diagnostic("truncation", _units_truncated,
               "round to the nearest unit: 436.9 becomes 437, not 436"),
    Diagnostic("counts/s without the drive's scaling", _units_counts_only,
               "multiply counts/s by 2**17 / 20000"),
    Diagnostic("the paper's rounded factor 43.7", _units_paper_factor,
               "400 / 60 · 2**17 / 20000 = 43.69…: compute the factor, do not round it"),
    Diagnostic("int(x + 0.5)", _units_half_up,
               "int(x + 0.5) rounds a negative speed towards zero (int(−436.4) is −436, "
               "not −437): round(x) rounds both ways"),
    Diagnostic("400 counts whatever counts_per_rev says", _units_400_counts,
               "use the counts_per_rev argument: other drives have other encoders"),
)

rpm_to_drive_units = Exercise(
    id="lab01.rpm_to_drive_units", function="rpm_to_drive_units",
    title="The IGV drive's velocity units",
    reference=kin.rpm_to_drive_units, points=2,
    public=(Case("10 RPM (the paper's example)", (10.0,)), Case("110 RPM", (110.0,)),
            Case("reverse 25.5 RPM", (-25.5,)),
            Case("110 RPM with a 1000-count encoder", (110.0, 1000))),
    hidden=telling(_units_draw, kin.rpm_to_drive_units, _UNITS_MISTAKES),
    diagnostics=_UNITS_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- turning radius

def _radius_hidden(rng: np.random.Generator) -> list[Case]:
    cases = [Case(f"random {i}", (float(rng.uniform(-1, 1)), float(rng.uniform(0.1, 2))))
             for i in range(3)]
    cases.append(Case("straight backwards", (-float(rng.uniform(0.1, 1)), 0.0)))
    return cases


def _radius_inverted(v: float, w: float) -> Any:
    return w / v if v else math.inf


def _radius_wrong_side(v: float, w: float) -> Any:
    return -kin.turning_radius(v, w)


turning_radius = Exercise(
    id="lab01.turning_radius", function="turning_radius", title="Turning radius",
    reference=kin.turning_radius, points=2,
    public=(Case("left arc", (1.0, 0.5)), Case("right arc", (1.0, -0.5)),
            Case("straight", (0.5, 0.0)), Case("spin in place", (0.0, 1.0))),
    hidden=_radius_hidden,
    diagnostics=(Diagnostic("ω / v", _radius_inverted, "R = v / ω"),
                 Diagnostic("the centre on the wrong side", _radius_wrong_side,
                            "a left (counter-clockwise) turn has its centre at +y: R = v / ω > 0 "
                            "(REP-103), and straight ahead is +inf")),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- saturation

def _sat_hidden(rng: np.random.Generator) -> list[Case]:
    cases = [Case(f"random {i}", (rng.uniform(-40, 40, 2), float(rng.uniform(5, 20))))
             for i in range(3)]
    limit = float(rng.uniform(5, 20))
    cases.append(Case("within the limit", (rng.uniform(-0.95, 0.95, 2) * limit, limit)))
    return cases


def _sat_clip(phi: Any, limit: float) -> Any:
    return np.clip(np.asarray(phi, float), -limit, limit)


def _sat_signed_peak(phi: Any, limit: float) -> Any:
    """np.max(phi) for the fastest wheel: a wheel fast backwards goes unseen."""
    phi = np.asarray(phi, float)
    peak = np.max(phi)
    return phi * (limit / peak) if peak > limit else phi


def _sat_always(phi: Any, limit: float) -> Any:
    phi = np.asarray(phi, float)
    return phi * (limit / np.max(np.abs(phi)))


_SAT_MISTAKES = (
    Diagnostic("clipping each wheel", _sat_clip,
               "clipping wheels separately changes ω/v, so the robot leaves its "
               "arc: scale both by the same factor"),
    Diagnostic("the fastest wheel found without abs()", _sat_signed_peak,
               "a wheel turning backwards can be the fastest: compare np.max(np.abs(speeds)) "
               "with the limit"),
    Diagnostic("scaling speeds that already fit", _sat_always,
               "speeds within the limit stay as they are: scale only when the fastest "
               "exceeds it"),
)

saturate_wheel_speeds = Exercise(
    id="lab01.saturate_wheel_speeds", function="saturate_wheel_speeds",
    title="Wheel-speed saturation that keeps the curvature",
    reference=kin.saturate_wheel_speeds, points=2,
    public=(Case("both too fast", ([30.0, 10.0], 15.0)), Case("within limits", ([5.0, -3.0], 15.0)),
            Case("spin too fast", ([-25.0, 25.0], 20.0)),
            Case("backwards too fast", ([-30.0, -10.0], 15.0))),
    hidden=telling(_sat_hidden, kin.saturate_wheel_speeds, _SAT_MISTAKES),
    diagnostics=_SAT_MISTAKES,
    blocked=_BLOCKED,
)


SPEC = LabSpec(
    name="lab01",
    title="Lab 01 — Kinematics",
    exercises=(constraint_matrices, forward_kinematics, inverse_kinematics, odometry_twist,
               twist_to_motor_speeds, igv_wheel_rpm, rpm_to_drive_units, turning_radius,
               saturate_wheel_speeds),
)

"""Lab 01 — kinematics (act): the exercises, their cases and their known mistakes."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import kinematics as kin

UIABOT = {"wheel_radius": 0.05, "half_track": 0.1805}
IGV_R, IGV_B = 0.16, 0.36
EDDIE_R, EDDIE_B = 0.0762, 0.195

_BLOCKED = tuple(f"kit.kinematics:{name}" for name in (
    "constraint_matrices", "forward_kinematics", "inverse_kinematics", "motor_speeds_to_twist",
    "twist_to_motor_speeds", "twist_to_wheel_speeds", "wheel_speeds_to_twist", "igv_wheel_rpm",
    "igv_body_velocity", "rpm_to_drive_units", "drive_units_to_rpm", "turning_radius",
    "turning_radius_from_wheels", "icc_body", "saturate_wheel_speeds"))


def _robot_params(rng: np.random.Generator) -> tuple[float, float]:
    return float(rng.uniform(0.03, 0.2)), float(rng.uniform(0.1, 0.5))


# ---------------------------------------------------------------- constraint matrices

def _constraints_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"r={r:.3f}, b={b:.3f}", (r, b)) for r, b in
            (_robot_params(rng) for _ in range(4))]


def _constraints_b_for_2b(r: float, b: float) -> Any:
    return kin.constraint_matrices(r, 2 * b)


constraint_matrices = Exercise(
    id="lab01.constraint_matrices", function="constraint_matrices", title="Constraint matrices",
    reference=kin.constraint_matrices, points=2,
    public=(Case("Uiabot", (0.05, 0.1805)), Case("IGV", (IGV_R, IGV_B))),
    hidden=_constraints_hidden,
    diagnostics=(Diagnostic("using the wheel separation for b", _constraints_b_for_2b,
                            "b is half the distance between the wheels"),),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- forward kinematics

FK_PUBLIC = (
    Case("straight ahead", ([10.0, 10.0], 0.05, 0.1805)),
    Case("right wheel faster", ([12.0, 8.0], 0.05, 0.1805)),
    Case("turn in place", ([-5.0, 5.0], 0.05, 0.1805)),
    Case("many speeds at once", (np.array([[1.0, 2.0], [3.0, -1.0], [0.0, 4.0]]), IGV_R, IGV_B)),
)


def _fk_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(4):
        r, b = _robot_params(rng)
        cases.append(Case(f"random robot {i}", (rng.uniform(-20, 20, 2), r, b)))
    r, b = _robot_params(rng)
    cases.append(Case("batch", (rng.uniform(-20, 20, (6, 2)), r, b)))
    return cases


def _fk_swapped(phi: Any, r: float, b: float) -> Any:
    return kin.forward_kinematics(np.asarray(phi, float)[..., ::-1], r, b)


def _fk_turns_right(phi: Any, r: float, b: float) -> Any:
    return kin.forward_kinematics(phi, r, b) * np.array([1.0, 1.0, -1.0])


def _fk_full_track(phi: Any, r: float, b: float) -> Any:
    return kin.forward_kinematics(phi, r, b / 2)


forward_kinematics = Exercise(
    id="lab01.forward_kinematics", function="forward_kinematics", title="Forward kinematics",
    reference=kin.forward_kinematics, points=3, public=FK_PUBLIC, hidden=_fk_hidden,
    diagnostics=(
        Diagnostic("swapped wheels", _fk_swapped,
                   "wheel arrays are ordered (right, left) in this lab"),
        Diagnostic("the paper's sign (erratum 5)", _fk_turns_right,
                   "a faster right wheel turns the robot left: theta_dot > 0 (REP-103)"),
        Diagnostic("b used as the full wheel separation", _fk_full_track,
                   "theta_dot = r (phi_r - phi_l) / (2 b), with b half the separation"),
    ),
    blocked=_BLOCKED,
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


def _ik_swapped(xi: Any, r: float, b: float) -> Any:
    return kin.inverse_kinematics(xi, r, b)[..., ::-1]


def _ik_forward_transposed(xi: Any, r: float, b: float) -> Any:
    A, B = kin.constraint_matrices(r, b)
    return np.asarray(xi, float) @ (np.linalg.pinv(A) @ B)


inverse_kinematics = Exercise(
    id="lab01.inverse_kinematics", function="inverse_kinematics", title="Inverse kinematics",
    reference=kin.inverse_kinematics, points=3,
    public=(Case("forward 0.5 m/s", ([0.5, 0.0, 0.0], 0.05, 0.1805)),
            Case("turn in place", ([0.0, 0.0, 1.0], 0.05, 0.1805)),
            Case("arc", ([0.4, 0.0, -0.8], EDDIE_R, EDDIE_B)),
            Case("sideways is impossible", ([0.0, 0.3, 0.0], 0.05, 0.1805))),
    hidden=_ik_hidden,
    diagnostics=(
        Diagnostic("swapped wheels", _ik_swapped, "return (phi_dot_r, phi_dot_l), right first"),
        Diagnostic("the transposed forward matrix", _ik_forward_transposed,
                   "the inverse is pinv(B) @ A, not the forward matrix transposed"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- find the bug: odometry node

def _odometry_node_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (rng.uniform(-40, 40, 2), 0.05, 0.361, 20.0, -1.0))
            for i in range(4)]


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


odometry_twist = Exercise(
    id="lab01.odometry_twist", function="odometry_twist",
    title="Find the bug: the odometry node (errata 1 and 5)",
    reference=kin.motor_speeds_to_twist, points=2,
    public=(Case("forward", ([10.0, -10.0], 0.05, 0.361, 20.0, -1.0)),
            Case("turning", ([12.0, -6.0], 0.05, 0.361, 20.0, -1.0)),
            Case("spin", ([5.0, 5.0], 0.05, 0.361, 20.0, -1.0))),
    hidden=_odometry_node_hidden,
    diagnostics=(
        Diagnostic("the paper's odometry equations (erratum 1)", _paper_odometry_node,
                   "v is the mean of the wheel speeds and ω their difference over 2b"),
        Diagnostic("forgetting the gearbox", _odometry_node_no_gear,
                   "the motor turns 20 times per wheel turn"),
        Diagnostic("turns/s taken as rad/s", _odometry_node_no_2pi,
                   "the ODrive reports turns per second: multiply by 2π"),
        Diagnostic("ignoring the mirrored left motor", _odometry_node_no_sign,
                   "multiply the left motor's speed by left_sign"),
    ),
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


twist_to_motor_speeds = Exercise(
    id="lab01.twist_to_motor_speeds", function="twist_to_motor_speeds",
    title="Find the bug: the twist node (erratum 6)",
    reference=kin.twist_to_motor_speeds, points=2,
    public=(Case("forward", (0.3, 0.0, 0.05, 0.361, 20.0, -1.0)),
            Case("turn left", (0.0, 1.0, 0.05, 0.361, 20.0, -1.0)),
            Case("arc", (0.2, -0.5, 0.05, 0.361, 20.0, -1.0))),
    hidden=_twist_node_hidden,
    diagnostics=(
        Diagnostic("the forward kinematics (erratum 6)", _twist_node_forward,
                   "the twist node needs the inverse kinematics: phi = (v ± b ω) / r"),
        Diagnostic("ignoring the mirrored left motor", _twist_node_no_sign,
                   "multiply the left command by left_sign"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- IGV RPM

def _igv_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (float(rng.uniform(-1.5, 1.5)), float(rng.uniform(-2, 2))))
            for i in range(4)]


def _igv_swapped(v: float, w: float) -> Any:
    uL, uR = kin.igv_wheel_rpm(v, w)
    return uR, uL


igv_wheel_rpm = Exercise(
    id="lab01.igv_wheel_rpm", function="igv_wheel_rpm", title="The IGV's wheel RPM",
    reference=kin.igv_wheel_rpm, points=2,
    public=(Case("1 m/s straight", (1.0, 0.0)), Case("spin at 1 rad/s", (0.0, 1.0)),
            Case("arc", (0.5, -0.3))),
    hidden=_igv_hidden,
    diagnostics=(Diagnostic("swapped wheels", _igv_swapped,
                            "return (u_L, u_R): left first, as the IGV paper writes them"),),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- DPRALTE units

def _units_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"{rpm:.2f} RPM", (rpm,)) for rpm in rng.uniform(-110, 110, 4).round(2)]


def _units_truncated(rpm: float, counts_per_rev: int = 400) -> Any:
    return int(rpm * counts_per_rev / 60 * 2**17 / 20000)


def _units_counts_only(rpm: float, counts_per_rev: int = 400) -> Any:
    return round(rpm * counts_per_rev / 60)


rpm_to_drive_units = Exercise(
    id="lab01.rpm_to_drive_units", function="rpm_to_drive_units",
    title="The IGV drive's velocity units",
    reference=kin.rpm_to_drive_units, points=2,
    public=(Case("10 RPM (the paper's example)", (10.0,)), Case("110 RPM", (110.0,)),
            Case("reverse 25.5 RPM", (-25.5,))),
    hidden=_units_hidden,
    diagnostics=(
        Diagnostic("truncation", _units_truncated,
                   "round to the nearest unit: 436.9 becomes 437, not 436"),
        Diagnostic("counts/s without the drive's scaling", _units_counts_only,
                   "multiply counts/s by 2**17 / 20000"),
    ),
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


turning_radius = Exercise(
    id="lab01.turning_radius", function="turning_radius", title="Turning radius",
    reference=kin.turning_radius, points=2,
    public=(Case("left arc", (1.0, 0.5)), Case("right arc", (1.0, -0.5)),
            Case("straight", (0.5, 0.0)), Case("spin in place", (0.0, 1.0))),
    hidden=_radius_hidden,
    diagnostics=(Diagnostic("ω / v", _radius_inverted, "R = v / ω"),),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- saturation

def _sat_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (rng.uniform(-40, 40, 2), float(rng.uniform(5, 20))))
            for i in range(4)]


def _sat_clip(phi: Any, limit: float) -> Any:
    return np.clip(np.asarray(phi, float), -limit, limit)


saturate_wheel_speeds = Exercise(
    id="lab01.saturate_wheel_speeds", function="saturate_wheel_speeds",
    title="Wheel-speed saturation that keeps the curvature",
    reference=kin.saturate_wheel_speeds, points=2,
    public=(Case("both too fast", ([30.0, 10.0], 15.0)), Case("within limits", ([5.0, -3.0], 15.0)),
            Case("spin too fast", ([-25.0, 25.0], 20.0))),
    hidden=_sat_hidden,
    diagnostics=(Diagnostic("clipping each wheel", _sat_clip,
                            "clipping wheels separately changes ω/v, so the robot leaves its "
                            "arc: scale both by the same factor"),),
    blocked=_BLOCKED,
)


SPEC = LabSpec(
    name="lab01",
    title="Lab 01 — Kinematics",
    exercises=(constraint_matrices, forward_kinematics, inverse_kinematics, odometry_twist,
               twist_to_motor_speeds, igv_wheel_rpm, rpm_to_drive_units, turning_radius,
               saturate_wheel_speeds),
)

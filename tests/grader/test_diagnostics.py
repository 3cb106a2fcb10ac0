"""The diagnostics catalogue: for every exercise of every lab, each classic mistake that
applies to it, written here as a student would write it, must get exactly its hint.

A buggy variant is run on the exercise's public cases and on seeded hidden cases, and judged
as the notebook's check does (``grader.checker.explain``). For every case it fails, the hints
given must name its mistake and nothing else — no other mistake of the exercise (unless the
catalogue declares the two give the same numbers on that case) and no generic hint — and at
least one failing public case must name it alone.
"""

from __future__ import annotations

import copy
import heapq
import itertools
import math
import re
import warnings

import numpy as np
import pytest

from grader.checker import explain
from grader.spec import course_seed, lab_names, load_lab
from kit import msgs

LABS = lab_names()  # every lab with a spec must have its mistakes catalogued here
HIDDEN_SEEDS = (1, 2)
SQRT2 = math.sqrt(2)
DIAG = re.compile(r"this is what (.+?) gives: ")
HONEST: dict[str, dict[str, list]] = {}
"""Honest work by lab, then function: (name, a correct solution written another way) pairs
that must keep full marks for every student (each lab's section adds its own)."""


_HIDDEN: dict[tuple[str, int], list] = {}


def hidden_cases(exercise, seed: int) -> list:
    """The hidden cases a seed draws, made once per test process for every variant of the
    exercise tried here (some generators simulate: Lab 04's step responses). The functions
    under test get copies of their arguments, as the grader's process does, so that one
    that changes them in place leaves the cases as they were."""
    key = (exercise.id, seed)
    if key not in _HIDDEN:
        _HIDDEN[key] = list(exercise.hidden_cases(seed))
    return _HIDDEN[key]


def hints(exercise, case, fn) -> set[str] | None:
    """None when ``fn`` passes ``case``, else the names of the hints its output gets. Judging
    the output (the reference, the comparison, the diagnostics) must raise no warning: a
    student's inf or NaN gets a message, never a RuntimeWarning in the check's output."""
    got = fn(*copy.deepcopy(case.args), **copy.deepcopy(case.kwargs))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        verdict = explain(exercise, case, got)
    if verdict is None:
        return None
    problem, hint = verdict
    names = set(DIAG.findall(hint))
    if not hint and "; hint: " in problem:
        names.add("generic: " + problem.split("; hint: ", 1)[1])
    return names


# ------------------------------------------------------------------ lab 01 as students err

def _A_B(r, b):
    A = np.array([[1.0, 0, b], [1, 0, -b], [0, -1, 0], [0, -1, 0]])
    B = np.array([[r, 0.0], [0, r], [0, 0], [0, 0]])
    return A, B


def _fk(phi, r, b, sign=1.0, mean=True):
    phi = np.asarray(phi, float)
    return np.stack([r * (phi[..., 0] + phi[..., 1]) / (2 if mean else 1), 0 * phi[..., 0],
                     sign * r * (phi[..., 0] - phi[..., 1]) / (2 * b)], axis=-1)


def _ik(xi, r, b):
    xi = np.asarray(xi, float)
    return np.stack([(xi[..., 0] + b * xi[..., 2]) / r, (xi[..., 0] - b * xi[..., 2]) / r],
                    axis=-1)


def _odom(m, r, sep, i, s, *, gear=True, two_pi=True, sign=True, swap=False, deg=False,
          halve=True, paper=False, gear_times=False):
    m = np.asarray(m, float)
    right, left = (m[..., 1], m[..., 0]) if swap else (m[..., 0], m[..., 1])
    left = left * (s if sign else 1.0)
    k = (2 * np.pi if two_pi else 1.0) / (i if gear else 1.0)
    if gear_times:
        k = 2 * np.pi * i
    pr, pl = right * k, left * k
    b = sep / 2 if halve else sep
    v, w = r * (pr + pl) / 2, r * (pr - pl) / (2 * b)
    if paper:
        v, w = r * (pr - pl) / (2 * b), r * (pr + pl) / 2
    return np.stack([v, np.degrees(w) if deg else w], axis=-1)


def _twist(v, w, r, sep, i, s, *, sign=True, swap=False, gear=True, turns=True, forward=False,
           gear_divides=False):
    b = sep / 2
    if forward:
        wheels = np.array([r / 2 * v + r / (2 * b) * w, r / 2 * v - r / (2 * b) * w])
    else:
        wheels = np.array([(v + b * w) / r, (v - b * w) / r])
    if swap:
        wheels = wheels[::-1]
    wheels = wheels * (i if gear else 1.0) / (2 * np.pi if turns else 1.0)
    if gear_divides:
        wheels = wheels / i / i
    return wheels * np.array([1.0, s if sign else 1.0])


def _radius(v, w, flip=1.0):
    if w == 0:
        return math.inf if v >= 0 else -math.inf
    return flip * v / w


LAB01 = {
    "constraint_matrices": [
        ("b = the whole wheel separation", lambda r, sep: _A_B(r, sep)),
        ("the left wheel's rolling row first",
         lambda r, sep: (_A_B(r, sep / 2)[0][[1, 0, 2, 3]], _A_B(r, sep / 2)[1])),
        ("A and B transposed", lambda r, sep: tuple(m.T for m in _A_B(r, sep / 2))),
        ("the no-slide rows as +ẏ = 0",
         lambda r, sep: (np.array([[1.0, 0, sep / 2], [1, 0, -sep / 2], [0, 1, 0], [0, 1, 0]]),
                         _A_B(r, sep / 2)[1])),
    ],
    "forward_kinematics": [
        ("swapped wheels or the paper's turn sign (erratum 5)",
         lambda phi, r, sep: _fk(np.asarray(phi, float)[..., ::-1], r, sep / 2)),
        ("swapped wheels or the paper's turn sign (erratum 5)",
         lambda phi, r, sep: _fk(phi, r, sep / 2, sign=-1.0)),
        ("b = the whole wheel separation", lambda phi, r, sep: _fk(phi, r, sep)),
        ("θ̇ in degrees per second",
         lambda phi, r, sep: _fk(phi, r, sep / 2) * np.array([1, 1, 180 / np.pi])),
        ("the inverse kinematics' matrix B⁺A",
         lambda phi, r, sep: np.asarray(phi, float) @ (np.linalg.pinv(_A_B(r, sep / 2)[1])
                                                       @ _A_B(r, sep / 2)[0])),
        ("ẋ as the sum of the rim speeds", lambda phi, r, sep: _fk(phi, r, sep / 2, mean=False)),
        ("θ̇ over b instead of over l = 2b",          # r (φ̇_r − φ̇_l) / b with b = l / 2
         lambda phi, r, sep: _fk(phi, r, sep / 4)),
    ],
    "inverse_kinematics": [
        ("swapped wheels", lambda xi, r, sep: _ik(xi, r, sep / 2)[..., ::-1]),
        ("the transposed forward matrix",
         lambda xi, r, sep: np.asarray(xi, float) @ (np.linalg.pinv(_A_B(r, sep / 2)[0])
                                                     @ _A_B(r, sep / 2)[1])),
        ("b = the whole wheel separation", lambda xi, r, sep: _ik(xi, r, sep)),
        ("turns per second", lambda xi, r, sep: _ik(xi, r, sep / 2) / (2 * np.pi)),
        ("the rim speed, not the wheel's", lambda xi, r, sep: _ik(xi, 1.0, sep / 2)),
    ],
    "odometry_twist": [
        ("the paper's odometry equations (erratum 1)", lambda *a: _odom(*a, paper=True)),
        ("forgetting the gearbox", lambda *a: _odom(*a, gear=False)),
        ("turns/s taken as rad/s", lambda *a: _odom(*a, two_pi=False)),
        ("ignoring the mirrored left motor", lambda *a: _odom(*a, sign=False)),
        ("the motors read (left, right)", lambda *a: _odom(*a, swap=True)),
        ("ω in degrees per second", lambda *a: _odom(*a, deg=True)),
        ("b = the whole wheel separation", lambda *a: _odom(*a, halve=False)),
        ("the gear ratio multiplied", lambda *a: _odom(*a, gear_times=True)),
    ],
    "twist_to_motor_speeds": [
        ("the forward kinematics (erratum 6)", lambda *a: _twist(*a, forward=True)),
        ("ignoring the mirrored left motor", lambda *a: _twist(*a, sign=False)),
        ("swapped wheels", lambda *a: _twist(*a, swap=True)),
        ("forgetting the gearbox", lambda *a: _twist(*a, gear=False)),
        ("rad/s instead of turns/s", lambda *a: _twist(*a, turns=False)),
        ("the gear ratio divided", lambda *a: _twist(*a, gear_divides=True)),
    ],
    "igv_wheel_rpm": [
        ("(u_L, u_R): the paper's order, or ω's sign flipped",
         lambda v, w: ((4000 * v - 1440 * w) / 67, (4000 * v + 1440 * w) / 67)),
        ("rad/s instead of RPM",
         lambda v, w: ((4000 * v + 1440 * w) / 67 * np.pi / 30,
                       (4000 * v - 1440 * w) / 67 * np.pi / 30)),
        ("revolutions per second, not per minute",
         lambda v, w: ((v + 0.36 * w) / 1.005, (v - 0.36 * w) / 1.005)),
        ("ω times the whole separation",
         lambda v, w: ((4000 * v + 2880 * w) / 67, (4000 * v - 2880 * w) / 67)),
    ],
    "rpm_to_drive_units": [
        ("truncation", lambda rpm, cpr=400: int(rpm * cpr / 60 * 2**17 / 20000)),
        ("counts/s without the drive's scaling", lambda rpm, cpr=400: round(rpm * cpr / 60)),
        ("the paper's rounded factor 43.7", lambda rpm, cpr=400: round(rpm * 43.7)),
        ("int(x + 0.5)", lambda rpm, cpr=400: int(rpm * cpr / 60 * 2**17 / 20000 + 0.5)),
        ("400 counts whatever counts_per_rev says",
         lambda rpm, cpr=400: round(rpm * 400 / 60 * 2**17 / 20000)),
    ],
    "turning_radius": [
        ("ω / v", lambda v, w: w / v if v else math.inf),
        ("the centre on the wrong side", lambda v, w: _radius(v, w, -1.0) if w else
         (-math.inf if v >= 0 else math.inf)),
    ],
    "saturate_wheel_speeds": [
        ("clipping each wheel", lambda phi, m: np.clip(np.asarray(phi, float), -m, m)),
        ("the fastest wheel found without abs()", lambda phi, m: _saturate(phi, m, peak=np.max)),
        ("scaling speeds that already fit", lambda phi, m: _saturate(phi, m, always=True)),
    ],
}


def _saturate(phi, limit, peak=lambda p: np.max(np.abs(p)), always=False):
    phi = np.asarray(phi, float)
    fastest = peak(phi)
    return phi * (limit / fastest) if always or fastest > limit else phi


def _fk_closed_form(phi, r, sep):
    phi = np.asarray(phi, float)
    right, left = phi[..., 0], phi[..., 1]
    return np.stack([r * (right + left) / 2, np.zeros_like(right), r * (right - left) / sep],
                    axis=-1)


def _fk_lstsq(phi, r, sep):
    A, B = _A_B(r, sep / 2)
    rhs = B @ np.asarray(phi, float).T                 # (4,) or (4, N)
    return np.linalg.lstsq(A, rhs, rcond=None)[0].T


def _ik_lstsq(xi, r, sep):
    A, B = _A_B(r, sep / 2)
    return np.linalg.lstsq(B, A @ np.asarray(xi, float).T, rcond=None)[0].T


def _odom_matrix(m, r, sep, i, s):
    wheels = np.asarray(m, float) * np.array([1.0, s]) * 2 * np.pi / i
    J = np.array([[r / 2, r / 2], [r / sep, -r / sep]])
    return wheels @ J.T


def _constraints_filled(r, sep):
    A, B = np.zeros((4, 3)), np.zeros((4, 2))
    A[0, 0] = A[1, 0] = 1.0
    A[0, 2], A[1, 2] = sep / 2, -sep / 2
    A[2, 1] = A[3, 1] = -1.0
    B[0, 0] = B[1, 1] = r
    return A, B


def _units_exact(rpm, counts_per_rev=400):
    from fractions import Fraction

    return round(Fraction(rpm) * counts_per_rev * 2**17 / (60 * 20000))


HONEST["lab01"] = {
    "constraint_matrices": [
        ("np.zeros, then the entries", _constraints_filled),
        ("a list [A, B] of nested lists",
         lambda r, sep: [m.tolist() for m in _constraints_filled(r, sep)]),
    ],
    "forward_kinematics": [
        ("the closed form, no pseudo-inverse", _fk_closed_form),
        ("least squares (np.linalg.lstsq)", _fk_lstsq),
    ],
    "inverse_kinematics": [
        ("the closed form", lambda xi, r, sep: _ik(xi, r, sep / 2)),
        ("least squares (np.linalg.lstsq)", _ik_lstsq),
    ],
    "odometry_twist": [
        ("a 2 × 2 matrix on the wheel speeds", _odom_matrix),
    ],
    "twist_to_motor_speeds": [
        ("wheel turns per second first",
         lambda v, w, r, sep, i, s: np.array([(v + w * sep / 2) / (2 * np.pi * r) * i,
                                              s * (v - w * sep / 2) / (2 * np.pi * r) * i])),
    ],
    "igv_wheel_rpm": [
        ("60 (v ± ω l/2) / 1.005 m per turn",
         lambda v, w: (60 * (v + w * 0.72 / 2) / 1.005, 60 * (v - w * 0.72 / 2) / 1.005)),
    ],
    "rpm_to_drive_units": [
        ("math.floor(x + 0.5)",
         lambda rpm, cpr=400: math.floor(rpm * cpr / 60 * 2**17 / 20000 + 0.5)),
        ("int(np.rint(x))", lambda rpm, cpr=400: int(np.rint(rpm * cpr * 2**17 / 1_200_000))),
        ("exact fractions", _units_exact),
    ],
    "turning_radius": [
        ("math.copysign(math.inf, v)",
         lambda v, w: v / w if w else math.copysign(math.inf, v)),
    ],
    "saturate_wheel_speeds": [
        ("divided by max(1, fastest / limit)",
         lambda phi, m: np.asarray(phi, float) / max(1.0, np.max(np.abs(phi)) / m)),
        ("a factor min(1, limit / fastest)",
         lambda phi, m: np.asarray(phi, float) * min(1.0, m / float(np.max(np.abs(phi))))),
    ],
}

# ------------------------------------------------------------------ lab 02


def _eddie(pose, dr, dl, sep, *, paper=False, wrap=True, deg=False, turn_first=True):
    x, y, th = (float(v) for v in pose)
    ds = (dr + dl) / 2
    if not turn_first:
        x, y = x + ds * math.cos(th), y + ds * math.sin(th)
    d = ((dl - dr) if paper else (dr - dl)) / sep
    th = th + (math.degrees(d) if deg else d)
    if wrap:
        th = (th + math.pi) % (2 * math.pi) - math.pi
    if not turn_first:
        return np.array([x, y, th])
    return np.array([x + ds * math.cos(th), y + ds * math.sin(th), th])


def _arc(pose, dr, dl, sep, *, chord=True, mean_heading=True, wrap=True, sinc_pi=True):
    x, y, th = (float(v) for v in pose)
    ds, dth = (dr + dl) / 2, (dr - dl) / sep
    length = ds * np.sinc(dth / (2 * np.pi) if sinc_pi else dth / 2) if chord else ds
    heading = th + dth / 2 if mean_heading else th
    new = th + dth
    if wrap:
        new = (new + math.pi) % (2 * math.pi) - math.pi
    return np.array([x + length * math.cos(heading), y + length * math.sin(heading), new])


def _path(d_right, d_left, sep, step, accumulate=True):
    poses = [np.zeros(3)]
    for dr, dl in zip(d_right, d_left, strict=True):
        poses.append(step(poses[-1] if accumulate else np.zeros(3), dr, dl, sep))
    return np.array(poses)


def _path_in_place(d_right, d_left, sep):
    pose = np.zeros(3)
    poses = [pose]
    for dr, dl in zip(d_right, d_left, strict=True):
        pose[:] = _arc(pose, dr, dl, sep)
        poses.append(pose)
    return np.array(poses)


def _odom_tf(pose, stamp, parent="odom", child="base_link"):
    x, y, th = pose
    return msgs.TransformStamped(
        msgs.Header(stamp, parent), child,
        msgs.Transform(msgs.Vector3(float(x), float(y), 0.0),
                       msgs.Quaternion(0.0, 0.0, math.sin(th / 2), math.cos(th / 2))))


LAB02 = {
    "conversion_factor": [
        ("the formula as printed, c_m = D / (n C_e)", lambda d, n, c: d / (n * c)),
        ("the radius in place of the diameter", lambda d, n, c: math.pi * (d / 2) / (n * c)),
        ("forgetting the gear ratio", lambda d, n, c: math.pi * d / c),
        ("2π D for the circumference", lambda d, n, c: 2 * math.pi * d / (n * c)),
        ("the gear ratio multiplied", lambda d, n, c: math.pi * d * n / c),
    ],
    "tick_delta": [
        ("a plain difference", lambda p, c, bits: c - p),
        ("the increment modulo 2**bits, never negative", lambda p, c, bits: (c - p) % 2**bits),
        ("16 bits whatever counter_bits says",
         lambda p, c, bits: (c - p) % 65536 - (65536 if (c - p) % 65536 >= 32768 else 0)),
    ],
    "eddie_odometry_step": [
        ("the paper's heading update (erratum 7)", lambda *a: _eddie(*a, paper=True)),
        ("an unwrapped heading", lambda *a: _eddie(*a, wrap=False)),
        ("the heading change in degrees", lambda *a: _eddie(*a, wrap=False, deg=True)),
        ("moving along the old heading", lambda *a: _eddie(*a, turn_first=False)),
    ],
    "exact_arc_step": [
        ("Euler integration", lambda *a: _arc(*a, chord=False, mean_heading=False)),
        ("the mean heading without the chord factor", lambda *a: _arc(*a, chord=False)),
        ("an unwrapped heading", lambda *a: _arc(*a, wrap=False)),
        ("the wheels swapped", lambda pose, dr, dl, sep: _arc(pose, dl, dr, sep)),
        ("np.sinc(Δθ / 2)", lambda *a: _arc(*a, sinc_pi=False)),
    ],
    "integrate_path": [
        ("the paper's pose update (erratum 2)",
         lambda dr, dl, sep: _path(dr, dl, sep, _arc, accumulate=False)),
        ("Euler steps in place of the arc",
         lambda dr, dl, sep: _path(dr, dl, sep, lambda *a: _arc(*a, chord=False,
                                                                  mean_heading=False))),
        ("the start pose left out", lambda dr, dl, sep: _path(dr, dl, sep, _arc)[1:]),
        ("one array appended again and again", _path_in_place),
    ],
    "yaw_to_quaternion": [
        ("the full angle", lambda t: np.array([0.0, 0.0, math.sin(t), math.cos(t)])),
        ("(w, x, y, z) order", lambda t: np.array([math.cos(t / 2), 0.0, 0.0, math.sin(t / 2)])),
        ("θ taken as degrees", lambda t: np.array([0.0, 0.0, math.sin(math.radians(t) / 2),
                                                   math.cos(math.radians(t) / 2)])),
    ],
    "make_odom_transform": [
        ("parent and child swapped", lambda pose, stamp: _odom_tf(pose, stamp, "base_link",
                                                                  "odom")),
        ("frame ids with a leading slash",
         lambda pose, stamp: _odom_tf(pose, stamp, "/odom", "/base_link")),
    ],
}


def _ticks_corrected(p, c, bits):
    d, m = c - p, 2**bits
    if d >= m // 2:
        d -= m
    elif d < -(m // 2):
        d += m
    return d


def _arc_formula(pose, dr, dl, sep):
    """R (sin(θ + Δθ) − sin θ), −R (cos(θ + Δθ) − cos θ), and a straight line when Δθ = 0."""
    x, y, th = (float(v) for v in pose)
    ds, dth = (dr + dl) / 2, (dr - dl) / sep
    if dth == 0:
        return np.array([x + ds * math.cos(th), y + ds * math.sin(th), _wrap(th)])
    R = ds / dth
    return np.array([x + R * (math.sin(th + dth) - math.sin(th)),
                     y - R * (math.cos(th + dth) - math.cos(th)), _wrap(th + dth)])


def _arc_sin_over_h(pose, dr, dl, sep):
    x, y, th = (float(v) for v in pose)
    ds, dth = (dr + dl) / 2, (dr - dl) / sep
    h = dth / 2
    chord = ds * (math.sin(h) / h if h else 1.0)
    return np.array([x + chord * math.cos(th + h), y + chord * math.sin(th + h),
                     math.atan2(math.sin(th + dth), math.cos(th + dth))])


def _path_preallocated(d_right, d_left, sep):
    poses = np.zeros((len(d_right) + 1, 3))
    for k, (dr, dl) in enumerate(zip(d_right, d_left, strict=True)):
        poses[k + 1] = _arc_sin_over_h(poses[k], dr, dl, sep)
    return poses


def _path_accumulate(d_right, d_left, sep):
    steps = itertools.accumulate(zip(d_right, d_left, strict=True),
                                 lambda pose, d: _arc(pose, d[0], d[1], sep),
                                 initial=np.zeros(3))
    return np.array(list(steps))


def _quat_scipy(theta):
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler("z", theta).as_quat()


def _tf_keywords(pose, stamp):
    x, y, th = (float(v) for v in pose)
    return msgs.TransformStamped(
        header=msgs.Header(stamp=msgs.Time(sec=stamp.sec, nanosec=stamp.nanosec),
                           frame_id="odom"),
        child_frame_id="base_link",
        transform=msgs.Transform(translation=msgs.Vector3(x=x, y=y, z=0.0),
                                 rotation=msgs.Quaternion(x=0.0, y=0.0, z=math.sin(th / 2),
                                                          w=math.cos(th / 2))))


HONEST["lab02"] = {
    "conversion_factor": [
        ("np.pi D / n / C_e", lambda d, n, c: np.pi * d / n / c),
        ("math.tau × the radius", lambda d, n, c: math.tau * (d / 2) / (n * c)),
    ],
    "tick_delta": [
        ("shifted by half the range",
         lambda p, c, bits: (c - p + 2 ** (bits - 1)) % 2**bits - 2 ** (bits - 1)),
        ("the plain difference corrected by ±2**bits", _ticks_corrected),
    ],
    "eddie_odometry_step": [
        ("the heading wrapped with atan2(sin, cos)",
         lambda pose, dr, dl, sep: _eddie(pose, dr, dl, sep, wrap=False)
         * np.array([1.0, 1.0, 0.0])
         + np.array([0.0, 0.0, math.atan2(math.sin(pose[2] + (dr - dl) / sep),
                                          math.cos(pose[2] + (dr - dl) / sep))])),
        ("the heading wrapped with math.remainder",
         lambda pose, dr, dl, sep: np.array([*_eddie(pose, dr, dl, sep)[:2],
                                             math.remainder(pose[2] + (dr - dl) / sep,
                                                            2 * math.pi)])),
    ],
    "exact_arc_step": [
        ("the arc formula, with a branch for Δθ = 0", _arc_formula),
        ("sin(h) / h, with a branch for h = 0", _arc_sin_over_h),
    ],
    "integrate_path": [
        ("a preallocated (N + 1, 3) array", _path_preallocated),
        ("itertools.accumulate", _path_accumulate),
    ],
    "yaw_to_quaternion": [
        ("scipy's Rotation.from_euler('z', θ).as_quat()", _quat_scipy),
        ("a half-angle complex exponential",
         lambda t: np.array([0.0, 0.0, np.exp(0.5j * t).imag, np.exp(0.5j * t).real])),
    ],
    "make_odom_transform": [
        ("keyword arguments throughout", _tf_keywords),
    ],
}

# ------------------------------------------------------------------ lab 03


def _crc(data, init=0, reflect=False, swap=False, mask=0xFFFF, shift=8):
    crc = init
    for byte in data:
        if reflect:
            crc ^= byte
            for _ in range(8):
                crc = (crc >> 1) ^ 0x8408 if crc & 1 else crc >> 1
        else:
            crc ^= byte << shift
            for _ in range(8):
                crc = ((crc << 1) ^ 0x1021) & mask if crc & 0x8000 else (crc << 1) & mask
    return ((crc & 0xFF) << 8) | (crc >> 8) if swap else crc


def _frame(address, offset, rpm, sequence=0, *, crc_order="big", data_order="little",
           factor=None, crc_from=0, shift=2, data_crc_of_all=False):
    units = round(rpm * 43.7) if factor else round(rpm * 400 / 60 * 2**17 / 20000)
    header = bytes([0xA5, address, 2 | (sequence << shift), 0x45, offset, 2])
    data = units.to_bytes(4, data_order, signed=True)
    frame = header + _crc(header[crc_from:]).to_bytes(2, crc_order) + data
    return frame + _crc(frame if data_crc_of_all else data).to_bytes(2, crc_order)


def _compass(line, yaw_of, checked=True, from_dollar=False):
    m = re.fullmatch(r"\$([^*$]*)\*([0-9A-Fa-f]{2})", line.strip())
    if not m:
        return None
    body, given = m.groups()
    check = 0
    for ch in ("$" if from_dollar else "") + body:
        check ^= ord(ch)
    if (checked and check != int(given, 16)) or not body.startswith("C"):
        return None
    f = dict(re.findall(r"(Mx|My|Mz|Ax|Ay|Az|[CPRTD])(-?\d+(?:\.\d+)?)", body))
    if not all(k in f for k in "CPR"):
        return None
    heading = float(f["C"])
    return heading, float(f["P"]), float(f["R"]), yaw_of(heading)


def _wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def _nodes(data, step_on_miss=1, raw=False, check_bit=False, quality_shift=2):
    rows, i = [], 0
    while i + 5 <= len(data):
        b0, b1 = data[i], data[i + 1]
        if ((b0 ^ (b0 >> 1)) & 1) and (b1 & 1):
            angle = (b1 | (data[i + 2] << 8)) if check_bit else (b1 >> 1) | (data[i + 2] << 7)
            dist = data[i + 3] | (data[i + 4] << 8)
            rows.append([b0 & 1, b0 >> quality_shift, angle if raw else angle / 64,
                         dist if raw else dist / 4])
            i += 5
        else:
            i += step_on_miss
    return np.array(rows, dtype=float).reshape(-1, 4)


PAPER_STATES = {0: "UNDEFINED", 1: "IDLE", 2: "STARTUP_SEQUENCE",
                3: "FULL_CALIBRATION_SEQUENCE", 4: "MOTOR_CALIBRATION", 5: "SENSORLESS_CONTROL",
                6: "ENCODER_INDEX_SEARCH", 7: "ENCODER_OFFSET_CALIBRATION",
                8: "CLOSED_LOOP_CONTROL", 9: "LOCKIN_SPIN", 10: "ENCODER_DIR_FIND"}


def _motors(v, w, *, mirror=True, turns=True, gear=True, clip_each=False, limited=True,
            b=0.1805):
    r, limit = 0.05, 20.0  # hardware/robots/uiabot.toml
    wheels = np.array([v + w * b, v - w * b]) / r
    if clip_each:
        wheels = np.clip(wheels, -limit, limit)
    elif limited and np.max(np.abs(wheels)) > limit:
        wheels = wheels * limit / np.max(np.abs(wheels))
    wheels = wheels * (20 if gear else 1) / (2 * math.pi if turns else 1)
    return wheels * np.array([1.0, -1.0 if mirror else 1.0])


LAB03 = {
    "crc16_xmodem": [
        ("CRC-16/CCITT-FALSE (initial value 0xFFFF)", lambda d: _crc(d, init=0xFFFF)),
        ("the two result bytes swapped", lambda d: _crc(d, swap=True)),
        ("CRC-16/KERMIT (bits reflected)", lambda d: _crc(d, reflect=True)),
        ("the CRC not kept to 16 bits", lambda d: _crc(d, mask=-1)),
        ("each byte XORed into the low 8 bits", lambda d: _crc(d, shift=0)),
    ],
    "velocity_frame": [
        ("CRCs sent low byte first", lambda *a: _frame(*a, crc_order="little")),
        ("the velocity sent big-endian", lambda *a: _frame(*a, data_order="big")),
        ("RPM × 43.7", lambda *a: _frame(*a, factor=43.7)),
        ("header CRC without the A5", lambda *a: _frame(*a, crc_from=1)),
        ("the sequence number not shifted", lambda *a: _frame(*a, shift=0)),
    ],
    "parse_compass": [
        ("the heading as yaw", lambda s: _compass(s, lambda h: _wrap(math.radians(h)))),
        ("yaw = −heading", lambda s: _compass(s, lambda h: _wrap(-math.radians(h)))),
        ("the yaw in degrees",
         lambda s: _compass(s, lambda h: math.degrees(_wrap(math.pi / 2 - math.radians(h))))),
        ("an unwrapped yaw", lambda s: _compass(s, lambda h: math.pi / 2 - math.radians(h))),
        ("the checksum not checked", lambda s: _compass(s, _yaw, checked=False)),
        ("a valid sentence refused", lambda s: _compass(s, _yaw, from_dollar=True)),
    ],
    "decode_nodes": [
        ("whole 5-byte steps (no resynchronising)", lambda d: _nodes(d, step_on_miss=5)),
        ("raw q6 angle and q2 distance", lambda d: _nodes(d, raw=True)),
        ("the check bit kept in the angle", lambda d: _nodes(d, check_bit=True)),
        ("the quality not shifted", lambda d: _nodes(d, quality_shift=0)),
    ],
    "axis_state_name": [
        ("the paper's table for every firmware", lambda value, fw: PAPER_STATES.get(value)),
        ("the new table for every firmware", lambda value, fw: NEW_STATES.get(value)),
    ],
    "uiabot_motor_speeds": [
        ("the left motor not mirrored", lambda v, w: _motors(v, w, mirror=False)),
        ("rad/s instead of turns/s", lambda v, w: _motors(v, w, turns=False)),
        ("wheel speed, not motor speed", lambda v, w: _motors(v, w, gear=False)),
        ("each wheel clipped on its own", lambda v, w: _motors(v, w, clip_each=True)),
        ("no wheel limit", lambda v, w: _motors(v, w, limited=False)),
        ("b = the whole wheel separation", lambda v, w: _motors(v, w, b=0.361)),
    ],
}


def _yaw(heading_deg):
    return _wrap(math.pi / 2 - math.radians(heading_deg))


def _crc_table():
    table = []
    for top in range(256):
        crc = top << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
        table.append(crc)
    return table


CRC_TABLE = _crc_table()


def _crc_by_table(data):
    crc = 0
    for byte in data:
        crc = ((crc << 8) & 0xFFFF) ^ CRC_TABLE[(crc >> 8) ^ byte]
    return crc


def _frame_struct(address, offset, rpm, sequence=0):
    import binascii
    import struct

    header = struct.pack("<6B", 0xA5, address, 2 | sequence << 2, 0x45, offset, 2)
    data = struct.pack("<i", round(rpm * 400 / 60 * 2**17 / 20000))
    return b"".join([header, struct.pack(">H", binascii.crc_hqx(header, 0)), data,
                     struct.pack(">H", binascii.crc_hqx(data, 0))])


def _compass_split(line):
    import functools
    import operator

    line = line.strip()
    if not line.startswith("$") or line.count("*") != 1:
        return None
    body, given = line[1:].split("*")
    if len(given) != 2 or any(c not in "0123456789abcdefABCDEF" for c in given):
        return None
    if functools.reduce(operator.xor, map(ord, body), 0) != int(given, 16):
        return None
    fields = {}
    for key, value in re.findall(r"(Mx|My|Mz|Ax|Ay|Az|[A-Z])(-?[\d.]+)", body):
        fields.setdefault(key, float(value))
    if not body.startswith("C") or not {"C", "P", "R"} <= set(fields):
        return None
    h = math.radians(fields["C"])
    return fields["C"], fields["P"], fields["R"], math.atan2(math.cos(h), math.sin(h))


def _nodes_struct(data):
    import struct

    rows, i = [], 0
    while i + 5 <= len(data):
        b0, angle, distance = struct.unpack_from("<BHH", data, i)
        if (b0 & 1) != ((b0 >> 1) & 1) and angle & 1:
            rows.append([b0 & 1, b0 >> 2, (angle >> 1) / 64, distance / 4])
            i += 5
        else:
            i += 1
    return np.array(rows, dtype=float).reshape(-1, 4)


NEW_STATES = {**{k: v for k, v in PAPER_STATES.items() if k != 5}, 11: "HOMING",
              12: "ENCODER_HALL_POLARITY_CALIBRATION", 13: "ENCODER_HALL_PHASE_CALIBRATION"}


def _state_by_version(value, firmware):
    from packaging.version import Version

    table = NEW_STATES if Version(firmware) >= Version("0.5.2") else PAPER_STATES
    return table.get(value)


HONEST["lab03"] = {
    "crc16_xmodem": [
        ("binascii.crc_hqx(data, 0)", lambda d: __import__("binascii").crc_hqx(d, 0)),
        ("a 256-entry table", _crc_by_table),
        ("masked once at the end", lambda d: _crc(d, mask=-1) & 0xFFFF),
    ],
    "velocity_frame": [
        ("struct.pack and binascii.crc_hqx", _frame_struct),
        # XMODEM over a block followed by its own CRC (high byte first) leaves 0, so the
        # CRC of header, header CRC and data is the data's CRC
        ("the data CRC over the whole frame so far",
         lambda *a: _frame(*a, data_crc_of_all=True)),
    ],
    "parse_compass": [
        ("str.split, functools.reduce and atan2", _compass_split),
    ],
    "decode_nodes": [
        ("struct.unpack_from('<BHH')", _nodes_struct),
    ],
    "axis_state_name": [
        ("packaging.version and two tables", _state_by_version),
        ("tuples of ints and two tables",
         lambda value, fw: (NEW_STATES if tuple(map(int, fw.split("."))) >= (0, 5, 2)
                            else PAPER_STATES).get(value)),
    ],
    "uiabot_motor_speeds": [
        ("a factor min(1, limit / fastest)",
         lambda v, w: (lambda wheels: wheels * min(1.0, 20.0 / np.max(np.abs(wheels))) * 20
                       / (2 * math.pi) * np.array([1.0, -1.0]))(
             np.array([v + w * 0.1805, v - w * 0.1805]) / 0.05)),
    ],
}

# ------------------------------------------------------------------ lab 04


def _tf(R, L, kt, ke, J, b, N, *, gear=True, reverse=False, gear_times=False, emf=True):
    den = np.array([J * L, J * R + b * L, b * R + (kt * ke if emf else 0.0)])
    num = kt * N if gear_times else kt / (N if gear else 1.0)
    return np.array([num]), den[::-1] if reverse else den


def _pi(kp, ki, dt, integral, r, y, low, high, *, clamp=True, use_dt=True, error_sign=1.0):
    e = error_sign * (r - y)
    new = integral + ki * e * (dt if use_dt else 1.0)
    raw = kp * e + new
    out = min(max(raw, low), high)
    if clamp and out != raw and (raw - out) * e > 0:
        new = integral
        out = min(max(kp * e + new, low), high)
    return out, new


def _figures(t, y, setpoint, *, rise_from=0.1, rise_to=0.9, percent=100.0, over_setpoint=False,
             error_sign=1.0, interpolate=True):
    t, y = np.asarray(t, float), np.asarray(y, float)
    final = y[-1]

    def cross(level):
        i = int(np.argmax(y >= level))
        if i == 0 or not interpolate:
            return t[i]
        return t[i - 1] + (level - y[i - 1]) * (t[i] - t[i - 1]) / (y[i] - y[i - 1])

    start = cross(rise_from * final) if rise_from else t[0]
    rise = (cross(rise_to * final) if rise_to < 1 else t[int(np.argmax(y >= final))]) - start
    reference = setpoint if over_setpoint else final
    over = max(0.0, (y.max() - reference) / reference * percent)
    outside = np.flatnonzero(np.abs(y - final) > 0.02 * final)
    settle = 0.0 if len(outside) == 0 else (t[outside[-1] + 1] - t[0] if outside[-1] + 1 < len(t)
                                            else t[-1] - t[0])
    return rise, over, settle, error_sign * (setpoint - final)


LAB04 = {
    "transfer_coefficients": [
        ("forgetting the gearbox", lambda *a: _tf(*a, gear=False)),
        ("the denominator lowest power first", lambda *a: _tf(*a, reverse=True)),
        ("the gear ratio multiplied", lambda *a: _tf(*a, gear_times=True)),
        ("the back-EMF forgotten", lambda *a: _tf(*a, emf=False)),
    ],
    "pi_step": [
        ("no anti-windup", lambda *a: _pi(*a, clamp=False)),
        ("the integral without dt", lambda *a: _pi(*a, use_dt=False)),
        ("the error as measurement − set-point", lambda *a: _pi(*a, error_sign=-1.0)),
    ],
    "step_figures": [
        ("0 → 100 % rise time", lambda *a: _figures(*a, rise_from=0.0, rise_to=1.0)),
        ("the overshoot as a fraction", lambda *a: _figures(*a, percent=1.0)),
        ("the overshoot over the set-point", lambda *a: _figures(*a, over_setpoint=True)),
        ("the steady-state error as y∞ − set-point", lambda *a: _figures(*a, error_sign=-1.0)),
        ("crossings at sample times", lambda *a: _figures(*a, interpolate=False)),
    ],
    "pole_placement": [
        ("dropping the plant's own damping",
         lambda K, tau, wn, z: (2 * z * wn * tau / K, wn * wn * tau / K)),
        ("K_i without τ", lambda K, tau, wn, z: ((2 * z * wn * tau - 1) / K, wn * wn / K)),
    ],
    "ziegler_nichols_pid": [
        ("the PI row", lambda ku, tu: (0.45 * ku, 0.45 * ku / (tu / 1.2), 0.0)),
        ("T_i and T_d in place of K_i and K_d", lambda ku, tu: (0.6 * ku, tu / 2, tu / 8)),
        ("K_i = K_p T_i", lambda ku, tu: (0.6 * ku, 0.6 * ku * tu / 2, 0.6 * ku * tu / 8)),
    ],
    "cascade_acceleration": [
        ("no acceleration limit", lambda r, v, k, a: k * (r - v)),
        ("the error the wrong way round", lambda r, v, k, a: min(max(k * (v - r), -a), a)),
    ],
}


def _pi_either_side(kp, ki, dt, integral, r, y, low, high):
    e = r - y
    trial = integral + ki * e * dt
    raw = kp * e + trial
    if (raw > high and e > 0) or (raw < low and e < 0):
        trial = integral
    return float(np.clip(kp * e + trial, low, high)), trial


def _figures_interp(t, y, setpoint):
    t, y = np.asarray(t, float), np.asarray(y, float)
    final = y[-1]

    def cross(level):
        i = int(np.argmax(y >= level))
        return t[0] if i == 0 else float(np.interp(level, y[i - 1:i + 1], t[i - 1:i + 1]))

    inside = np.abs(y - final) <= 0.02 * final
    last_out = len(y) - 1 - int(np.argmin(inside[::-1])) if not inside.all() else None
    settle = 0.0 if last_out is None else t[min(last_out + 1, len(t) - 1)] - t[0]
    return (cross(0.9 * final) - cross(0.1 * final),
            100 * max(0.0, y.max() / final - 1), settle, setpoint - final)


HONEST["lab04"] = {
    "transfer_coefficients": [
        ("np.polymul of (J s + b)(L s + R), plus K_t K_e",
         lambda R, L, kt, ke, J, b, N: (np.array([kt / N]),
                                        np.polymul([J, b], [L, R]) + np.array([0, 0, kt * ke]))),
        ("np.convolve", lambda R, L, kt, ke, J, b, N: (
            np.array([kt]) / N, np.convolve([J, b], [L, R]) + np.array([0, 0, kt * ke]))),
    ],
    "pi_step": [
        ("the clamp as two conditions, np.clip", _pi_either_side),
    ],
    "step_figures": [
        ("np.interp between the samples, the settling time from the end", _figures_interp),
    ],
    "pole_placement": [
        ("divided by τ first",
         lambda K, tau, wn, z: ((2 * z * wn - 1 / tau) * tau / K, wn**2 * tau / K)),
    ],
    "ziegler_nichols_pid": [
        ("from T_i and T_d", lambda ku, tu: (lambda kp, ti, td: (kp, kp / ti, kp * td))(
            0.6 * ku, tu / 2, tu / 8)),
    ],
    "cascade_acceleration": [
        ("np.clip", lambda r, v, k, a: float(np.clip(k * (r - v), -a, a))),
        ("math.copysign", lambda r, v, k, a: math.copysign(min(abs(k * (r - v)), a),
                                                           k * (r - v))),
    ],
}

# ------------------------------------------------------------------ lab 05


def _update(x, P, z, H, R, *, gain="S", joseph=True):
    x, P, z = (np.asarray(v, float) for v in (x, P, z))
    H, R = np.atleast_2d(H), np.atleast_2d(R)
    S = H @ P @ H.T + R
    K = P @ H.T @ (S if gain == "S times" else np.linalg.inv(S if gain == "S" else R))
    x_new = x + K @ (z - H @ x)
    I_KH = np.eye(len(x)) - K @ H
    return x_new, (I_KH @ P @ I_KH.T + K @ R @ K.T) if joseph else I_KH @ P


def _jacobian(x, dt, *, sign=-1.0, half=0.5):
    _, _, yaw, vx, _, ax = x
    s = vx * dt + half * ax * dt * dt
    c, sn = math.cos(yaw), math.sin(yaw)
    return np.array([[1, 0, sign * s * sn, dt * c, 0, half * dt * dt * c],
                     [0, 1, s * c, dt * sn, 0, half * dt * dt * sn],
                     [0, 0, 1, 0, dt, 0], [0, 0, 0, 1, 0, dt], [0, 0, 0, 0, 1, 0],
                     [0, 0, 0, 0, 0, 1]], dtype=float)


CONFIG = ("x", "y", "z", "roll", "pitch", "yaw", "vx", "vy", "vz", "vroll", "vpitch", "vyaw",
          "ax", "ay", "az")


def _one_turn(z, zh):
    d = z - zh
    if d >= math.pi:
        d -= 2 * math.pi
    elif d < -math.pi:
        d += 2 * math.pi
    return d


def _update_solved(x, P, z, H, R):
    x, P, z = (np.asarray(v, float) for v in (x, P, z))
    H, R = np.atleast_2d(H), np.atleast_2d(R)
    S = H @ P @ H.T + R
    K = np.linalg.solve(S, H @ P).T          # S symmetric: K = (S⁻¹ H P)ᵀ = P Hᵀ S⁻¹
    I_KH = np.eye(len(x)) - K @ H
    return x + K @ (z - H @ x), I_KH @ P @ I_KH.T + K @ R @ K.T


LAB05 = {
    "kf_predict": [
        ("F transposed in the covariance",
         lambda x, P, F, Q: (np.asarray(F) @ x, np.asarray(F).T @ P @ np.asarray(F) + Q)),
        ("forgetting Q", lambda x, P, F, Q: (np.asarray(F) @ x,
                                             np.asarray(F) @ P @ np.asarray(F).T)),
        ("F P F, the second F not transposed",
         lambda x, P, F, Q: (np.asarray(F) @ x, np.asarray(F) @ P @ np.asarray(F) + Q)),
    ],
    "joseph_update": [
        ("a gain without S", lambda *a: _update(*a, gain="R")),
        ("the short form (I − K H) P", lambda *a: _update(*a, joseph=False)),
        ("S multiplied, not inverted", lambda *a: _update(*a, gain="S times")),
    ],
    "angle_residual": [
        ("an unwrapped difference", lambda z, zh: z - zh),
        ("a difference wrapped to [0, 2π)", lambda z, zh: (z - zh) % (2 * math.pi)),
        ("(d mod 2π) − π", lambda z, zh: (z - zh) % (2 * math.pi) - math.pi),
        ("a single ±2π correction", _one_turn),
        ("generic: the values are the expected ones in degrees: work in radians",
         lambda z, zh: math.degrees(_wrap(z - zh))),
    ],
    "nis": [
        ("yᵀ S y", lambda y, S: float(np.asarray(y) @ np.asarray(S) @ np.asarray(y))),
        ("the Mahalanobis distance",
         lambda y, S: math.sqrt(float(np.asarray(y) @ np.linalg.solve(S, y)))),
        ("divided by the dimension",
         lambda y, S: float(np.asarray(y) @ np.linalg.solve(S, y)) / len(y)),
    ],
    "planar_jacobian": [
        ("a transposed Jacobian", lambda x, dt: _jacobian(x, dt).T),
        ("∂x'/∂ψ with the wrong sign", lambda x, dt: _jacobian(x, dt, sign=1.0)),
        ("the ½ of ½ a_x Δt² forgotten", lambda x, dt: _jacobian(x, dt, half=1.0)),
    ],
    "fused_state_indices": [
        ("the config's own indices", lambda config: [i for i, on in enumerate(config) if on]),
        ("a state with vy", lambda config: [
            i for i, name in enumerate(("x", "y", "yaw", "vx", "vy", "vyaw", "ax"))
            if config[CONFIG.index(name)]]),
    ],
}


def _planar_f(x, dt):
    """The planar model's f (complex-safe: no wrapping)."""
    px, py, yaw, vx, w, ax = x
    s = vx * dt + 0.5 * ax * dt * dt
    return np.array([px + s * np.cos(yaw), py + s * np.sin(yaw), yaw + w * dt, vx + ax * dt,
                     w, ax])


def _jacobian_complex_step(x, dt, h=1e-30):
    """∂f/∂x by complex steps: exact to rounding, an independent check of the algebra."""
    x = np.asarray(x, dtype=complex)
    return np.column_stack([_planar_f(x + 1j * h * e, dt).imag / h for e in np.eye(6)])


HONEST["lab05"] = {
    "kf_predict": [
        ("np.linalg.multi_dot", lambda x, P, F, Q: (np.asarray(F) @ np.asarray(x),
                                                    np.linalg.multi_dot([F, P, np.transpose(F)])
                                                    + Q)),
        ("np.einsum", lambda x, P, F, Q: (np.einsum("ij,j->i", F, x),
                                          np.einsum("ik,kl,jl->ij", F, P, F) + Q)),
    ],
    "joseph_update": [
        ("np.linalg.solve for the gain", lambda x, P, z, H, R: _update_solved(x, P, z, H, R)),
    ],
    "angle_residual": [
        ("atan2(sin d, cos d)", lambda z, zh: math.atan2(math.sin(z - zh), math.cos(z - zh))),
        ("math.remainder(d, 2π)", lambda z, zh: math.remainder(z - zh, 2 * math.pi)),
        ("np.angle of a unit complex number", lambda z, zh: float(np.angle(np.exp(1j * (z - zh))))),
        ("(d + π) mod 2π − π", lambda z, zh: (z - zh + math.pi) % (2 * math.pi) - math.pi),
    ],
    "nis": [
        ("y @ inv(S) @ y", lambda y, S: float(np.asarray(y) @ np.linalg.inv(S) @ np.asarray(y))),
        ("a Cholesky solve", lambda y, S: float(np.sum(np.linalg.solve(np.linalg.cholesky(S),
                                                                       y) ** 2))),
    ],
    "planar_jacobian": [
        ("complex-step differentiation of f", _jacobian_complex_step),
    ],
    "fused_state_indices": [
        ("a dict from field to state index",
         lambda config: sorted({"x": 0, "y": 1, "yaw": 2, "vx": 3, "vyaw": 4, "ax": 5}[name]
                               for name, on in zip(CONFIG, config, strict=True) if on and name in
                               ("x", "y", "yaw", "vx", "vyaw", "ax"))),
        ("np.flatnonzero on the six columns",
         lambda config: np.flatnonzero(np.asarray(config)[[0, 1, 5, 6, 11, 12]]).tolist()),
    ],
}

# ------------------------------------------------------------------ lab 06 as students err

def _ok06(r, lo, hi):
    r = np.asarray(r, float)
    with np.errstate(invalid="ignore"):
        return np.isfinite(r) & (r >= lo) & (r <= hi)


def _points06(r, amin, inc, lo, hi, T, mode="right"):
    r = np.asarray(r, float)
    a = amin + inc * np.arange(len(r))
    ok = _ok06(r, lo, hi)
    px, py = r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok])
    x, y, th = T
    if mode == "laser":
        return np.column_stack([px, py])
    if mode == "inverse":          # (x, y, θ) undone instead of applied
        c, s = math.cos(th), math.sin(th)
        qx, qy = px - x, py - y
        return np.column_stack([c * qx + s * qy, -s * qx + c * qy])
    if mode == "translate":
        return np.column_stack([px + x, py + y])
    if mode == "transposed":       # [[c, s], [-s, c]] typed for R
        c, s = math.cos(th), math.sin(th)
        return np.column_stack([x + c * px + s * py, y - s * px + c * py])
    c, s = math.cos(th), math.sin(th)
    return np.column_stack([x + c * px - s * py, y + s * px + c * py])


def _deskew06(r, angle, beam, ref, mode="right"):
    p = np.array([r * math.cos(angle), r * math.sin(angle)])
    if mode == "none":
        return p
    first, second = (ref, beam) if mode == "swap" else (beam, ref)
    c, s = math.cos(first[2]), math.sin(first[2])
    w = np.array([first[0] + c * p[0] - s * p[1], first[1] + s * p[0] + c * p[1]])
    c, s = math.cos(second[2]), math.sin(second[2])
    if mode == "negate":           # the inverse pose written as (-x, -y, -θ)
        return np.array([c * w[0] + s * w[1] - second[0], -s * w[0] + c * w[1] - second[1]])
    d = w - np.array(second[:2])
    if mode == "R":                # the inverse rotates by +θ_ref
        return np.array([c * d[0] - s * d[1], s * d[0] + c * d[1]])
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]])


def _exclusive06(r, lo, hi):
    r = np.asarray(r, float)
    with np.errstate(invalid="ignore"):
        return np.isfinite(r) & (r > lo) & (r < hi)


LAB06 = {
    "beam_angles": [
        ("linspace up to angle_min + n · angle_increment",
         lambda amin, inc, n: np.linspace(amin, amin + n * inc, n)),
        ("beams counted from 1", lambda amin, inc, n: np.array([amin + (i + 1) * inc
                                                                for i in range(n)])),
        ("degrees", lambda amin, inc, n: np.degrees(amin + inc * np.arange(n))),
    ],
    "valid_returns": [
        ("range limits ignored", lambda r, lo, hi: np.isfinite(np.asarray(r, float))),
        ("inf taken for a return", lambda r, lo, hi: np.nan_to_num(np.asarray(r, float)) > 0),
        ("the limits excluded", _exclusive06),
    ],
    "scan_to_points": [
        ("points left in the laser's frame", lambda *a: _points06(*a, mode="laser")),
        ("the mounting applied inverted", lambda *a: _points06(*a, mode="inverse")),
        ("the mounting's rotation ignored", lambda *a: _points06(*a, mode="translate")),
        ("Rᵀ in place of R", lambda *a: _points06(*a, mode="transposed")),
    ],
    "deskew_beam": [
        ("not de-skewed", lambda *a: _deskew06(*a, mode="none")),
        ("the two poses swapped", lambda *a: _deskew06(*a, mode="swap")),
        ("R in place of Rᵀ in the inverse", lambda *a: _deskew06(*a, mode="R")),
        ("the inverse taken as (−x, −y, −θ)", lambda *a: _deskew06(*a, mode="negate")),
    ],
    "depth_to_range": [
        ("depth along the optical axis taken as the range",
         lambda z, u, fx, cx: np.asarray(z, float) * np.ones_like(np.asarray(u, float))),
        ("only the sideways offset",
         lambda z, u, fx, cx: np.abs((np.asarray(u, float) - cx) * np.asarray(z, float) / fx)),
        ("z · cos α", lambda z, u, fx, cx: np.asarray(z, float) * np.cos(
            np.arctan((np.asarray(u, float) - cx) / fx))),
        ("the offset (u − cx) / fx without z", lambda z, u, fx, cx: np.sqrt(
            ((np.asarray(u, float) - cx) / fx) ** 2 + np.asarray(z, float) ** 2)),
    ],
}


# ------------------------------------------------------------------ lab 07 as students err

def _sense07(belief, world, z, hit, miss, normalise=True, add=False):
    lik = np.array([hit if c == z else miss for c in world])
    b = np.asarray(belief, float) + lik if add else np.asarray(belief, float) * lik
    return b / b.sum() if normalise else b


def _move07(belief, shift, under, exact, over, backwards=False, noise=True):
    b = np.asarray(belief, float)
    sign = -1 if backwards else 1
    if not noise:
        return np.roll(b, sign * shift)
    return (exact * np.roll(b, sign * shift) + under * np.roll(b, sign * (shift - 1))
            + over * np.roll(b, sign * (shift + 1)))


def _control07(a, b, degrees=False, swap=False, wrap=True, spot=True):
    dx, dy = b[0] - a[0], b[1] - a[1]
    trans = math.hypot(dx, dy)
    w = (lambda t: (t + math.pi) % (2 * math.pi) - math.pi) if wrap else (lambda t: t)
    heading = math.atan2(dx, dy) if swap else math.atan2(dy, dx)
    rot1 = 0.0 if trans < 0.01 and spot else w(heading - a[2])
    rot2 = w(b[2] - a[2] - rot1)
    if degrees:
        return np.array([math.degrees(rot1), trans, math.degrees(rot2)])
    return np.array([rot1, trans, rot2])


def _loglik07(poses, ends, dist, res, origin, z_hit, z_rand, sigma, rmax, product=False,
              rotate=True, clip=False, swap=False):
    p, e, d = np.asarray(poses, float), np.asarray(ends, float), np.asarray(dist, float)
    out = []
    for x, y, th in p:
        th = th if rotate else 0.0
        pz = []
        for ex, ey in e:
            px, py = x + math.cos(th) * ex - math.sin(th) * ey, y + math.sin(th) * ex + \
                math.cos(th) * ey
            r, c = math.floor((py - origin[1]) / res), math.floor((px - origin[0]) / res)
            if swap:
                r, c = c, r
            if clip:                  # the nearest cell of the grid's edge
                r, c = min(max(r, 0), d.shape[0] - 1), min(max(c, 0), d.shape[1] - 1)
            dd = d[r, c] if 0 <= r < d.shape[0] and 0 <= c < d.shape[1] else d.max()
            pz.append(z_hit * math.exp(-dd * dd / (2 * sigma * sigma)) + z_rand / rmax)
        if product:
            total = math.prod(pz)
            out.append(math.log(total) if total > 0 else -math.inf)
        else:
            out.append(sum(math.log(v) for v in pz))
    return np.array(out)


def _normalise07(lw, shift=True, divide=True, by_min=False):
    lw = np.asarray(lw, float)
    with np.errstate(all="ignore"):
        w = np.exp(lw - (lw.min() if by_min else lw.max())) if shift else np.exp(lw)
        return w / w.sum() if divide else w


def _low_variance07(w, n, r, normalise=True, side="right"):
    """The textbook's loop (table 4.4), as a student writes it; the lab's convention
    c_{i-1} <= u < c_i moves on while u >= c (the book's "while U > c" is side="left")."""
    w = np.asarray(w, float)
    w = w / w.sum() if normalise else w
    out, i, c = [], 0, w[0]
    for m in range(n):
        u = r + m / n
        while (u >= c if side == "right" else u > c) and i < len(w) - 1:
            i += 1
            c += w[i]
        out.append(i)
    return np.array(out)


LAB07 = {
    "sense": [
        ("weights not normalised", lambda *a: _sense07(*a, normalise=False)),
        ("likelihood added, not multiplied", lambda *a: _sense07(*a, add=True)),
    ],
    "move": [
        ("moved the wrong way", lambda *a: _move07(*a, backwards=True)),
        ("the motion noise left out", lambda *a: _move07(*a, noise=False)),
    ],
    "odometry_control": [
        ("degrees", lambda a, b: _control07(a, b, degrees=True)),
        ("atan2(dx, dy)", lambda a, b: _control07(a, b, swap=True)),
        ("rotations not wrapped", lambda a, b: _control07(a, b, wrap=False)),
        ("a move under 1 cm not taken as a turn on the spot",
         lambda a, b: _control07(a, b, spot=False)),
    ],
    "log_likelihoods": [
        ("likelihoods multiplied until they underflow", lambda *a: _loglik07(*a, product=True)),
        ("beam angles in the wrong frame", lambda *a: _loglik07(*a, rotate=False)),
        ("off-grid endpoints read from the edge cell", lambda *a: _loglik07(*a, clip=True)),
        ("row and column swapped", lambda *a: _loglik07(*a, swap=True)),
    ],
    "normalize_log_weights": [
        ("exp of the log-weights as they are", lambda lw: _normalise07(lw, shift=False)),
        ("weights not normalised", lambda lw: _normalise07(lw, divide=False)),
        ("the smallest log-weight subtracted", lambda lw: _normalise07(lw, by_min=True)),
    ],
    "should_resample": [
        ("resampling every step", lambda w, t: True),
        ("N_eff compared with the share itself",
         lambda w, t: bool(1 / np.sum(np.asarray(w) ** 2) < t)),
    ],
    "low_variance_resample": [
        ("a pointer on a boundary taken to the left",
         lambda w, n, r: _low_variance07(w, n, r, side="left")),
        ("weights not normalised first", lambda w, n, r: _low_variance07(w, n, r,
                                                                          normalise=False)),
    ],
}


# ------------------------------------------------------------------ lab 08 as students err

def _ends(ranges, angle_min, inc, pose, rotate=True, keep_inf=False, in_laser=False,
          transposed=False, first=0):
    r = np.asarray(ranges, float)
    a = angle_min + inc * np.arange(first, first + len(r))
    if not keep_inf:
        a, r = a[np.isfinite(r)], r[np.isfinite(r)]
    with np.errstate(invalid="ignore"):
        px, py = r * np.cos(a), r * np.sin(a)
        if in_laser:
            return np.column_stack([px, py])
        th = pose[2] if rotate else 0.0
        c, s = math.cos(th), math.sin(th)
        if transposed:
            s = -s
        return np.column_stack([pose[0] + c * px - s * py, pose[1] + s * px + c * py])


def _rel(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, b[2] - a[2]])


def _edge(xi, xj, z, wrap=True, swap=False, R_i=False):
    xi, xj, z = (np.asarray(v, float) for v in (xi, xj, z))
    seen = _rel(xi, xj)
    if R_i:                        # rotated by +θ_i into node i's frame
        c, s = math.cos(xi[2]), math.sin(xi[2])
        dx, dy = xj[0] - xi[0], xj[1] - xi[1]
        seen = np.array([c * dx - s * dy, s * dx + c * dy, xj[2] - xi[2]])
    d = _rel(seen, z) if swap else _rel(z, seen)
    if wrap:
        d[2] = (d[2] + math.pi) % (2 * math.pi) - math.pi
    return d


def _jac(xi, xj, z):
    ci, si = math.cos(xi[2]), math.sin(xi[2])
    a = ci * (xj[0] - xi[0]) + si * (xj[1] - xi[1])
    b = -si * (xj[0] - xi[0]) + ci * (xj[1] - xi[1])
    c, s = math.cos(xi[2] + z[2]), math.sin(xi[2] + z[2])
    cz, sz = math.cos(z[2]), math.sin(z[2])
    A = np.array([[-c, -s, cz * b - sz * a], [s, -c, -sz * b - cz * a], [0, 0, -1.0]])
    B = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1.0]])
    return A, B


def _gn(poses, edges, invert=False, uphill=False, wrap=True, fix=True):
    x = np.asarray(poses, float)
    n = len(x)
    H, b = np.zeros((3 * n, 3 * n)), np.zeros(3 * n)
    for i, j, z, om in edges:
        om = np.linalg.inv(om) if invert else np.asarray(om, float)
        e, (A, B) = _edge(x[i], x[j], z), _jac(x[i], x[j], z)
        for p, P in ((i, A), (j, B)):
            b[3 * p:3 * p + 3] += P.T @ om @ e
            for q, Q in ((i, A), (j, B)):
                H[3 * p:3 * p + 3, 3 * q:3 * q + 3] += P.T @ om @ Q
    dx = np.zeros(3 * n)
    if fix:
        dx[3:] = np.linalg.solve(H[3:, 3:], (b if uphill else -b)[3:])
    else:                          # no node held: the least-squares step of all of them
        dx = np.linalg.lstsq(H, -b, rcond=None)[0]
    new = x + dx.reshape(n, 3)
    if wrap:
        new[:, 2] = (new[:, 2] + math.pi) % (2 * math.pi) - math.pi
    return new


LAB08 = {
    "update_log_odds": [
        ("log-odds not clamped", lambda odds, c, lo, hi: np.asarray(odds) + np.asarray(c)),
        ("probabilities multiplied", lambda odds, c, lo, hi: np.clip(np.log(
            (p := 1 / (1 + np.exp(-np.asarray(odds))) / (1 + np.exp(-np.asarray(c))))
            / (1 - p)), lo, hi)),
    ],
    "beam_endpoints": [
        ("the laser's heading ignored", lambda *a: _ends(*a, rotate=False)),
        ("points left in the laser's frame", lambda *a: _ends(*a, in_laser=True)),
        ("inf ranges made into points", lambda *a: _ends(*a, keep_inf=True)),
        ("Rᵀ in place of R", lambda *a: _ends(*a, transposed=True)),
        ("the first beam at angle_min + angle_increment", lambda *a: _ends(*a, first=1)),
    ],
    "edge_error": [
        ("angle residual not wrapped", lambda xi, xj, z: _edge(xi, xj, z, wrap=False)),
        ("poses subtracted in the world frame",
         lambda xi, xj, z: np.asarray(xj, float) - np.asarray(xi, float) - np.asarray(z, float)),
        ("the other transform inverted", lambda xi, xj, z: _edge(xi, xj, z, swap=True)),
        ("R(θ_i) in place of its transpose", lambda xi, xj, z: _edge(xi, xj, z, R_i=True)),
    ],
    "edge_jacobians": [
        ("Jacobians transposed", lambda *a: tuple(m.T for m in _jac(*a))),
        ("A and B swapped", lambda *a: _jac(*a)[::-1]),
    ],
    "gauss_newton_step": [
        ("information matrix inverted", lambda p, e: _gn(p, e, invert=True)),
        ("the step taken uphill", lambda p, e: _gn(p, e, uphill=True)),
        ("angles not wrapped after the step", lambda p, e: _gn(p, e, wrap=False)),
        ("node 0 not held fixed", lambda p, e: _gn(p, e, fix=False)),
    ],
}


# ------------------------------------------------------------------ lab 09 as students err

def _cost(d, r, k, scale=252.0, lethal=True, cap=252.0, inside=np.less_equal, floor=True,
          offset=True):
    d = np.asarray(d, float)
    decay = scale * np.exp(-k * (d - r if offset else d))
    decay = np.floor(decay) if floor else np.rint(decay)
    c = np.where(inside(d, r), 253.0, decay if cap is None else np.minimum(decay, cap))
    if lethal:
        c = np.where(d == 0, 254.0, c)
    return c.astype(np.uint8)


def _inflate(lethal, res, r_in, radius, k, reach_cells=True, cost_metres=True, ceil=True,
             metric="euclidean"):
    from scipy import ndimage

    lethal = np.asarray(lethal, bool)
    out = np.zeros(lethal.shape, np.uint8)
    sources = np.argwhere(lethal)
    if not len(sources):
        return out
    if metric == "of the obstacles":             # distance_transform_edt(lethal)
        cells = ndimage.distance_transform_edt(lethal)
    elif metric == "chessboard":                 # distance_transform_cdt(~lethal)
        cells = ndimage.distance_transform_cdt(~lethal).astype(float)
    else:
        rows, cols = np.indices(lethal.shape)
        cells = np.sqrt(np.min([(rows - r) ** 2 + (cols - c) ** 2 for r, c in sources], axis=0))
    reach = (math.ceil(radius / res) if ceil else radius / res) if reach_cells else radius
    near = cells <= reach
    out[near] = _cost(cells[near] * (res if cost_metres else 1.0), r_in, k)
    return out


def _astar_as_students_err(free, start, goal, diagonal=SQRT2, cut=False, weight=1.0,
                           transposed=False, manhattan=False):
    free = np.asarray(free, bool)
    if transposed:            # cells read as (x, y): free[y][x] with x = row, y = col
        free = free.T
    h, w = free.shape
    start, goal = tuple(start), tuple(goal)
    inside = [0 <= p[0] < h and 0 <= p[1] < w and free[p] for p in (start, goal)]
    if not all(inside):
        return math.inf

    def octile(a):
        dr, dc = abs(a[0] - goal[0]), abs(a[1] - goal[1])
        if manhattan:
            return dr + dc
        straight, diag = max(dr, dc) - min(dr, dc), min(dr, dc)
        return weight * (straight + diagonal * diag)

    best, done, queue = {start: 0.0}, set(), [(octile(start), start)]
    while queue:
        _, cell = heapq.heappop(queue)
        if cell in done:
            continue
        if cell == goal:
            return best[cell]
        done.add(cell)
        for dr, dc in itertools.product((-1, 0, 1), repeat=2):
            n = (cell[0] + dr, cell[1] + dc)
            if (dr, dc) == (0, 0) or not (0 <= n[0] < h and 0 <= n[1] < w) or not free[n]:
                continue
            if dr and dc and not cut and not (free[cell[0] + dr, cell[1]] and
                                              free[cell[0], cell[1] + dc]):
                continue
            g = best[cell] + (diagonal if dr and dc else 1.0)
            if g < best.get(n, math.inf):
                best[n] = g
                heapq.heappush(queue, (g + octile(n), n))
    return math.inf


LAB09 = {
    "inflation_cost": [
        ("the obstacle cell itself not lethal", lambda d, r, k: _cost(d, r, k, lethal=False)),
        ("253 · exp(…) instead of (253 − 1) · exp(…)",
         lambda d, r, k: _cost(d, r, k, scale=253.0)),
        ("254 · exp(…) instead of (253 − 1) · exp(…)",
         lambda d, r, k: _cost(d, r, k, scale=254.0, cap=None)),
        ("the inscribed radius exclusive (d < r_in)",
         lambda d, r, k: _cost(d, r, k, inside=np.less)),
        ("the decayed cost rounded instead of truncated",
         lambda d, r, k: _cost(d, r, k, floor=False)),
        ("the decay measured from the obstacle (exp(−k d))",
         lambda d, r, k: _cost(d, r, k, offset=False)),
    ],
    "inflate": [
        ("the inflation radius in metres against distances in cells",
         lambda *a: _inflate(*a, reach_cells=False)),
        ("distances in cells costed as metres", lambda *a: _inflate(*a, cost_metres=False)),
        ("the reach not rounded up to whole cells", lambda *a: _inflate(*a, ceil=False)),
        ("the distances of the obstacle cells instead of the free ones",
         lambda *a: _inflate(*a, metric="of the obstacles")),
        ("chessboard distances (distance_transform_cdt)",
         lambda *a: _inflate(*a, metric="chessboard")),
    ],
    "octile_distance": [
        ("a diagonal step costing 1",
         lambda a, b: float(max(abs(a[0] - b[0]), abs(a[1] - b[1])))),
        ("Manhattan distance on an 8-connected grid",
         lambda a, b: float(abs(a[0] - b[0]) + abs(a[1] - b[1]))),
        ("the Euclidean distance", lambda a, b: math.dist(a, b)),
    ],
    "astar": [
        ("a diagonal step costing 1", lambda *a: _astar_as_students_err(*a, diagonal=1.0)),
        ("corner cutting", lambda *a: _astar_as_students_err(*a, cut=True)),
        ("a heuristic that is not admissible",
         lambda *a: _astar_as_students_err(*a, weight=3.0)),
        ("a heuristic that is not admissible",          # Manhattan on 8 moves (issue 26)
         lambda *a: _astar_as_students_err(*a, manhattan=True)),
        ("a heuristic that is not admissible",          # 1.5 × octile (issue 26)
         lambda *a: _astar_as_students_err(*a, weight=1.5)),
        ("row and column swapped", lambda *a: _astar_as_students_err(*a, transposed=True)),
    ],
}


def _astar_honest(free, start, goal, heuristic, *, lifo=False, closed_set=True,
                  from_parents=False):
    """A correct A* written another way: any admissible heuristic, either tie order, with or
    without a closed set, the length summed back along the parents."""
    free = np.asarray(free, bool)
    h, w = free.shape
    start, goal = tuple(start), tuple(goal)
    g, parent, done, n = {start: 0.0}, {start: None}, set(), 0
    queue = [(heuristic(start, goal), 0, start)]
    while queue:
        f, _, cell = heapq.heappop(queue)
        if closed_set and cell in done:
            continue
        if not closed_set and f > g[cell] + heuristic(cell, goal) + 1e-12:
            continue                                   # a stale entry
        if cell == goal:
            if not from_parents:
                return g[cell]
            length, c = 0.0, cell
            while parent[c] is not None:
                p = parent[c]
                length += math.hypot(c[0] - p[0], c[1] - p[1])
                c = p
            return length
        done.add(cell)
        for dr in (1, 0, -1):
            for dc in (1, 0, -1):
                nxt = (cell[0] + dr, cell[1] + dc)
                if (dr or dc) and 0 <= nxt[0] < h and 0 <= nxt[1] < w and free[nxt] and \
                        (not (dr and dc) or (free[cell[0] + dr, cell[1]]
                                             and free[cell[0], cell[1] + dc])):
                    new = g[cell] + math.hypot(dr, dc)
                    if new < g.get(nxt, math.inf):
                        g[nxt], parent[nxt] = new, cell
                        n += 1
                        heapq.heappush(queue, (new + heuristic(nxt, goal), -n if lifo else n,
                                               nxt))
    return math.inf


HONEST["lab09"] = {
    "inflation_cost": [
        ("a loop over the cells with math.exp",
         lambda d, r, k: np.array([254 if x == 0 else 253 if x <= r else
                                   int(252 * math.exp(-k * (x - r)))
                                   for x in np.ravel(d)], np.uint8).reshape(np.shape(d))),
    ],
    "inflate": [
        ("distances in metres straight from the transform (sampling=resolution)",
         lambda *a: _inflate_in_metres(*a)),
    ],
    "octile_distance": [
        ("√2 − 1 times the shorter side on top of the longer one",
         lambda a, b: max(abs(a[0] - b[0]), abs(a[1] - b[1]))
         + (SQRT2 - 1) * min(abs(a[0] - b[0]), abs(a[1] - b[1]))),
    ],
    "astar": [
        ("Dijkstra (heuristic 0)", lambda *a: _astar_honest(*a, lambda c, g: 0.0)),
        ("the Euclidean heuristic", lambda *a: _astar_honest(*a, lambda c, g: math.dist(c, g))),
        ("the Chebyshev heuristic, newest first among ties",
         lambda *a: _astar_honest(*a, lambda c, g: max(abs(c[0] - g[0]), abs(c[1] - g[1])),
                                  lifo=True)),
        ("octile, no closed set, the length summed along the parents",
         lambda *a: _astar_honest(*a, lambda c, g: _octile(c, g), closed_set=False,
                                  from_parents=True)),
    ],
}


def _inflate_in_metres(lethal, res, r_in, radius, k):
    from scipy import ndimage

    lethal = np.asarray(lethal, bool)
    costs = np.zeros(lethal.shape, np.uint8)
    if not lethal.any():
        return costs
    metres = ndimage.distance_transform_edt(~lethal, sampling=res)
    near = metres <= math.ceil(radius / res) * res + 1e-9
    costs[near] = HONEST["lab09"]["inflation_cost"][0][1](metres[near], r_in, k)
    return costs


def _octile(a, b):
    dr, dc = abs(a[0] - b[0]), abs(a[1] - b[1])
    return max(dr, dc) - min(dr, dc) + SQRT2 * min(dr, dc)


# ------------------------------------------------------------------ lab 10 as students err

def _pp_as_students_err(pose, carrot, *, frame=True, two=2.0, use_x=False, turn=-1.0,
                        sign=1.0):
    dx, dy = carrot[0] - pose[0], carrot[1] - pose[1]
    if frame:
        c, s = math.cos(turn * pose[2]), math.sin(turn * pose[2])
        dx, dy = c * dx - s * dy, s * dx + c * dy
    return sign * two * (dx if use_x else dy) / (dx * dx + dy * dy)


def _rpp_as_students_err(k, remaining, desired, min_r, min_v, approach, min_approach, *,
                         floor=True, near_goal=True, inverted=False, of_desired=False,
                         approach_floor=True, floor_last=False, signed=False):
    v = desired
    r = math.inf if k == 0 else 1 / (k if signed else abs(k))
    if r < min_r:
        v = desired * (min_r / r if inverted else r / min_r)
    if floor and not floor_last and v < desired:
        v = max(v, min_v)
    if near_goal and remaining < approach:
        scaled = (desired if of_desired else v) * remaining / approach
        v = min(v, max(scaled, min_approach) if approach_floor else scaled)
    if floor_last and v < desired:
        v = max(v, min_v)
    return v


def _window_as_students_err(v, w, T, max_v, max_w, a_v, a_w, n_v, n_w, *, period=None,
                            clip=True, whole=False, reverse=False, xy=False):
    t = T if period is None else period
    lo_v, hi_v, lo_w, hi_w = v - a_v * t, v + a_v * t, w - a_w * t, w + a_w * t
    if whole:
        lo_v, hi_v, lo_w, hi_w = 0.0, max_v, -max_w, max_w
    if clip:
        lo_v, hi_v = max(lo_v, -max_v if reverse else 0.0), min(hi_v, max_v)
        lo_w, hi_w = max(lo_w, -max_w), min(hi_w, max_w)
    vs, ws = np.linspace(lo_v, hi_v, n_v), np.linspace(lo_w, hi_w, n_w)
    if xy:
        return np.array([(a, b) for b in ws for a in vs])
    return np.array([(a, b) for a in vs for b in ws])


def _rollout_as_students_err(pose, v, w, T, steps, *, turn_first=False, dt=None, start=False):
    x, y, th = pose
    dt = T / steps if dt is None else dt
    out = [list(pose)] if start else []
    for _ in range(steps):
        th = th + w * dt if turn_first else th
        x, y = x + v * math.cos(th) * dt, y + v * math.sin(th) * dt
        th = th if turn_first else th + w * dt
        out.append([x, y, th])
    return np.array(out)


def _rollout_on_the_arc(pose, v, w, T, steps):
    x, y, th = pose
    out = []
    for k in range(1, steps + 1):
        t = k * T / steps
        if abs(w) < 1e-12:
            out.append([x + v * t * math.cos(th), y + v * t * math.sin(th), th])
        else:
            out.append([x + v / w * (math.sin(th + w * t) - math.sin(th)),
                        y - v / w * (math.cos(th + w * t) - math.cos(th)), th + w * t])
    return np.array(out)


def _goal_as_students_err(p, g, xy, yaw, *, wrap=True, less=False, heading=True,
                          absolute=True, squared=False, box=False):
    dx, dy = g[0] - p[0], g[1] - p[1]
    e = g[2] - p[2]
    if wrap:
        e = math.atan2(math.sin(e), math.cos(e))
    if absolute:
        e = abs(e)
    within = (lambda a, b: a < b) if less else (lambda a, b: a <= b)
    if box:
        close = within(abs(dx), xy) and within(abs(dy), xy)
    else:
        close = within(dx * dx + dy * dy if squared else math.sqrt(dx * dx + dy * dy), xy)
    return bool(close and (within(e, yaw) if heading else True))


LAB10 = {
    "pure_pursuit_curvature": [
        ("the carrot left in the map frame", lambda p, c: _pp_as_students_err(p, c, frame=False)),
        ("y / L² (the 2 left out)", lambda p, c: _pp_as_students_err(p, c, two=1.0)),
        ("x instead of y", lambda p, c: _pp_as_students_err(p, c, use_x=True)),
        ("the carrot rotated by +θ instead of −θ",
         lambda p, c: _pp_as_students_err(p, c, turn=1.0)),
        ("the curvature's sign flipped", lambda p, c: _pp_as_students_err(p, c, sign=-1.0)),
    ],
    "regulated_speed": [
        ("no floor at regulated_linear_scaling_min_speed",
         lambda *a: _rpp_as_students_err(*a, floor=False)),
        ("no slowing near the goal", lambda *a: _rpp_as_students_err(*a, near_goal=False)),
        ("min_radius / radius instead of radius / min_radius",
         lambda *a: _rpp_as_students_err(*a, inverted=True)),
        ("the goal approach scaling desired_linear_vel",
         lambda *a: _rpp_as_students_err(*a, of_desired=True)),
        ("no floor at min_approach_linear_velocity",
         lambda *a: _rpp_as_students_err(*a, approach_floor=False)),
        ("the floor at min_speed applied after the goal approach",
         lambda *a: _rpp_as_students_err(*a, floor_last=True)),
        ("the curvature's sign kept in the radius",
         lambda *a: _rpp_as_students_err(*a, signed=True)),
    ],
    "dynamic_window": [
        ("the window over one control period",
         lambda *a: _window_as_students_err(*a, period=0.05)),
        ("velocities beyond the limits", lambda *a: _window_as_students_err(*a, clip=False)),
        ("the acceleration limits ignored", lambda *a: _window_as_students_err(*a, whole=True)),
        ("the speed clipped at −max_v instead of 0",
         lambda *a: _window_as_students_err(*a, reverse=True)),
        ("ω varying slowest (meshgrid's default indexing)",
         lambda *a: _window_as_students_err(*a, xy=True)),
    ],
    "rollout": [
        ("heading turned before the step",
         lambda *a: _rollout_as_students_err(*a, turn_first=True)),
        ("dt = sim_time", lambda p, v, w, T, n: _rollout_as_students_err(p, v, w, T, n, dt=T)),
        ("the exact arc instead of Euler steps", _rollout_on_the_arc),
        ("the start pose included", lambda *a: _rollout_as_students_err(*a, start=True)),
    ],
    "goal_reached": [
        ("the heading error not wrapped", lambda *a: _goal_as_students_err(*a, wrap=False)),
        ("< instead of ≤ (the tolerances exclusive)",
         lambda *a: _goal_as_students_err(*a, less=True)),
        ("the heading not checked", lambda *a: _goal_as_students_err(*a, heading=False)),
        ("the heading not checked",                     # only the error's sign compared
         lambda *a: _goal_as_students_err(*a, absolute=False)),
        ("the distance measured wrong (squared, or per axis)",
         lambda *a: _goal_as_students_err(*a, squared=True)),
        ("the distance measured wrong (squared, or per axis)",
         lambda *a: _goal_as_students_err(*a, box=True)),
    ],
}


def _pp_honest_angle(pose, carrot):
    """2 sin α / L, α the carrot's bearing from the heading."""
    dx, dy = carrot[0] - pose[0], carrot[1] - pose[1]
    alpha = math.atan2(dy, dx) - pose[2]
    return 2.0 * math.sin(alpha) / math.hypot(dx, dy)


def _pp_honest_matrix(pose, carrot):
    c, s = np.cos(pose[2]), np.sin(pose[2])
    x, y = np.array([[c, s], [-s, c]]) @ (np.asarray(carrot, float)[:2] - np.asarray(pose)[:2])
    return float(2 * y / (x ** 2 + y ** 2))


def _rpp_honest_nav2(k, remaining, desired, min_r, min_v, approach, min_approach):
    """Nav2's code path: curvatureConstraint, the floor always, approachVelocityConstraint,
    then the clamp to [0, desired]."""
    v = desired
    radius = abs(1.0 / k) if k else math.inf
    if radius < min_r:
        v *= 1.0 - abs(radius - min_r) / min_r
    v = max(v, min_v)
    if remaining < approach:
        slowed = v * (remaining / approach)
        v = min(v, min_approach if slowed < min_approach else slowed)
    return min(max(v, 0.0), desired)


def _rpp_honest_kit_order(k, remaining, desired, min_r, min_v, approach, min_approach):
    """The floor only when regulated below desired, the approach as max(min(v, v s), m)."""
    v = desired * min(1.0, 1.0 / (abs(k) * min_r)) if k else desired
    if v < desired:
        v = max(v, min_v)
    if remaining < approach:
        v = max(min(v, v * remaining / approach), min_approach)
    return v


def _window_honest_loops(v, w, T, max_v, max_w, a_v, a_w, n_v, n_w):
    lo_v, hi_v = max(0.0, v - a_v * T), min(max_v, v + a_v * T)
    lo_w, hi_w = max(-max_w, w - a_w * T), min(max_w, w + a_w * T)
    rows = []
    for i in range(n_v):
        for j in range(n_w):
            rows.append((lo_v + (hi_v - lo_v) * i / (n_v - 1) if n_v > 1 else lo_v,
                         lo_w + (hi_w - lo_w) * j / (n_w - 1) if n_w > 1 else lo_w))
    return np.array(rows)


def _rollout_honest_vectorised(pose, v, w, T, steps):
    dt = T / steps
    th = pose[2] + w * dt * np.arange(steps + 1)          # heading before each step, and after
    x = pose[0] + np.cumsum(v * np.cos(th[:-1]) * dt)
    y = pose[1] + np.cumsum(v * np.sin(th[:-1]) * dt)
    return np.column_stack([x, y, th[1:]])


def _rollout_honest_wrapped(pose, v, w, T, steps):
    out = _rollout_as_students_err(pose, v, w, T, steps)
    out[:, 2] = (out[:, 2] + math.pi) % (2 * math.pi) - math.pi
    return out


def _goal_honest(p, g, xy, yaw, *, distance="hypot", wrap="atan2"):
    dx, dy = p[0] - g[0], p[1] - g[1]
    e = p[2] - g[2]
    e = {"atan2": lambda a: math.atan2(math.sin(a), math.cos(a)),
         "mod": lambda a: (a + math.pi) % (2 * math.pi) - math.pi,
         "remainder": lambda a: math.remainder(a, 2 * math.pi),
         "np.angle": lambda a: float(np.angle(np.exp(1j * a)))}[wrap](e)
    if distance == "squared":
        close = dx * dx + dy * dy <= xy * xy
    elif distance == "norm":
        close = np.linalg.norm([dx, dy]) <= xy
    else:
        close = math.hypot(dx, dy) <= xy
    return bool(close) and abs(e) <= yaw


HONEST["lab10"] = {
    "pure_pursuit_curvature": [
        ("2 sin α / L", _pp_honest_angle),
        ("a rotation matrix in numpy", _pp_honest_matrix),
    ],
    "regulated_speed": [
        ("Nav2's own code path", _rpp_honest_nav2),
        ("the kit's order of operations", _rpp_honest_kit_order),
    ],
    "dynamic_window": [
        ("two loops, the samples spaced by hand", _window_honest_loops),
    ],
    "rollout": [
        ("vectorised with cumulative sums", _rollout_honest_vectorised),
        ("the heading wrapped after every step", _rollout_honest_wrapped),
    ],
    "goal_reached": [
        ("math.hypot, atan2(sin, cos)", lambda *a: _goal_honest(*a)),
        ("squared distances, (a + π) mod 2π − π",
         lambda *a: _goal_honest(*a, distance="squared", wrap="mod")),
        ("np.linalg.norm, math.remainder",
         lambda *a: _goal_honest(*a, distance="norm", wrap="remainder")),
        ("np.angle of a unit complex number", lambda *a: _goal_honest(*a, wrap="np.angle")),
    ],
}


CATALOGUE = {"lab01": LAB01, "lab02": LAB02, "lab03": LAB03, "lab04": LAB04, "lab05": LAB05,
             "lab06": LAB06, "lab07": LAB07, "lab08": LAB08, "lab09": LAB09, "lab10": LAB10,
             # Lab 11 is graded closed-loop: an episode's verdict names what failed
             "lab11": {"make_controller": []}}
COINCIDENT: dict[tuple[str, str], set[str]] = {
    # mistakes that give the same numbers on some cases: the check names both there
    # Lab 01: backwards, int(x + 0.5) truncates like int(x) wherever x's fraction is ≥ .5;
    # the paper's factor ignores counts_per_rev too, and often rounds to the same unit
    ("rpm_to_drive_units", "truncation"): {"int(x + 0.5)"},
    ("rpm_to_drive_units", "int(x + 0.5)"): {"truncation"},
    ("rpm_to_drive_units", "the paper's rounded factor 43.7"):
        {"400 counts whatever counts_per_rev says"},
    ("rpm_to_drive_units", "400 counts whatever counts_per_rev says"):
        {"the paper's rounded factor 43.7"},
    # Lab 04: an error pushing further into saturation is frozen, as a reversed error is
    # wherever the true one brings the output back (and the missing dt can land there too)
    ("pi_step", "the integral without dt"): {"the error as measurement − set-point"},
    ("pi_step", "the error as measurement − set-point"): {"the integral without dt"},
    ("tick_delta", "a plain difference"): {"the increment modulo 2**bits, never negative"},
    ("tick_delta", "the increment modulo 2**bits, never negative"): {"a plain difference"},
    ("angle_residual", "an unwrapped difference"): {"a difference wrapped to [0, 2π)"},
    ("angle_residual", "a difference wrapped to [0, 2π)"): {"an unwrapped difference",
                                                            "a single ±2π correction"},
    # between 3π and 4π one turn off is what [0, 2π) gives too
    ("angle_residual", "a single ±2π correction"): {"a difference wrapped to [0, 2π)"},
    # Lab 09: both unit slips leave only the obstacle when the costs decay within a cell;
    # a transposed grid can block the path that a unit diagonal would have found
    ("inflate", "the inflation radius in metres against distances in cells"):
        {"distances in cells costed as metres"},
    ("inflate", "distances in cells costed as metres"):
        {"the inflation radius in metres against distances in cells"},
    # Lab 06: without inf among the ranges, both slips keep the same out-of-range readings
    ("valid_returns", "range limits ignored"): {"inf taken for a return"},
    ("valid_returns", "inf taken for a return"): {"range limits ignored"},
    # floor(253 e) and round(252 e) agree wherever the fraction of 252 e is at least 1 − e
    ("inflation_cost", "253 · exp(…) instead of (253 − 1) · exp(…)"):
        {"the decayed cost rounded instead of truncated"},
    ("inflation_cost", "the decayed cost rounded instead of truncated"):
        {"253 · exp(…) instead of (253 − 1) · exp(…)"},
    ("astar", "a diagonal step costing 1"): {"row and column swapped"},
    # Lab 10: where only the window's lowest speed leaves the limits, both slips keep it
    ("dynamic_window", "velocities beyond the limits"):
        {"the speed clipped at −max_v instead of 0"},
    ("dynamic_window", "the speed clipped at −max_v instead of 0"):
        {"velocities beyond the limits"},
    # a transposed grid can make the path longer: "longer than the shortest" names both
    ("astar", "row and column swapped"): {"a diagonal step costing 1",
                                          "a heuristic that is not admissible"},
    ("astar", "a heuristic that is not admissible"): {"row and column swapped"},
}
ENTRIES = [(lab, function, name, fn) for lab, table in CATALOGUE.items()
           for function, bugs in table.items() for name, fn in bugs]


@pytest.mark.parametrize(("lab", "function", "mistake", "buggy"), ENTRIES,
                         ids=[f"{lab}.{fn}: {name}" for lab, fn, name, _ in ENTRIES])
def test_each_classic_mistake_gets_exactly_its_hint(lab, function, mistake, buggy):
    exercise = load_lab(lab).exercise(function)
    allowed = {mistake} | COINCIDENT.get((function, mistake), set())
    failing_public, failing = [], []
    for seed in (None, *HIDDEN_SEEDS):
        cases = exercise.public if seed is None else hidden_cases(exercise, seed)
        for case in cases:
            names = hints(exercise, case, buggy)
            if names is None:
                continue
            failing.append((case.name, names))
            if seed is None:
                failing_public.append(names)
    assert failing, f"the buggy {function} passes every case: the cases cannot see {mistake!r}"
    for case_name, names in failing:
        assert mistake in names and names <= allowed, (case_name, names)
    assert any(names == {mistake} for names in failing_public), failing_public


# ------------------------------------------------------------------ every student loses points

STUDENTS = (*(f"student{i:02d}" for i in range(20)), "Zoë", "李明")
SECRETS = ("course-secret-one", "course-secret-two")
CAUGHT_ONLY_IN_PUBLIC: set[tuple[str, str]] = set()
"""(function, mistake) pairs that only the public cases can see, each with its reason in a
comment: every other mistake must be caught by each student's hidden cases alone, so that a
submission that fits the public cases by hand still loses points."""


def _fails(exercise, fn, cases) -> bool:
    for case in cases:
        try:
            got = fn(*copy.deepcopy(case.args), **copy.deepcopy(case.kwargs))
        except Exception:
            return True
        if explain(exercise, case, got) is not None:
            return True
    return False


def _hidden_cases(exercise, secret: str, student: str) -> list:
    return hidden_cases(exercise, course_seed(exercise.id, student, secret))


def _students_spared(exercise, fn) -> list[tuple[str, str]]:
    """The (secret, student) pairs whose hidden cases all pass ``fn``."""
    return [(secret, student) for secret in SECRETS for student in STUDENTS
            if not _fails(exercise, fn, _hidden_cases(exercise, secret, student))]


@pytest.mark.parametrize(("lab", "function", "mistake", "buggy"), ENTRIES,
                         ids=[f"{lab}.{fn}: {name}" for lab, fn, name, _ in ENTRIES])
def test_each_classic_mistake_loses_points_for_every_student(lab, function, mistake, buggy):
    """Whether a mistake costs points must not depend on which hidden cases a student's seed
    drew: the generators always include the cases that tell it apart."""
    exercise = load_lab(lab).exercise(function)
    if (function, mistake) in CAUGHT_ONLY_IN_PUBLIC:
        assert _fails(exercise, buggy, exercise.public)
        return
    spared = _students_spared(exercise, buggy)
    assert not spared, (f"{len(spared)} of {len(SECRETS) * len(STUDENTS)} students' hidden "
                        f"cases miss {mistake!r}, e.g. {spared[:3]}")


# ------------------------------------------------------------------ honest variants keep full marks
# Another correct way to write each exercise, as a student might: every one must pass the
# public cases and every student's hidden cases, whatever their seed drew (boundaries exact
# in binary where a rule's edge is tested, no case on a wrap-around's ±π itself).

def _wrap_mod(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def _homogeneous(p):
    c, s = math.cos(p[2]), math.sin(p[2])
    return np.array([[c, -s, p[0]], [s, c, p[1]], [0.0, 0.0, 1.0]])


def _points_complex(r, amin, inc, lo, hi, T):
    r = np.asarray(r, float)
    ok = _ok06(r, lo, hi)
    a = np.array([amin + i * inc for i in range(len(r))])[ok]
    z = r[ok] * np.exp(1j * (a + T[2])) + complex(T[0], T[1])
    return np.column_stack([z.real, z.imag])


def _points_matrix(r, amin, inc, lo, hi, T):
    r = np.asarray(r, float)
    a = np.linspace(amin, amin + (len(r) - 1) * inc, len(r))
    with np.errstate(invalid="ignore"):
        ok = ~np.isnan(r) & ~np.isinf(r) & (r >= lo) & (r <= hi)
    local = np.vstack([r[ok] * np.cos(a[ok]), r[ok] * np.sin(a[ok]), np.ones(ok.sum())])
    return (_homogeneous(T) @ local)[:2].T


def _deskew_relative(r, angle, beam, ref):
    from kit import geometry

    return geometry.transform_points(geometry.relative(ref, beam),
                                     [[r * math.cos(angle), r * math.sin(angle)]])[0]


def _deskew_matrices(r, angle, beam, ref):
    p = np.array([r * math.cos(angle), r * math.sin(angle), 1.0])
    return (np.linalg.inv(_homogeneous(ref)) @ _homogeneous(beam) @ p)[:2]


def _move_loop(belief, shift, under, exact, over):
    n = len(belief)
    out = [0.0] * n
    for i, b in enumerate(belief):
        for k, p in ((-1, under), (0, exact), (1, over)):
            out[(i + shift + k) % n] += p * b
    return np.array(out)


def _control_atan_wrap(a, b):
    dx, dy = b[0] - a[0], b[1] - a[1]
    trans = math.sqrt(dx * dx + dy * dy)
    rot1 = 0.0 if trans < 0.01 else math.atan2(dy, dx) - a[2]
    rot1 = math.atan2(math.sin(rot1), math.cos(rot1))
    rot2 = b[2] - a[2] - rot1
    return np.array([rot1, trans, math.atan2(math.sin(rot2), math.cos(rot2))])


def _control_complex(a, b):
    step = complex(b[0] - a[0], b[1] - a[1])
    rot1 = 0.0 if abs(step) < 0.01 else float(np.angle(step * np.exp(-1j * a[2])))
    return np.array([rot1, abs(step), float(np.angle(np.exp(1j * (b[2] - a[2] - rot1))))])


def _loglik_flat(poses, ends, dist, res, origin, z_hit, z_rand, sigma, rmax):
    p, e, d = np.asarray(poses, float), np.asarray(ends, float), np.asarray(dist, float)
    h, w = d.shape
    out = np.empty(len(p))
    for k, (x, y, th) in enumerate(p):
        c, s = math.cos(th), math.sin(th)
        col = np.floor((x + c * e[:, 0] - s * e[:, 1] - origin[0]) / res).astype(int)
        row = np.floor((y + s * e[:, 0] + c * e[:, 1] - origin[1]) / res).astype(int)
        inside = (row >= 0) & (row < h) & (col >= 0) & (col < w)
        dd = np.where(inside, np.take(d, np.where(inside, row * w + col, 0)), d.max())
        out[k] = np.log(z_hit * np.exp(-dd ** 2 / (2 * sigma ** 2)) + z_rand / rmax).sum()
    return out


def _lv_searchsorted(w, n, r):
    c = np.cumsum(np.asarray(w, float)) / np.sum(w)
    c[-1] = 1.0
    return np.searchsorted(c, [r + m / n for m in range(n)], side="right")


def _lv_stepping(w, n, r):
    w = np.asarray(w, float)
    c, i, u, out = w[0] / w.sum(), 0, r, []
    for _ in range(n):
        while u >= c and i < len(w) - 1:
            i += 1
            c += w[i] / w.sum()
        out.append(i)
        u += 1.0 / n
    return np.array(out)


def _edge_formula(xi, xj, z):
    ci, si, cz, sz = (math.cos(xi[2]), math.sin(xi[2]), math.cos(z[2]), math.sin(z[2]))
    dx, dy = xj[0] - xi[0], xj[1] - xi[1]
    a, b = ci * dx + si * dy - z[0], -si * dx + ci * dy - z[1]
    return np.array([cz * a + sz * b, -sz * a + cz * b, _wrap_mod(xj[2] - xi[2] - z[2])])


def _edge_homogeneous(xi, xj, z):
    E = np.linalg.inv(_homogeneous(z)) @ np.linalg.inv(_homogeneous(xi)) @ _homogeneous(xj)
    return np.array([E[0, 2], E[1, 2], math.atan2(E[1, 0], E[0, 0])])


def _jacobians_rotations(xi, xj, z):
    def rot(t):
        return np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])

    Ri, Rz = rot(xi[2]), rot(z[2])
    dRi = np.array([[-math.sin(xi[2]), -math.cos(xi[2])], [math.cos(xi[2]), -math.sin(xi[2])]])
    t = np.asarray(xj[:2], float) - np.asarray(xi[:2], float)
    A, B = -np.eye(3), np.eye(3)
    A[:2, :2], B[:2, :2] = -Rz.T @ Ri.T, Rz.T @ Ri.T
    A[:2, 2] = Rz.T @ dRi.T @ t
    return A, B


def _gn_delete(poses, edges, edge=_edge_formula, jac=_jacobians_rotations):
    x = np.asarray(poses, float)
    n = len(x)
    H, b = np.zeros((3 * n, 3 * n)), np.zeros(3 * n)
    for i, j, z, om in edges:
        e, (A, B) = edge(x[i], x[j], z), jac(x[i], x[j], z)
        J = np.zeros((3, 3 * n))
        J[:, 3 * i:3 * i + 3], J[:, 3 * j:3 * j + 3] = A, B
        H += J.T @ om @ J
        b += J.T @ om @ e
    keep = np.arange(3, 3 * n)
    dx = np.concatenate([np.zeros(3), np.linalg.lstsq(H[np.ix_(keep, keep)], -b[keep],
                                                      rcond=None)[0]])
    new = x + dx.reshape(n, 3)
    new[:, 2] = np.arctan2(np.sin(new[:, 2]), np.cos(new[:, 2]))
    return new


HONEST.update({
    "lab06": {
        "beam_angles": [
            ("linspace to the last beam", lambda amin, inc, n: np.linspace(
                amin, amin + (n - 1) * inc, n)),
            ("linspace without its end point", lambda amin, inc, n: np.linspace(
                amin, amin + n * inc, n, endpoint=False)),
            ("a list, beam by beam", lambda amin, inc, n: [amin + i * inc for i in range(n)]),
        ],
        "valid_returns": [
            ("comparisons alone (NaN and ±inf compare false or beyond a limit)",
             lambda r, lo, hi: _ok06(r, lo, hi) & (np.nan_to_num(np.asarray(r, float),
                                                                 nan=-1.0) >= lo)),
            ("one reading at a time", lambda r, lo, hi: [math.isfinite(v) and lo <= v <= hi
                                                        for v in r]),
        ],
        "scan_to_points": [
            ("complex numbers", _points_complex),
            ("a homogeneous transform", _points_matrix),
        ],
        "deskew_beam": [
            ("the relative pose T(t_ref)⁻¹ T(t_i) first", _deskew_relative),
            ("homogeneous matrices", _deskew_matrices),
        ],
        "depth_to_range": [
            ("z / cos α", lambda z, u, fx, cx: np.asarray(z, float) / np.cos(
                np.arctan2(np.asarray(u, float) - cx, fx))),
            ("z √(1 + tan² α)", lambda z, u, fx, cx: np.asarray(z, float) * np.sqrt(
                1 + ((np.asarray(u, float) - cx) / fx) ** 2)),
        ],
    },
    "lab07": {
        "sense": [
            ("np.where over the world", lambda belief, world, z, hit, miss: (
                b := np.asarray(belief) * np.where(np.array(world) == z, hit, miss)) / b.sum()),
        ],
        "move": [
            ("a loop over the cells", _move_loop),
        ],
        "odometry_control": [
            ("atan2(sin, cos) to wrap", _control_atan_wrap),
            ("complex numbers", _control_complex),
        ],
        "log_likelihoods": [
            ("the textbook's loops", _loglik07),
            ("one particle at a time, flat indices", _loglik_flat),
        ],
        "normalize_log_weights": [
            ("scipy's softmax", lambda lw: __import__("scipy.special").special.softmax(lw)),
            ("exp(l − logsumexp(l))", lambda lw: np.exp(
                np.asarray(lw) - __import__("scipy.special").special.logsumexp(lw))),
        ],
        "should_resample": [
            ("N_eff by a dot product", lambda w, t: 1 / np.dot(w, w) < t * len(w)),
            ("(Σw)² / Σw², not >=", lambda w, t: not (np.sum(w) ** 2 / np.sum(np.square(w))
                                                       >= t * np.size(w))),
        ],
        "low_variance_resample": [
            ("the book's loop, moving on while u >= c", _low_variance07),
            ("searchsorted on the normalised cumulative sum", _lv_searchsorted),
            ("a pointer stepped by 1/n", _lv_stepping),
        ],
    },
    "lab08": {
        "update_log_odds": [
            ("minimum of maximum", lambda odds, c, lo, hi: np.minimum(
                np.maximum(np.add(odds, c), lo), hi)),
            ("one cell at a time", lambda odds, c, lo, hi: np.array(
                [min(max(a + b, lo), hi) for a, b in zip(odds, c, strict=True)])),
        ],
        "beam_endpoints": [
            ("a loop over the finite beams", lambda r, amin, inc, pose: np.array(
                [[pose[0] + d * math.cos(pose[2] + amin + k * inc),
                  pose[1] + d * math.sin(pose[2] + amin + k * inc)]
                 for k, d in enumerate(r) if math.isfinite(d)]).reshape(-1, 2)),
            ("a homogeneous transform", lambda r, amin, inc, pose: _points_matrix(
                r, amin, inc, 0.0, np.inf, pose)),
        ],
        "edge_error": [
            ("the formula written out", _edge_formula),
            ("homogeneous matrices", _edge_homogeneous),
        ],
        "edge_jacobians": [
            ("rotation matrices and dR/dθ", _jacobians_rotations),
        ],
        "gauss_newton_step": [
            ("stacked Jacobian rows, node 0's rows deleted", _gn_delete),
            ("the catalogue's own error and Jacobians", lambda p, e: _gn_delete(
                p, e, edge=_edge, jac=_jac)),
        ],
    },
})
HONEST_ENTRIES = [(lab, function, name, fn) for lab, table in HONEST.items()
                  for function, variants in table.items() for name, fn in variants]


@pytest.mark.parametrize(("lab", "function", "variant", "honest"), HONEST_ENTRIES,
                         ids=[f"{lab}.{fn}: {name}" for lab, fn, name, _ in HONEST_ENTRIES])
def test_each_honest_variant_keeps_full_marks_for_every_student(lab, function, variant, honest):
    exercise = load_lab(lab).exercise(function)
    assert not _fails(exercise, honest, exercise.public), "a public case fails"
    failed = [(secret, student) for secret in SECRETS for student in STUDENTS
              if _fails(exercise, honest, _hidden_cases(exercise, secret, student))]
    assert not failed, (f"{len(failed)} of {len(SECRETS) * len(STUDENTS)} students lose points "
                        f"for {variant!r}, e.g. {failed[:3]}")


def test_honest_variants_cover_every_exercise_of_labs_06_to_08():
    for lab in ("lab06", "lab07", "lab08"):
        assert set(HONEST[lab]) == {ex.function for ex in load_lab(lab).exercises}, lab


def test_the_catalogue_covers_every_exercise_and_every_diagnostic():
    for lab in LABS:
        spec = load_lab(lab)
        table = CATALOGUE[lab]
        assert {ex.function for ex in spec.exercises} == set(table), lab
        for ex in spec.exercises:
            catalogued = {name for name, _ in table[ex.function]}
            assert {d.name for d in ex.diagnostics} <= catalogued, ex.id


def test_no_two_exercises_share_a_hint():
    """A hint names its exercise's mistake; the same words under two exercises would point a
    student at the other one."""
    seen: dict[str, str] = {}
    for lab in LABS:
        for ex in load_lab(lab).exercises:
            for diag in ex.diagnostics:
                assert seen.setdefault(diag.hint, ex.id) == ex.id, (diag.hint, ex.id)


# ------------------------------------------------------------------ the two hints issue 11 named

def test_swapped_wheels_in_the_twist_node_are_called_swapped_not_a_sign_error(capsys):
    from grader import checker

    def twist_to_motor_speeds(linear, angular, wheel_radius, wheel_separation, gear_ratio,
                              left_sign):
        return _twist(linear, angular, wheel_radius, wheel_separation, gear_ratio, left_sign,
                      swap=True)

    checker("lab01")(twist_to_motor_speeds)
    out = capsys.readouterr().out
    assert "swapped wheels" in out and "wrong sign" not in out, out


def test_theta_dot_in_degrees_per_second_gets_a_hint(capsys):
    from grader import checker

    def forward_kinematics(wheel_speeds, wheel_radius, wheel_separation):
        return _fk(wheel_speeds, wheel_radius, wheel_separation / 2) * np.array([1, 1, 57.29578])

    checker("lab01")(forward_kinematics)
    out = capsys.readouterr().out
    assert "θ̇ in degrees per second" in out, out


def test_the_igv_wheels_come_right_first_and_the_papers_order_is_named(capsys):
    """Replaces tests/test_grader.py's igv check, whose student now returns the right order."""
    from grader import checker

    def igv_wheel_rpm(linear, angular):
        return (4000 * linear - 1440 * angular) / 67, (4000 * linear + 1440 * angular) / 67

    checker("lab01")(igv_wheel_rpm)
    out = capsys.readouterr().out
    assert "✗ lab01.igv_wheel_rpm" in out and "the paper's order" in out, out


@pytest.mark.slow
def test_the_twist_node_built_from_the_forward_kinematics_loses_exactly_its_points(tmp_path):
    """tests/test_grader.py's seeded erratum-6 bug, for the renamed wheel_separation argument."""
    from pathlib import Path

    import nbformat

    from grader.grade import grade_notebook

    root = Path(__file__).resolve().parents[2]
    nb = nbformat.read(root / "solutions" / "01-kinematics.ipynb", as_version=4)
    old = ("wheels = inverse_kinematics([linear, 0.0, angular], wheel_radius, "
           "wheel_separation)")
    new = ("b = wheel_separation / 2\n    r = wheel_radius\n    wheels = np.array("
           "[r / 2 * linear + r / (2 * b) * angular, r / 2 * linear - r / (2 * b) * angular])")
    cells = [c for c in nb.cells if c.cell_type == "code" and old in c.source]
    assert len(cells) == 1
    cells[0].source = cells[0].source.replace(old, new)
    nbformat.write(nb, tmp_path / "bug.ipynb")
    spec = load_lab("lab01")
    result = grade_notebook(tmp_path / "bug.ipynb", spec)
    lost = {k: v for k, v in result.exercises.items() if v.points < v.max_points}
    assert list(lost) == ["lab01.twist_to_motor_speeds"]
    assert "erratum 6" in lost["lab01.twist_to_motor_speeds"].reason


# ------------------------------------------------------------------ Labs 06–08: hints that explain

def _checked(lab, fn, name, capsys):
    """What ``check`` prints for ``fn`` under the exercise's name, and the warnings raised."""
    import warnings

    from grader import checker

    def student(*args, **kwargs):
        return fn(*args, **kwargs)

    student.__name__ = name
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        checker(lab)(student)
    return capsys.readouterr().out, [str(w.message) for w in caught]


def test_should_resample_turned_round_is_told_the_comparison_not_to_multiply_by_n(capsys):
    """'>' for '<' answers every case wrongly, so each hint that fits its answer is given (a
    bool tells one bit): each must name the turned comparison. It costs every student."""
    def turned(w, t):
        return bool(1 / np.sum(np.square(w)) > t * len(w))

    assert not _students_spared(load_lab("lab07").exercise("should_resample"), turned)
    out, _ = _checked("lab07", turned, "should_resample", capsys)
    hints = [line for line in out.splitlines() if line.startswith("  this is what")]
    assert "✗ lab07.should_resample" in out and len(hints) == 3, out
    for line in hints:
        assert "(<, not >)" in line or "turned round" in line, line


def test_edge_error_with_the_composition_turned_round_names_the_inverted_transform(capsys):
    from kit import geometry

    out, _ = _checked("lab08", lambda xi, xj, z: geometry.relative(geometry.relative(xi, xj),
                                                                    z), "edge_error", capsys)
    assert "the other transform inverted" in out and "REP-103" not in out, out


def test_beam_angles_by_linspace_is_told_the_spacing_not_n_plus_one_points(capsys):
    out, _ = _checked("lab06", lambda amin, inc, n: np.linspace(amin, amin + n * inc, n),
                      "beam_angles", capsys)
    assert "n · angle_increment / (n − 1) apart" in out and "n + 1" not in out, out


def test_multinomial_resampling_loses_points_for_every_student_without_a_wrong_hint(capsys):
    """Independent draws cannot be recognised case by case (each call draws others), so no
    hint names them; they must still cost points under every student's hidden cases, and
    no other mistake's hint may be given.

    The draws come from one seeded stream, the same in every run: a draw can happen to be
    exactly what a known mistake answers (the boundary-to-the-left mistake's answer to a
    public case), and such an answer gets that mistake's hint, as any answer equal to it
    would; unseeded, ``check`` gave a hint in 5 of 600 runs, and this test failed once in a
    clean-clone run."""
    draws = np.random.default_rng(2026)

    def multinomial(w, n, r):
        w = np.asarray(w, float)
        return np.sort(draws.choice(len(w), n, p=w / w.sum()))

    exercise = load_lab("lab07").exercise("low_variance_resample")
    assert not _students_spared(exercise, multinomial)
    out, _ = _checked("lab07", multinomial, "low_variance_resample", capsys)
    assert "✗ lab07.low_variance_resample" in out and "this is what" not in out, out


@pytest.mark.parametrize("lab", ["lab06", "lab07", "lab08"])
def test_no_warning_reaches_the_check_output_of_a_seeded_mistake_or_a_nan_answer(lab, capsys):
    spec = load_lab(lab)
    for function, bugs in CATALOGUE[lab].items():
        expected = spec.exercise(function).reference(*spec.exercise(function).public[0].args)

        def nan(*args, _e=expected):
            if isinstance(_e, tuple):
                return tuple(np.full(np.shape(v), np.nan) for v in _e)
            return np.full(np.shape(_e), np.inf) if np.ndim(_e) else np.nan

        for name, buggy in [*bugs, ("NaN or inf", nan)]:
            out, warned = _checked(lab, buggy, function, capsys)
            assert "✗" in out and not warned, (function, name, warned)
            assert "Warning" not in out, (function, name, out)

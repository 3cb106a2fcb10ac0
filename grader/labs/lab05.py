"""Lab 05 — sensor fusion (see/think): the exercises, their cases and their known mistakes."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grader.labs._hidden import telling
from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import estimation as est

_BLOCKED = tuple(f"kit.estimation:{name}" for name in (
    "predict", "update", "residual", "nis", "nees", "EKF", "PlanarModel", "SensorConfig",
    "FusionFilter"))


def _spd(rng: np.random.Generator, n: int) -> Any:
    a = rng.normal(0, 1, (n, n))
    return a @ a.T + n * np.eye(n) * 0.1


# ---------------------------------------------------------------- predict

def _kf_predict(x: Any, P: Any, F: Any, Q: Any) -> Any:
    Fa = np.asarray(F, float)
    return est.predict(x, P, lambda s: Fa @ s, Fa, Q)


def _kf_predict_transposed(x: Any, P: Any, F: Any, Q: Any) -> Any:
    Fa = np.asarray(F, float)
    return Fa @ np.asarray(x, float), Fa.T @ np.asarray(P, float) @ Fa + np.asarray(Q, float)


def _kf_predict_no_q(x: Any, P: Any, F: Any, Q: Any) -> Any:
    Fa = np.asarray(F, float)
    return Fa @ np.asarray(x, float), Fa @ np.asarray(P, float) @ Fa.T


def _kf_predict_f_twice(x: Any, P: Any, F: Any, Q: Any) -> Any:
    Fa = np.asarray(F, float)
    return Fa @ np.asarray(x, float), Fa @ np.asarray(P, float) @ Fa + np.asarray(Q, float)


_PREDICT_MISTAKES = (
    Diagnostic("F transposed in the covariance", _kf_predict_transposed,
               "P⁻ = F P Fᵀ + Q, with F on the left"),
    Diagnostic("forgetting Q", _kf_predict_no_q,
               "the prediction adds the process noise: P⁻ = F P Fᵀ + Q"),
    Diagnostic("F P F, the second F not transposed", _kf_predict_f_twice,
               "the covariance of F x is F P Fᵀ: the F on the right is transposed"),
)


def _predict_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for _i in range(3):
        n = int(rng.integers(2, 5))
        cases.append(Case(f"random {n}-state", (rng.normal(0, 1, n), _spd(rng, n),
                                                np.eye(n) + rng.normal(0, 0.2, (n, n)),
                                                np.eye(n) * float(rng.uniform(0.01, 0.1)))))
    return cases


CV = np.array([[1.0, 0.1], [0.0, 1.0]])
kf_predict = Exercise(
    id="lab05.kf_predict", function="kf_predict", title="The prediction step",
    reference=_kf_predict, points=2,
    public=(Case("constant velocity", (np.array([0.0, 1.0]), np.eye(2), CV,
                                       np.diag([1e-4, 1e-2]))),
            Case("correlated", (np.array([1.0, -0.5]), np.array([[2.0, 0.3], [0.3, 0.5]]), CV,
                                np.diag([0.01, 0.01])))),
    hidden=telling(_predict_hidden, _kf_predict, _PREDICT_MISTAKES, 1e-9, 1e-12),
    rtol=1e-9, atol=1e-12,
    diagnostics=_PREDICT_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- update

def _joseph(x: Any, P: Any, z: Any, H: Any, R: Any) -> Any:
    Ha = np.atleast_2d(np.asarray(H, float))
    x_new, P_new, _, _ = est.update(x, P, z, lambda s: Ha @ s, Ha, R)
    return x_new, P_new


def _update_no_s(x: Any, P: Any, z: Any, H: Any, R: Any) -> Any:
    Ha = np.atleast_2d(np.asarray(H, float))
    Pa = np.asarray(P, float)
    K = Pa @ Ha.T @ np.linalg.inv(np.atleast_2d(np.asarray(R, float)))
    x_new = np.asarray(x, float) + K @ (np.asarray(z, float) - Ha @ np.asarray(x, float))
    I_KH = np.eye(len(x_new)) - K @ Ha
    return x_new, I_KH @ Pa @ I_KH.T + K @ np.atleast_2d(R) @ K.T


def _update_short_form(x: Any, P: Any, z: Any, H: Any, R: Any) -> Any:
    """The short form P⁺ = (I − K H) P⁻, exact only in exact arithmetic with the optimal K."""
    Ha = np.atleast_2d(np.asarray(H, float))
    Pa = np.asarray(P, float)
    xa = np.asarray(x, float)
    S = Ha @ Pa @ Ha.T + np.atleast_2d(np.asarray(R, float))
    K = Pa @ Ha.T @ np.linalg.inv(S)
    return xa + K @ (np.asarray(z, float) - Ha @ xa), (np.eye(len(xa)) - K @ Ha) @ Pa


def _precise_measurement(rng: np.random.Generator | None = None) -> Case:
    """A position measured 2⁵³ times more precisely than it was known: S = P + R rounds to P,
    K to 1 and I − K H to 0, and the short form's P⁺ loses the measured variance (≈ R).
    The public case uses powers of two, so that K is exactly 1 whether S is inverted or
    solved for."""
    if rng is None:
        p, r, q, c = 2.0**26, 2.0**-27, 1.0, 0.0
    else:
        p, r = float(rng.uniform(0.5, 2)) * 1e8, float(rng.uniform(0.5, 2)) * 1e-8
        q = float(rng.uniform(0.5, 2))
        c = float(rng.uniform(-0.5, 0.5)) * (p * q) ** 0.5
    return Case("a measurement far more precise than the prior",
                (np.array([0.0, 1.0]), np.array([[p, c], [c, q]]), np.array([0.3]),
                 np.array([[1.0, 0.0]]), np.array([[r]])))


def _update_s_not_inverted(x: Any, P: Any, z: Any, H: Any, R: Any) -> Any:
    Ha = np.atleast_2d(np.asarray(H, float))
    Pa, xa, Ra = np.asarray(P, float), np.asarray(x, float), np.atleast_2d(np.asarray(R, float))
    K = Pa @ Ha.T @ (Ha @ Pa @ Ha.T + Ra)
    I_KH = np.eye(len(xa)) - K @ Ha
    return xa + K @ (np.asarray(z, float) - Ha @ xa), I_KH @ Pa @ I_KH.T + K @ Ra @ K.T


def _update_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        n, m = 3, int(rng.integers(1, 3))
        cases.append(Case(f"random {i}", (rng.normal(0, 1, n), _spd(rng, n), rng.normal(0, 1, m),
                                          rng.normal(0, 1, (m, n)), _spd(rng, m))))
    cases.append(_precise_measurement(rng))
    return cases


_UPDATE_MISTAKES = (
    Diagnostic("a gain without S", _update_no_s,
               "K = P Hᵀ S⁻¹ with S = H P Hᵀ + R, not R alone"),
    Diagnostic("the short form (I − K H) P", _update_short_form,
               "when K H rounds to I the short form's P⁺ is rounding noise (0 "
               "here) instead of about R, and no longer positive definite; the "
               "Joseph form (I − K H) P (I − K H)ᵀ + K R Kᵀ keeps R's share"),
    Diagnostic("S multiplied, not inverted", _update_s_not_inverted,
               "the gain divides by the innovation's covariance: K = P Hᵀ S⁻¹ "
               "(np.linalg.inv(S), or np.linalg.solve), not P Hᵀ S"),
)

joseph_update = Exercise(
    id="lab05.joseph_update", function="joseph_update", title="The update step, Joseph form",
    reference=_joseph, points=3,
    public=(Case("position measured", (np.array([0.0, 1.0]), np.eye(2), np.array([0.3]),
                                       np.array([[1.0, 0.0]]), np.array([[0.25]]))),
            Case("both measured", (np.array([1.0, 0.0]), np.diag([2.0, 1.0]),
                                   np.array([1.5, 0.2]), np.eye(2), np.diag([0.5, 0.1]))),
            _precise_measurement()),
    hidden=telling(_update_hidden, _joseph, _UPDATE_MISTAKES, 1e-9, 1e-12),
    rtol=1e-9, atol=1e-12,
    diagnostics=_UPDATE_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- angles and NIS

def _angle_residual(z: float, z_hat: float) -> float:
    return float(est.residual([z], [z_hat], [0])[0])


def _angle_plain(z: float, z_hat: float) -> float:
    return z - z_hat


def _angle_wrapped_to_2pi(z: float, z_hat: float) -> float:
    return (z - z_hat) % (2 * np.pi)


def _angle_shift_forgotten(z: float, z_hat: float) -> float:
    return (z - z_hat) % (2 * np.pi) - np.pi


def _angle_one_turn(z: float, z_hat: float) -> float:
    d = z - z_hat
    return d - 2 * np.pi if d >= np.pi else d + 2 * np.pi if d < -np.pi else d


def _angles_hidden(rng: np.random.Generator) -> list[Case]:
    """Three pairs anywhere, one across ±π whose residual is negative (the measurement just
    clockwise of ±π, the prediction just counter-clockwise), one a gyro's unwrapped yaw two or
    three turns on."""
    cases = [Case(f"random {i}", (float(rng.uniform(-10, 10)), float(rng.uniform(-4, 4))))
             for i in range(3)]
    short, past = rng.uniform(0.01, 0.5, 2)
    cases.append(Case("random 3", (float(-math.pi + short), float(math.pi - past))))
    turns = int(rng.choice([-3, -2, 3]))
    z_hat = float(rng.uniform(-math.pi, math.pi))
    cases.append(Case("random 4", (z_hat + 2 * math.pi * turns + float(rng.uniform(-2.5, 2.5)),
                                   z_hat)))
    return cases


_ANGLE_MISTAKES = (
    Diagnostic("an unwrapped difference", _angle_plain,
               "wrap the difference to [-π, π)"),
    Diagnostic("a difference wrapped to [0, 2π)", _angle_wrapped_to_2pi,
               "a residual is signed: wrap to [-π, π), not [0, 2π)"),
    Diagnostic("(d mod 2π) − π", _angle_shift_forgotten,
               "shift before the modulo and back after: (d + π) mod 2π − π"),
    Diagnostic("a single ±2π correction", _angle_one_turn,
               "an unwrapped yaw can be several turns away: one ±2π is not always enough "
               "(wrap_angle, or (d + π) mod 2π − π)"),
)


angle_residual = Exercise(
    id="lab05.angle_residual", function="angle_residual", title="Angle-aware residuals",
    reference=_angle_residual, points=2,
    public=(Case("small", (0.3, 0.1)), Case("small, negative", (0.1, 0.3)),
            Case("across ±π", (3.1, -3.1)),
            Case("the other way", (-3.1, 3.1)), Case("several turns", (7.0, 0.0)),
            Case("a gyro's unwrapped yaw, three turns on", (19.5, 0.3))),
    hidden=telling(_angles_hidden, _angle_residual, _ANGLE_MISTAKES),
    diagnostics=_ANGLE_MISTAKES,
    blocked=_BLOCKED,
)


def _nis_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (rng.normal(0, 1, n), _spd(rng, n)))
            for i, n in enumerate([*rng.integers(1, 4, 2), int(rng.integers(2, 4))])]


_NIS_MISTAKES = (
    Diagnostic("yᵀ S y", lambda y, S: float(np.asarray(y) @ np.asarray(S) @ np.asarray(y)),
               "the innovation is weighed by the inverse of S"),
    Diagnostic("the Mahalanobis distance", lambda y, S: est.nis(y, S) ** 0.5,
               "the NIS is the squared distance yᵀ S⁻¹ y: no square root"),
    Diagnostic("divided by the dimension", lambda y, S: est.nis(y, S) / len(y),
               "the NIS of one update is yᵀ S⁻¹ y itself; dividing by dim(y) belongs to the "
               "average over many updates, compared with a χ² band"),
)


nis_exercise = Exercise(
    id="lab05.nis", function="nis", title="Normalised innovation squared",
    reference=est.nis, points=2,
    public=(Case("scalar", (np.array([0.5]), np.array([[0.25]]))),
            Case("two measurements", (np.array([1.0, -1.0]), np.array([[2.0, 0.5],
                                                                       [0.5, 1.0]])))),
    hidden=telling(_nis_hidden, est.nis, _NIS_MISTAKES, 1e-9), rtol=1e-9,
    diagnostics=_NIS_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- the planar model

def _jacobian(x: Any, dt: float) -> Any:
    return est.PlanarModel().F_x(np.asarray(x, float), dt)


def _jacobian_t(x: Any, dt: float) -> Any:
    return _jacobian(x, dt).T


def _jacobian_x_yaw_sign(x: Any, dt: float) -> Any:
    F = _jacobian(x, dt)
    F[0, 2] = -F[0, 2]
    return F


def _jacobian_half_forgotten(x: Any, dt: float) -> Any:
    """s = v_x Δt + a_x Δt² (the ½ forgotten), in the yaw and the acceleration columns."""
    x = np.asarray(x, float)
    F = _jacobian(x, dt)
    c, sn = math.cos(x[2]), math.sin(x[2])
    s = x[3] * dt + x[5] * dt * dt
    F[0, 2], F[1, 2] = -s * sn, s * c
    F[0, 5], F[1, 5] = dt * dt * c, dt * dt * sn
    return F


_JACOBIAN_MISTAKES = (
    Diagnostic("a transposed Jacobian", _jacobian_t,
               "row i holds the derivatives of state i"),
    Diagnostic("∂x'/∂ψ with the wrong sign", _jacobian_x_yaw_sign,
               "x' = x + s cos ψ, so ∂x'/∂ψ = −s sin ψ"),
    Diagnostic("the ½ of ½ a_x Δt² forgotten", _jacobian_half_forgotten,
               "s = v_x Δt + ½ a_x Δt²: the ½ belongs in ∂x'/∂ψ, ∂y'/∂ψ and in the a_x "
               "column (½ Δt² cos ψ, ½ Δt² sin ψ)"),
)


planar_jacobian = Exercise(
    id="lab05.planar_jacobian", function="planar_jacobian", title="The motion model's Jacobian",
    reference=_jacobian, points=3,
    public=(Case("standing still", (np.zeros(6), 0.1)),
            Case("driving and turning", (np.array([1.0, 2.0, 0.5, 0.4, 0.3, 0.1]), 0.05))),
    hidden=telling(lambda rng: [Case(f"random {i}", (rng.normal(0, 1, 6),
                                                      float(rng.uniform(0.01, 0.2))))
                                for i in range(3)], _jacobian, _JACOBIAN_MISTAKES, 1e-9, 1e-12),
    rtol=1e-9, atol=1e-12,
    diagnostics=_JACOBIAN_MISTAKES,
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- robot_localization configs

def _indices(config: Any) -> list[int]:
    fused = est.SensorConfig(tuple(bool(b) for b in config)).fused()
    return [est.STATE.index(f) for f in fused]


def _indices_raw(config: Any) -> list[int]:
    return [i for i, on in enumerate(config) if on]


WITH_VY = ("x", "y", "yaw", "vx", "vy", "vyaw", "ax")


def _indices_with_vy(config: Any) -> list[int]:
    """Indices into a state that keeps vy: [x, y, yaw, vx, vy, vyaw, ax]."""
    on = {name for name, flag in zip(est.CONFIG_FIELDS, config, strict=True) if flag}
    return [i for i, name in enumerate(WITH_VY) if name in on]


_INDEX_MISTAKES = (
    Diagnostic("the config's own indices", _indices_raw,
               "map config fields (x y z roll pitch yaw vx vy vz vroll vpitch vyaw "
               "ax ay az) onto the state [x, y, yaw, vx, vyaw, ax]"),
    Diagnostic("a state with vy", _indices_with_vy,
               "the kit's planar state has no vy (a differential drive does not slide): "
               "[x, y, yaw, vx, vyaw, ax], so vyaw is 4 and ax is 5"),
)


T, F = True, False
fused_state_indices = Exercise(
    id="lab05.fused_state_indices", function="fused_state_indices",
    title="robot_localization's configuration vectors", reference=_indices, points=2,
    public=(Case("the Uiabot's odom0_config", ((T, T, T, F, F, F, F, F, F, F, F, T, F, F, F),)),
            Case("the Uiabot's imu0_config", ((F, F, F, T, T, T, F, F, F, F, F, F, F, F, F),)),
            Case("velocities and acceleration", ((F,) * 6 + (T, T, F, F, F, T, T, F, F),))),
    hidden=telling(lambda rng: [Case(f"random {i}",
                                     (tuple(bool(b) for b in rng.random(15) < 0.4),))
                                for i in range(4)], _indices, _INDEX_MISTAKES),
    diagnostics=_INDEX_MISTAKES,
    blocked=_BLOCKED,
)


SPEC = LabSpec(
    name="lab05",
    title="Lab 05 — Sensor fusion",
    exercises=(kf_predict, joseph_update, angle_residual, nis_exercise, planar_jacobian,
               fused_state_indices),
)

"""Motion and measurement models shared by estimation, localization and SLAM.

An estimator depends on a *protocol*, not on one robot (the habit of Corke's Robotics
Toolbox): a motion model gives the next state ``f(x, u)`` and its Jacobians ``F_x = ∂f/∂x``
and ``F_u = ∂f/∂u``; a measurement model gives the predicted measurement ``h(x)`` and
``H_x = ∂h/∂x``. An EKF needs exactly these, a particle filter needs ``f`` and a way to
sample, and a pose graph needs ``f`` to chain odometry.

The planar state is ``x = (x, y, θ)`` [m, m, rad] in a fixed frame (``odom`` or ``map``,
REP-105), θ counter-clockwise (REP-103).

The odometry motion model (Thrun, Burgard & Fox, *Probabilistic Robotics*, § 5.4) takes as its
control the motion between two odometry poses, split into a first rotation, a translation and
a second rotation::

    δrot1 = atan2(ȳ' − ȳ, x̄' − x̄) − θ̄,   δtrans = √((x̄' − x̄)² + (ȳ' − ȳ)²),
    δrot2 = θ̄' − θ̄ − δrot1

and perturbs each with zero-mean noise whose variance grows with the motion, through the four
parameters AMCL calls ``alpha1`` … ``alpha4``:

==========  ===========================================================
``alpha1``  rotation noise from rotation     (rad² per rad²)
``alpha2``  rotation noise from translation  (rad² per m²)
``alpha3``  translation noise from translation (m² per m²)
``alpha4``  translation noise from rotation  (m² per rad²)
==========  ===========================================================

Two details follow Nav2's ``DifferentialMotionModel``: a translation under 1 cm gets
``δrot1 = 0`` (a bearing between two nearly equal positions is noise, as in a turn on the
spot), and the rotations enter the noise as their distance from 0 *or* π, whichever is
smaller, so driving backwards (δrot1 ≈ π) is as certain as driving forwards.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry

__all__ = [
    "MeasurementModel",
    "MotionModel",
    "OdometryMotionModel",
    "RangeBearingModel",
    "odometry_control",
    "sample_odometry_motion",
]

FloatArray = NDArray[np.float64]

IN_PLACE_TRANSLATION = 0.01
"""m: below this translation δrot1 is taken as 0 (Nav2's guard for turns on the spot)."""


@runtime_checkable
class MotionModel(Protocol):
    """``x' = f(x, u)`` with its Jacobians; ``x`` of shape (n,), ``u`` of shape (m,)."""

    def f(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        """The state after control ``u``, shape (n,)."""
        ...

    def F_x(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂x``, shape (n, n)."""
        ...

    def F_u(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        """``∂f/∂u``, shape (n, m)."""
        ...


@runtime_checkable
class MeasurementModel(Protocol):
    """``z = h(x)`` with its Jacobian."""

    def h(self, x: ArrayLike) -> FloatArray:
        """The predicted measurement, shape (k,)."""
        ...

    def H_x(self, x: ArrayLike) -> FloatArray:
        """``∂h/∂x``, shape (k, n)."""
        ...


def _check_alphas(alphas: ArrayLike) -> FloatArray:
    a = np.asarray(alphas, dtype=np.float64)
    if a.shape != (4,) or not np.all(np.isfinite(a)) or np.any(a < 0):
        raise ValueError(f"alphas must be four non-negative numbers (AMCL's alpha1..alpha4); "
                         f"got {alphas!r}")
    return a


def _check_control(u: ArrayLike) -> FloatArray:
    c = np.asarray(u, dtype=np.float64)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise ValueError(f"an odometry control is (δrot1 [rad], δtrans [m], δrot2 [rad]); "
                         f"got {u!r}")
    return c


def odometry_control(odom_previous: ArrayLike, odom_current: ArrayLike) -> FloatArray:
    """The control ``u = (δrot1, δtrans, δrot2)`` that takes the odometry pose
    ``odom_previous`` to ``odom_current`` (both ``(x, y, θ)`` in ``odom``).

    >>> odometry_control([0.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2]).round(6).tolist()
    [0.785398, 1.414214, 0.785398]
    >>> odometry_control([0.0, 0.0, 0.0], [0.0, 0.0, 0.5]).tolist()  # a turn on the spot
    [0.0, 0.0, 0.5]
    """
    a = geometry.check_pose(odom_previous, "odom_previous")
    b = geometry.check_pose(odom_current, "odom_current")
    if a.ndim != 1 or b.ndim != 1:
        raise ValueError("odometry_control takes two single poses of shape (3,)")
    dx, dy = b[0] - a[0], b[1] - a[1]
    trans = math.hypot(dx, dy)
    rot1 = 0.0 if trans < IN_PLACE_TRANSLATION else \
        float(geometry.wrap_angle(math.atan2(dy, dx) - a[2]))
    rot2 = float(geometry.wrap_angle(b[2] - a[2] - rot1))
    return np.array([rot1, trans, rot2])


def _rotation_noise(rot: FloatArray | float) -> FloatArray:
    """min(|rot|, |rot − π|) after wrapping: a backwards move is as certain as a forward one."""
    return np.minimum(np.abs(geometry.wrap_angle(rot)), np.abs(geometry.wrap_angle(
        np.asarray(rot) - np.pi)))


Control = Callable[[ArrayLike, ArrayLike], ArrayLike]
"""``control(odom_previous, odom_current) -> (δrot1, δtrans, δrot2)``, as
:func:`odometry_control`."""


def sample_odometry_motion(poses: ArrayLike, odom_previous: ArrayLike, odom_current: ArrayLike,
                           alphas: ArrayLike, rng: np.random.Generator,
                           control: Control | None = None) -> FloatArray:
    """Move every particle by the odometry's motion, with sampled noise
    (*Probabilistic Robotics*, table 5.6, as Nav2's AMCL applies it).

    .. math::
        \\hat δ_{rot1} = δ_{rot1} − ε(α_1 δ_{rot1}^2 + α_2 δ_{trans}^2),\\quad
        \\hat δ_{trans} = δ_{trans} − ε(α_3 δ_{trans}^2 + α_4 (δ_{rot1}^2 + δ_{rot2}^2)),\\quad
        \\hat δ_{rot2} = δ_{rot2} − ε(α_1 δ_{rot2}^2 + α_2 δ_{trans}^2)

    where ``ε(b²)`` is a zero-mean normal draw of variance ``b²``, then
    ``x' = x + \\hat δ_{trans} cos(θ + \\hat δ_{rot1})``,
    ``y' = y + \\hat δ_{trans} sin(θ + \\hat δ_{rot1})``,
    ``θ' = θ + \\hat δ_{rot1} + \\hat δ_{rot2}``.

    Parameters
    ----------
    poses : array_like, shape (N, 3)
        Particles ``(x, y, θ)`` in ``map`` [m, m, rad].
    odom_previous, odom_current : array_like, shape (3,)
        The odometry poses (``odom → base``) at the last update and now.
    alphas : array_like, shape (4,)
        AMCL's ``alpha1`` … ``alpha4``.
    rng : numpy.random.Generator
        The source of the noise.
    control : callable, optional
        Computes the control in place of :func:`odometry_control` (same arguments, same
        result).

    Returns
    -------
    ndarray, shape (N, 3)
        The moved particles, θ wrapped to [−π, π).

    >>> rng = np.random.default_rng(0)
    >>> sample_odometry_motion([[1.0, 2.0, np.pi / 2]], [0, 0, 0], [1.0, 0, 0], [0] * 4,
    ...                        rng).round(6).tolist()   # no noise: the odometry's motion
    [[1.0, 3.0, 1.570796]]
    """
    p = geometry.check_pose(poses, "poses").reshape(-1, 3)
    a = _check_alphas(alphas)
    rot1, trans, rot2 = _check_control((control or odometry_control)(odom_previous,
                                                                     odom_current))
    n1, n2 = _rotation_noise(rot1), _rotation_noise(rot2)
    n = len(p)
    rot1_hat = rot1 - rng.normal(0.0, math.sqrt(a[0] * n1**2 + a[1] * trans**2), n)
    trans_hat = trans - rng.normal(0.0, math.sqrt(a[2] * trans**2 + a[3] * (n1**2 + n2**2)), n)
    rot2_hat = rot2 - rng.normal(0.0, math.sqrt(a[0] * n2**2 + a[1] * trans**2), n)
    heading = p[:, 2] + rot1_hat
    return np.column_stack([p[:, 0] + trans_hat * np.cos(heading),
                            p[:, 1] + trans_hat * np.sin(heading),
                            geometry.wrap_angle(heading + rot2_hat)])


@dataclass(frozen=True)
class OdometryMotionModel:
    """The odometry motion model of a differential drive as a :class:`MotionModel`.

    ``u = (δrot1, δtrans, δrot2)`` from :func:`odometry_control`; :meth:`control_covariance`
    is the noise ``M`` of ``u`` (the EKF's process noise is ``F_u M F_uᵀ``), :meth:`sample`
    draws many successors at once (the particle filter's prediction).

    >>> model = OdometryMotionModel()
    >>> model.f([0.0, 0.0, 0.0], [np.pi / 2, 1.0, 0.0]).round(6).tolist()
    [0.0, 1.0, 1.570796]
    """

    alpha1: float = 0.2
    alpha2: float = 0.2
    alpha3: float = 0.2
    alpha4: float = 0.2

    def __post_init__(self) -> None:
        _check_alphas(self.alphas)

    @property
    def alphas(self) -> FloatArray:
        return np.array([self.alpha1, self.alpha2, self.alpha3, self.alpha4])

    def f(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        p = geometry.check_pose(x, "x")
        rot1, trans, rot2 = _check_control(u)
        heading = p[..., 2] + rot1
        return np.stack([p[..., 0] + trans * np.cos(heading), p[..., 1] + trans * np.sin(heading),
                         geometry.wrap_angle(heading + rot2)], axis=-1)

    def F_x(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        p = geometry.check_pose(x, "x")
        rot1, trans, _ = _check_control(u)
        heading = float(p[2]) + rot1
        return np.array([[1.0, 0.0, -trans * math.sin(heading)],
                         [0.0, 1.0, trans * math.cos(heading)],
                         [0.0, 0.0, 1.0]])

    def F_u(self, x: ArrayLike, u: ArrayLike) -> FloatArray:
        p = geometry.check_pose(x, "x")
        rot1, trans, _ = _check_control(u)
        heading = float(p[2]) + rot1
        c, s = math.cos(heading), math.sin(heading)
        return np.array([[-trans * s, c, 0.0],
                         [trans * c, s, 0.0],
                         [1.0, 0.0, 1.0]])

    def control_covariance(self, u: ArrayLike) -> FloatArray:
        """``M = diag(α1 r1² + α2 t², α3 t² + α4 (r1² + r2²), α1 r2² + α2 t²)`` with ``r``
        the rotations' distances from 0 or π."""
        rot1, trans, rot2 = _check_control(u)
        n1, n2 = float(_rotation_noise(rot1)), float(_rotation_noise(rot2))
        a1, a2, a3, a4 = self.alphas
        return np.diag([a1 * n1**2 + a2 * trans**2, a3 * trans**2 + a4 * (n1**2 + n2**2),
                        a1 * n2**2 + a2 * trans**2])

    def sample(self, poses: ArrayLike, odom_previous: ArrayLike, odom_current: ArrayLike,
               rng: np.random.Generator) -> FloatArray:
        """:func:`sample_odometry_motion` with this model's alphas."""
        return sample_odometry_motion(poses, odom_previous, odom_current, self.alphas, rng)


@dataclass(frozen=True)
class RangeBearingModel:
    """Range and bearing from the robot to a known landmark, a :class:`MeasurementModel`.

    .. math:: h(x) = \\begin{pmatrix} \\sqrt{Δx^2 + Δy^2} \\\\
              \\mathrm{wrap}(\\operatorname{atan2}(Δy, Δx) − θ) \\end{pmatrix},\\quad
              Δ = m − (x, y)

    >>> RangeBearingModel((3.0, 4.0)).h([0.0, 0.0, 0.0]).round(6).tolist()
    [5.0, 0.927295]
    """

    landmark: tuple[float, float]

    def h(self, x: ArrayLike) -> FloatArray:
        p = geometry.check_pose(x, "x")
        dx, dy = self.landmark[0] - p[0], self.landmark[1] - p[1]
        return np.array([math.hypot(dx, dy),
                         float(geometry.wrap_angle(math.atan2(dy, dx) - p[2]))])

    def H_x(self, x: ArrayLike) -> FloatArray:
        p = geometry.check_pose(x, "x")
        dx, dy = self.landmark[0] - p[0], self.landmark[1] - p[1]
        q = dx * dx + dy * dy
        if q == 0.0:
            raise ValueError("the bearing to a landmark at the robot's own position is undefined")
        r = math.sqrt(q)
        return np.array([[-dx / r, -dy / r, 0.0],
                         [dy / q, -dx / q, -1.0]])

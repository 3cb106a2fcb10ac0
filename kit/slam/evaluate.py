"""The SLAM benchmark's metric (Kümmerle et al., "On measuring the accuracy of SLAM
algorithms", Autonomous Robots 27(4), 2009).

For each ground-truth relation ``δ* = x*(t1)⁻¹ ⊕ x*(t2)`` the trajectory under test gives
``δ̂ = x̂(t1)⁻¹ ⊕ x̂(t2)``, and the relation's error is

.. math:: ε = δ̂^{-1} ⊕ δ^*

whose translation ``|ε_xy|`` [m] and rotation ``|wrap(ε_θ)|`` [rad] are averaged (mean ± std,
and the squared versions) over all relations and over the local ones (``t2 − t1`` at most
``local_seconds``, 1 s by default: the subset scan-to-scan matching is judged on). The
metric depends only on relative poses, so a trajectory in any global frame can be scored.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs
from kit.slam.carmen import Relations

__all__ = ["ErrorSummary", "RelationErrors", "align_maps", "map_agreement", "occupied_points",
           "perturb_odometry", "relation_errors", "summarize"]

FloatArray = NDArray[np.float64]


@dataclass(frozen=True, eq=False)
class RelationErrors:
    """Per-relation errors of the relations whose two times are in the trajectory."""

    translational: FloatArray
    """|ε_xy| [m], one per evaluated relation."""
    rotational: FloatArray
    """|ε_θ| [rad]."""
    span: FloatArray
    """t2 − t1 [s]."""
    evaluated: NDArray[np.bool_]
    """Which of the file's relations were matched to trajectory stamps."""


@dataclass(frozen=True)
class ErrorSummary:
    count: int
    translational_mean: float
    translational_std: float
    rotational_mean_deg: float
    rotational_std_deg: float
    translational_sq_mean: float
    translational_sq_std: float
    rotational_sq_mean_deg2: float
    rotational_sq_std_deg2: float

    def line(self, label: str) -> str:
        return (f"{label:8s} {self.count:5d}  {self.translational_mean:.4f} ± "
                f"{self.translational_std:.4f} m  {self.rotational_mean_deg:.3f} ± "
                f"{self.rotational_std_deg:.3f} deg")


def _match(stamps: FloatArray, times: FloatArray, tolerance: float
           ) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    order = np.argsort(stamps)
    s = stamps[order]
    k = np.clip(np.searchsorted(s, times), 1, max(len(s) - 1, 1))
    left, right = s[k - 1], s[np.minimum(k, len(s) - 1)]
    nearest = np.where(np.abs(times - left) <= np.abs(right - times), k - 1, k)
    nearest = np.minimum(nearest, len(s) - 1)
    ok = np.abs(s[nearest] - times) <= tolerance
    return order[nearest], ok


def relation_errors(stamps: ArrayLike, poses: ArrayLike, relations: Relations,
                    tolerance: float = 1e-3) -> RelationErrors:
    """The error of every relation whose times match trajectory ``stamps`` within
    ``tolerance`` seconds.

    Parameters
    ----------
    stamps : array_like, shape (N,)
        Times [s] of the trajectory's poses (the log's IPC timestamps).
    poses : array_like, shape (N, 3)
        The robot's estimated poses (x, y, θ) in any fixed frame.
    relations
        From :func:`kit.slam.carmen.read_relations`.

    >>> from kit.slam.carmen import Relations
    >>> rel = Relations(np.array([0.0]), np.array([1.0]), np.array([[1.0, 0.0, 0.0]]))
    >>> e = relation_errors([0.0, 1.0], [[0, 0, 0], [1.1, 0, 0.1]], rel)
    >>> round(float(e.translational[0]), 4), round(float(e.rotational[0]), 4)
    (0.1, 0.1)
    """
    t = np.asarray(stamps, dtype=np.float64)
    x = geometry.check_pose(poses, "poses")
    if t.ndim != 1 or x.ndim != 2 or len(t) != len(x) or len(t) == 0:
        raise ValueError(f"stamps (N,) and poses (N, 3) must have the same non-zero length; "
                         f"got {t.shape} and {x.shape}")
    i1, ok1 = _match(t, relations.t1, tolerance)
    i2, ok2 = _match(t, relations.t2, tolerance)
    ok = ok1 & ok2
    estimated = geometry.relative(x[i1[ok]], x[i2[ok]])
    eps = geometry.compose(geometry.inverse(estimated), relations.delta[ok])
    return RelationErrors(np.hypot(eps[:, 0], eps[:, 1]),
                          np.abs(geometry.wrap_angle(eps[:, 2])),
                          relations.t2[ok] - relations.t1[ok], ok)


def summarize(errors: RelationErrors, local_seconds: float | None = None) -> ErrorSummary:
    """Mean ± std of the errors (all of them, or those spanning at most ``local_seconds``)."""
    sel = np.ones(len(errors.span), dtype=bool) if local_seconds is None else \
        np.abs(errors.span) <= local_seconds
    if not sel.any():
        raise ValueError("no relation to summarise (none matched the trajectory's stamps)")
    tr, rot = errors.translational[sel], np.degrees(errors.rotational[sel])
    return ErrorSummary(int(sel.sum()), float(tr.mean()), float(tr.std()), float(rot.mean()),
                        float(rot.std()), float((tr**2).mean()), float((tr**2).std()),
                        float((rot**2).mean()), float((rot**2).std()))


def perturb_odometry(poses: ArrayLike, seed: int, scale: float = 0.02,
                     heading_scale: float = 0.01, drift: float = 0.01,
                     noise_xy: tuple[float, float] = (0.01, 0.002),
                     noise_theta: tuple[float, float, float] = (0.01, 0.002, 0.0005)
                     ) -> FloatArray:
    """Odometry with a seeded, wheel-like error, made from ``poses`` ``(N, 3)`` (a log's
    corrected poses, or any trajectory): every step ``Δ = x_{k−1}⁻¹ ⊕ x_k`` becomes

    .. math:: Δ' = ((1 + s) Δx, (1 + s) Δy, (1 + h) Δθ + κ d) + n

    with ``s`` the distance ``scale`` error, ``h`` the ``heading_scale`` error, ``κ`` the
    ``drift`` [rad/m], ``d = |(Δx, Δy)|`` and ``n`` Gaussian with standard deviations
    ``a d + b`` [m] in x and y (``noise_xy = (a, b)``) and ``a_θ |Δθ| + b_θ d + c_θ``
    [rad] (``noise_theta``); the steps are chained from the first pose. The defaults are
    the SLAM issue's: +2 % distance, +1 % turning, 0.01 rad/m drift.

    >>> p = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    >>> perturb_odometry(p, 0, noise_xy=(0, 0), noise_theta=(0, 0, 0)).round(3).tolist()
    [[0.0, 0.0, 0.0], [1.02, 0.0, 0.01]]
    """
    x = geometry.check_pose(poses, "poses")
    if x.ndim != 2 or len(x) == 0:
        raise ValueError(f"poses must have shape (N, 3) with N >= 1; got {x.shape}")
    rng = np.random.default_rng(seed)
    steps = geometry.relative(x[:-1], x[1:])
    d = np.hypot(steps[:, 0], steps[:, 1])
    sd_xy = noise_xy[0] * d + noise_xy[1]
    sd_th = noise_theta[0] * np.abs(steps[:, 2]) + noise_theta[1] * d + noise_theta[2]
    noisy = np.column_stack([steps[:, 0] * (1 + scale), steps[:, 1] * (1 + scale),
                             steps[:, 2] * (1 + heading_scale) + drift * d])
    noisy += rng.standard_normal((len(steps), 3)) * np.column_stack([sd_xy, sd_xy, sd_th])
    out = np.empty_like(x)
    out[0] = x[0]
    for k, step in enumerate(noisy):
        out[k + 1] = geometry.compose(out[k], step)
    return out


# ----------------------------------------------------------------------------- maps
def occupied_points(grid: msgs.OccupancyGrid) -> FloatArray:
    """Centres [m] of the grid's occupied cells (value 100), ``(M, 2)``; the grid's origin
    must not be rotated."""
    info = grid.info
    o = info.origin
    if abs(float(geometry.quaternion_to_yaw([o.orientation.x, o.orientation.y,
                                             o.orientation.z, o.orientation.w]))) > 1e-9:
        raise ValueError("occupied_points needs a map whose origin is not rotated")
    rows, cols = np.nonzero(grid.data.reshape(info.height, info.width) == 100)
    return np.column_stack([o.position.x + (cols + 0.5) * info.resolution,
                            o.position.y + (rows + 0.5) * info.resolution])


def align_maps(grid: msgs.OccupancyGrid, reference: msgs.OccupancyGrid,
               initial: ArrayLike = (0.0, 0.0, 0.0), linear_window: float = 6.0) -> FloatArray:
    """``T_reference_grid``: the rigid pose that lays ``grid``'s occupied cells best on
    ``reference``'s — a correlative search over every heading (18 sectors of 20°, 1° steps)
    and ``initial ± linear_window`` metres, refined to 0.25° and one cell."""
    from kit.slam import scan_matching as sm
    from kit.slam.frontend import thin

    ours, theirs = occupied_points(grid), occupied_points(reference)
    if len(ours) == 0 or len(theirs) == 0:
        raise ValueError("both maps need occupied cells to be aligned")
    x0 = geometry.check_pose(initial)
    field = sm.likelihood_field(theirs, 0.05, 0.1, margin=2.0)
    source = thin(ours, 0.15)
    best = max((sm.correlative_match(source, field, [x0[0], x0[1], x0[2] + a],
                                     linear_window, np.radians(10), np.radians(1), 8)
                for a in np.radians(np.arange(-180, 180, 20))), key=lambda r: r.response)
    fine = sm.correlative_match(thin(ours, 0.05), field, best.pose, 0.3, np.radians(2),
                                np.radians(0.25), 2)
    return fine.pose


def map_agreement(grid: msgs.OccupancyGrid, reference: msgs.OccupancyGrid,
                  pose: ArrayLike | None = None, tolerance: float = 0.1
                  ) -> tuple[float, FloatArray]:
    """Share of ``grid``'s occupied cells within ``tolerance`` metres of an occupied cell of
    ``reference``, once aligned by ``pose`` (``T_reference_grid``; found by
    :func:`align_maps` when ``None``); returns the share and the pose."""
    from scipy.spatial import cKDTree

    p = align_maps(grid, reference) if pose is None else geometry.check_pose(pose)
    distance, _ = cKDTree(occupied_points(reference)).query(
        geometry.transform_points(p, occupied_points(grid)))
    return float(np.mean(distance <= tolerance)), p

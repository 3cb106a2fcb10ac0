"""Scan matching: where is a scan, given a reference (another scan or a local map)?

Two matchers, used together by the SLAM front end:

* **Point-to-line ICP** (Censi's PL-ICP family, here with Gauss–Newton steps): each source
  point ``p`` is moved by the pose ``x = (t, θ)`` to ``q = R(θ) p + t`` and paired with its
  nearest reference point ``m``, whose surface normal is ``n``; the residual is the distance
  to the reference's local line, ``r = nᵀ (q − m)``. Each iteration minimises

  .. math:: \\sum_k \\frac{r_k^2}{σ^2} + (x - x_p)^T Ω_p (x - x_p)

  over the pairs that survive trimming (the ``trim`` fraction with the smallest ``|r|``,
  after dropping pairs farther apart than ``max_distance``), where ``x_p`` is an odometry
  prior with information ``Ω_p``. The covariance of the result is ``(Jᵀ J / s² + Ω_p)⁻¹`` with
  ``s²`` the residuals' variance (never below ``σ²``): wide along a corridor, where the scan
  cannot tell positions apart and the prior takes over.

* **Correlative, multi-resolution matching** (Olson, ICRA 2009; Karto's matcher), in
  :mod:`kit.slam.correlative` and re-exported here: every pose of a search window scored
  against a likelihood field of the reference, the best found by branch and bound.

Poses are ``T_reference_source``: the source scan's frame in the reference frame.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry
from kit.slam.correlative import (
    LikelihoodField,
    MatchResult,
    correlative_match,
    likelihood_field,
)
from kit.slam.correlative import check_points as _check_points

__all__ = [
    "ODOMETRY_PRIOR",
    "IcpConfig",
    "LikelihoodField",
    "MatchResult",
    "PointCloudReference",
    "correlative_match",
    "estimate_normals",
    "icp",
    "icp_iteration",
    "likelihood_field",
]

FloatArray = NDArray[np.float64]

ODOMETRY_PRIOR = np.diag([1 / 0.05**2, 1 / 0.05**2, 1 / math.radians(3.0) ** 2])
"""Information of an odometry guess between scans a fraction of a second apart: 5 cm and
3° standard deviation (an assumption; wheel odometry's local error on the CSAIL log is
3 cm and 3° on average)."""
ODOMETRY_PRIOR.flags.writeable = False


# ----------------------------------------------------------------------------- ICP
def estimate_normals(points: ArrayLike, neighbours: int = 5, tree: Any = None,
                     max_spread: float = 0.5) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Unit surface normals of 2-D points from their nearest neighbours, and which are usable.

    The normal is the direction of least spread of the point and its ``neighbours`` nearest
    neighbours (the smaller eigenvector of their 2×2 covariance). A point is usable when that
    neighbourhood is line-like (the smaller eigenvalue under a tenth of the larger) and
    no neighbour lies farther than ``max_spread`` metres.

    Returns
    -------
    normals : (M, 2)
    usable : (M,) bool

    >>> pts = np.column_stack([np.linspace(0, 1, 11), np.full(11, 2.0)])
    >>> n, ok = estimate_normals(pts, neighbours=3)
    >>> bool(ok.all()), np.abs(n).round(6).max(axis=0).tolist()
    (True, [0.0, 1.0])
    """
    from scipy.spatial import cKDTree

    p = _check_points(points, "points")
    k = min(neighbours + 1, len(p))
    if k < 3:
        return np.zeros_like(p), np.zeros(len(p), dtype=bool)
    tree = cKDTree(p) if tree is None else tree
    dist, idx = tree.query(p, k=k)
    nb = p[idx]                                        # (M, k, 2)
    d = nb - nb.mean(axis=1, keepdims=True)
    cxx = (d[..., 0] ** 2).mean(axis=1)
    cyy = (d[..., 1] ** 2).mean(axis=1)
    cxy = (d[..., 0] * d[..., 1]).mean(axis=1)
    # direction of largest spread: angle φ with tan 2φ = 2 cxy / (cxx − cyy)
    phi = 0.5 * np.arctan2(2.0 * cxy, cxx - cyy)
    normals = np.column_stack([-np.sin(phi), np.cos(phi)])
    half_trace = 0.5 * (cxx + cyy)
    root = np.sqrt((0.5 * (cxx - cyy)) ** 2 + cxy**2)
    small, large = half_trace - root, half_trace + root
    usable = (small <= 0.1 * large) & (dist[:, -1] <= max_spread) & (large > 0)
    return normals, usable


@dataclass(frozen=True)
class IcpConfig:
    """Point-to-line ICP settings (SI units)."""

    max_iterations: int = 30
    max_distance: float = 0.5
    """Pairs farther apart than this [m] are not used."""
    trim: float = 0.9
    """Fraction of the remaining pairs kept, those with the smallest residuals."""
    sigma: float = 0.02
    """Assumed standard deviation of a point-to-line residual [m] (range noise)."""
    tolerance: float = 1e-4
    """Stop when a step moves less than this [m, rad]."""
    neighbours: int = 5
    """Neighbours used for a reference point's normal."""
    max_spread: float = 0.5
    """A normal whose neighbours spread wider than this [m] is not used."""

    def __post_init__(self) -> None:
        if not 0.0 < self.trim <= 1.0:
            raise ValueError(f"trim is a fraction in (0, 1]; got {self.trim}")
        if self.max_iterations < 1 or self.max_distance <= 0 or self.sigma <= 0:
            raise ValueError("max_iterations, max_distance and sigma must be positive")


@dataclass
class PointCloudReference:
    """Reference points with their normals and a k-d tree, built once and matched against
    many times (the previous scan, a local map)."""

    points: FloatArray
    config: IcpConfig = field(default_factory=IcpConfig)
    normals: FloatArray | None = None
    """Unit normals of ``points``, estimated from them when not given."""

    def __post_init__(self) -> None:
        pts = _check_points(self.points, "reference points")
        if self.normals is None:
            normals, usable = estimate_normals(pts, self.config.neighbours,
                                               max_spread=self.config.max_spread)
            pts, normals = pts[usable], normals[usable]
        else:
            normals = np.asarray(self.normals, dtype=np.float64)
            if normals.shape != pts.shape:
                raise ValueError(f"normals must match the points' shape {pts.shape}; got "
                                 f"{normals.shape}")
        self.points = pts
        self.normals = normals
        self._tree: Any = None
        self._buckets: _Buckets | None = None

    @property
    def tree(self) -> Any:
        """A ``scipy.spatial.cKDTree`` of ``points`` (``None`` when there are none), built
        when first asked for: ICP itself searches :meth:`buckets`."""
        if self._tree is None and len(self.points):
            from scipy.spatial import cKDTree

            self._tree = cKDTree(self.points)
        return self._tree

    def buckets(self) -> _Buckets:
        """The points sorted into square cells, for ICP's nearest-neighbour search."""
        if self._buckets is None:
            self._buckets = _Buckets.of(self.points, self.config.max_distance)
        return self._buckets


@dataclass(frozen=True)
class _Buckets:
    """Reference points sorted by the square cell of side ``cell`` they fall in: cell
    ``(i, j)`` (column ``i`` from ``origin[0]``, row ``j`` from ``origin[1]``) holds the
    points ``order[start[j * width + i]:start[j * width + i + 1]]``, in index order."""

    origin: FloatArray
    cell: float
    width: int
    height: int
    start: NDArray[np.int64]
    order: NDArray[np.int64]

    MAX_CELLS = 1 << 22
    """A reference spread so wide that cells of a quarter of ``max_distance`` would number
    more than this gets wider cells (the search is exact for any cell size)."""

    @classmethod
    def of(cls, points: FloatArray, max_distance: float) -> _Buckets:
        lo = points.min(axis=0)
        span = points.max(axis=0) - lo
        cell = max_distance / 4.0
        count = (span[0] / cell + 1.0) * (span[1] / cell + 1.0)
        if count > cls.MAX_CELLS:
            cell *= math.sqrt(count / cls.MAX_CELLS)
        width, height = int(span[0] // cell) + 1, int(span[1] // cell) + 1
        ix = np.minimum(np.floor((points[:, 0] - lo[0]) / cell), width - 1).astype(np.int64)
        iy = np.minimum(np.floor((points[:, 1] - lo[1]) / cell), height - 1).astype(np.int64)
        key = iy * width + ix
        order = np.argsort(key, kind="stable").astype(np.int64)
        start = np.zeros(width * height + 1, dtype=np.int64)
        np.cumsum(np.bincount(key, minlength=width * height), out=start[1:])
        return cls(lo.astype(np.float64), float(cell), width, height, start, order)


def _pairs(source: FloatArray, ref: PointCloudReference, pose: FloatArray, cfg: IcpConfig
           ) -> tuple[FloatArray, FloatArray, FloatArray, NDArray[np.int64], FloatArray]:
    """The moved source points ``q`` of the pairs kept (nearest reference point within
    ``max_distance``, then the ``trim`` fraction with the smallest residuals), their reference
    points, normals, source indices and residuals ``nᵀ (q − m)``."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    q = source @ np.array([[c, s], [-s, c]]) + pose[:2]
    assert ref.tree is not None  # icp() returns before matching against no points
    dist, idx = ref.tree.query(q, k=1, distance_upper_bound=cfg.max_distance)
    found = np.flatnonzero(dist < np.inf)
    assert ref.normals is not None
    q, m, n = q[found], ref.points[idx[found]], ref.normals[idx[found]]
    r = n[:, 0] * (q[:, 0] - m[:, 0]) + n[:, 1] * (q[:, 1] - m[:, 1])
    keep_count = max(3, math.ceil(cfg.trim * len(found)))
    if keep_count < len(found):
        keep = np.argpartition(np.abs(r), keep_count - 1)[:keep_count]
        q, m, n, found, r = q[keep], m[keep], n[keep], found[keep], r[keep]
    return q, m, n, found, r


def icp_iteration(source: FloatArray, reference: PointCloudReference, pose: ArrayLike,
                  prior: ArrayLike | None = None, prior_information: ArrayLike | None = None
                  ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """One Gauss–Newton step of point-to-line ICP.

    With ``q = R(θ) p + t`` the residual ``r = nᵀ (q − m)`` has the Jacobian
    ``J = [n_x, n_y, nᵀ (∂q/∂θ)]`` where ``∂q/∂θ = (−(q_y − t_y), q_x − t_x)``; the step
    solves ``(JᵀJ/σ² + Ω_p) Δx = −(Jᵀ r/σ² + Ω_p (x − x_p))``.

    Parameters
    ----------
    source : (M, 2)
        Points in the source frame [m].
    reference
        The reference points and normals.
    pose : (3,)
        Current ``T_reference_source``.
    prior, prior_information : (3,) and (3, 3), optional
        An odometry guess of the pose and its information matrix.

    Returns
    -------
    new_pose : (3,)
    H : (3, 3)
        ``Jᵀ J / σ²`` of the scan's pairs alone (no prior).
    residuals : (K,)
        Point-to-line residuals [m] of the kept pairs, before the step.
    """
    cfg = reference.config
    x = np.asarray(pose, dtype=np.float64)
    q, _, n, _, r = _pairs(source, reference, x, cfg)
    J = np.empty((len(r), 3))
    J[:, :2] = n
    J[:, 2] = -n[:, 0] * (q[:, 1] - x[1]) + n[:, 1] * (q[:, 0] - x[0])
    w = 1.0 / cfg.sigma**2
    H = w * (J.T @ J)
    g = w * (J.T @ r)
    A = H
    if prior is not None:
        omega = np.asarray(prior_information, dtype=np.float64)
        d = x - np.asarray(prior, dtype=np.float64)
        d[2] = float(geometry.wrap_angle(d[2]))
        A = H + omega
        g = g + omega @ d
    try:
        step = -np.linalg.solve(A, g)
    except np.linalg.LinAlgError:
        step = -np.linalg.lstsq(A, g, rcond=None)[0]
    new = x + step
    new[2] = float(geometry.wrap_angle(new[2]))
    return new, H, r


def icp(source: ArrayLike, reference: PointCloudReference | ArrayLike, initial: ArrayLike,
        prior_information: ArrayLike | None = None, config: IcpConfig | None = None
        ) -> MatchResult:
    """Point-to-line ICP of ``source`` points onto ``reference`` from ``initial``.

    With ``prior_information`` the initial pose is also a prior (an odometry guess) that
    the result may not stray from more than the scan justifies.

    >>> t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    >>> room = np.column_stack([3 * np.cos(t), 2 * np.sin(t)])   # an elliptic wall
    >>> true = np.array([0.1, -0.05, 0.03])
    >>> scan = geometry.transform_points(geometry.inverse(true), room)
    >>> icp(scan, room, [0, 0, 0]).pose.round(3).tolist()
    [0.1, -0.05, 0.03]
    """
    src = _check_points(source, "source")
    ref = reference if isinstance(reference, PointCloudReference) else \
        PointCloudReference(np.asarray(reference, dtype=np.float64),
                            config or IcpConfig())
    cfg = ref.config if config is None else config
    if config is not None and config != ref.config:
        ref = PointCloudReference(ref.points, config)
    x0 = geometry.check_pose(initial, "initial")
    omega = None if prior_information is None else \
        np.array(prior_information, dtype=np.float64)
    if omega is not None and (omega.shape != (3, 3) or not np.all(np.isfinite(omega))):
        raise ValueError(f"prior_information must be a finite 3 × 3 matrix, got {omega!r}")
    if len(ref.points) == 0 or len(src) < 3:
        return MatchResult(x0, _fallback_covariance(omega), False)
    b = ref.buckets()
    assert ref.normals is not None
    loop = _compiled_icp()
    held = np.zeros((3, 3)) if omega is None else omega
    x, it, step, kept = x0, 0, np.zeros(3, dtype=np.float64), 0
    while True:  # once, or once more after each exactly singular system
        x, H, g, kept, squares, converged, it, singular = loop(
            src, ref.points, ref.normals, b.origin, b.cell, b.width, b.height, b.start,
            b.order, x0, omega is not None, held, cfg.max_iterations, cfg.max_distance,
            cfg.trim, cfg.sigma, cfg.tolerance, x, it, step, kept)
        if not singular:
            break
        step = -np.asarray(np.linalg.lstsq(H, g, rcond=3 * np.finfo(np.float64).eps)[0],
                           dtype=np.float64)
    dof = max(kept - 3, 1)
    s2 = max(squares / dof, cfg.sigma**2)
    info = H * (cfg.sigma**2 / s2)
    if omega is not None:
        info = info + omega
    covariance = _inverse(info)
    return MatchResult(x, covariance, converged and kept >= 3, it, kept / len(src),
                       math.sqrt(squares / max(kept, 1)))


def _inverse(info: FloatArray) -> FloatArray:
    try:
        cov = np.linalg.inv(info)
        if np.all(np.isfinite(cov)) and np.all(np.linalg.eigvalsh(0.5 * (cov + cov.T)) > 0):
            return 0.5 * (cov + cov.T)
    except np.linalg.LinAlgError:
        pass
    return np.diag([1e6, 1e6, 1e3])  # unconstrained: nothing was learnt


def _fallback_covariance(omega: FloatArray | None) -> FloatArray:
    return _inverse(omega) if omega is not None else np.diag([1e6, 1e6, 1e3])


# ----------------------------------------------------------------------------- compiled ICP
# icp()'s loop as icp_iteration() steps it, compiled: the nearest reference point of each
# source point is searched among the reference's buckets (exactly the k-d tree's answer, the
# first found of equally near points aside) and the trimmed pairs' normal equations are summed
# point by point, so a result differs from icp_iteration()'s only by rounding.

def _nearest_python(qx: float, qy: float, points: FloatArray, origin: FloatArray, cell: float,
                    width: int, height: int, start: NDArray[np.int64],
                    order: NDArray[np.int64], bound: float) -> int:
    # pragma: no cover - compiled by numba
    """The index of the reference point nearest ``(qx, qy)`` closer than ``bound``, or -1:
    the cells in rings around the query's cell, nearest ring first, until no farther ring
    can hold a nearer point (ring ``k + 1`` lies at least ``k · cell`` away)."""
    gx, gy = (qx - origin[0]) / cell, (qy - origin[1]) / cell
    if not (abs(gx) < 2.0**52 and abs(gy) < 2.0**52):
        return -1                     # NaN, or too far for any cell (and for an integer)
    cx, cy = math.floor(gx), math.floor(gy)
    best, best_d2 = -1, bound * bound
    k = 0
    while True:
        for j in range(max(cy - k, 0), min(cy + k, height - 1) + 1):
            edge = j == cy - k or j == cy + k
            step = 1 if edge or k == 0 else 2 * k
            for i in range(cx - k, cx + k + 1, step):
                if i < 0 or i >= width:
                    continue
                c = j * width + i
                for s in range(start[c], start[c + 1]):
                    m = order[s]
                    dx, dy = points[m, 0] - qx, points[m, 1] - qy
                    d2 = dx * dx + dy * dy
                    if d2 < best_d2 or (d2 == best_d2 and 0 <= best and m < best):
                        best, best_d2 = m, d2
        reach = k * cell
        if (best >= 0 and best_d2 <= reach * reach) or reach >= bound:
            return best
        k += 1


def _wrap_python(a: float) -> float:
    # pragma: no cover - compiled by numba
    """:func:`kit.geometry.wrap_angle` of a float, in the same arithmetic."""
    w = (a + math.pi) % (2.0 * math.pi) - math.pi
    return w - 2.0 * math.pi if w >= math.pi else w


def _smallest_python(values: FloatArray, k: int) -> float:
    # pragma: no cover - compiled by numba
    """The ``k``-th smallest of ``values`` (from 0; ``np.sort(values)[k]``), found by
    partitioning ``values`` in place (numba compiles this far faster than its sort)."""
    lo, hi = 0, len(values) - 1
    while lo < hi:
        pivot = values[(lo + hi) // 2]
        i, j = lo, hi
        while i <= j:
            while values[i] < pivot:
                i += 1
            while values[j] > pivot:
                j -= 1
            if i <= j:
                values[i], values[j] = values[j], values[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    return values[k]


def _solve3_python(A: FloatArray, b: FloatArray) -> tuple[FloatArray, bool]:
    # pragma: no cover - compiled by numba
    """``A x = b`` for a 3 × 3 ``A`` by Gaussian elimination with partial pivoting, as
    LAPACK's ``gesv`` (to rounding): ``(x, True)``, or ``(b, False)`` if a pivot is exactly
    zero, where ``gesv`` reports a singular matrix."""
    M, y = A.copy(), b.copy()
    for c in range(3):
        p = c
        for r in range(c + 1, 3):
            if abs(M[r, c]) > abs(M[p, c]):
                p = r
        if M[p, c] == 0.0:
            return b, False
        if p != c:
            for k in range(3):
                M[c, k], M[p, k] = M[p, k], M[c, k]
            y[c], y[p] = y[p], y[c]
        for r in range(c + 1, 3):
            f = M[r, c] / M[c, c]
            for k in range(c + 1, 3):
                M[r, k] -= f * M[c, k]
            y[r] -= f * y[c]
    for c in range(2, -1, -1):
        total = y[c]
        for k in range(c + 1, 3):
            total -= M[c, k] * y[k]
        y[c] = total / M[c, c]
    return y, True


def _normal_equations_python(src: FloatArray, points: FloatArray, normals: FloatArray,
                             origin: FloatArray, cell: float, width: int, height: int,
                             start: NDArray[np.int64], order: NDArray[np.int64], x: FloatArray,
                             max_distance: float, trim: float, sigma: float
                             ) -> tuple[FloatArray, FloatArray, int, float]:
    # pragma: no cover - compiled by numba
    """:func:`_pairs` and the sums of :func:`icp_iteration` at pose ``x``: ``(H, Jᵀr/σ²,
    pairs kept, sum of their squared residuals)``."""
    c, s = math.cos(x[2]), math.sin(x[2])
    n = len(src)
    q = np.empty((n, 2))
    nearest = np.empty(n, dtype=np.int64)
    r = np.empty(n)
    found = 0
    for k in range(n):
        qx = src[k, 0] * c - src[k, 1] * s + x[0]
        qy = src[k, 0] * s + src[k, 1] * c + x[1]
        m = _nearest(qx, qy, points, origin, cell, width, height, start, order, max_distance)
        if m >= 0:
            q[found, 0], q[found, 1], nearest[found] = qx, qy, m
            r[found] = normals[m, 0] * (qx - points[m, 0]) + normals[m, 1] * (qy - points[m, 1])
            found += 1
    keep = max(3, math.ceil(trim * found))
    # the ``keep`` smallest |r| (argpartition's choice, ties at the threshold aside)
    threshold, spare = np.inf, found
    if keep < found:
        # a fresh array, which the select may reorder: the count below does not change
        size = np.abs(r[:found])
        threshold = _smallest(size, keep - 1)
        spare = keep - int(np.sum(size < threshold))
    H, g = np.zeros((3, 3)), np.zeros(3)
    kept, squares = 0, 0.0
    for k in range(found):
        a = abs(r[k])
        if a > threshold or (a == threshold and spare == 0):
            continue
        if a == threshold:
            spare -= 1
        m = nearest[k]
        j = (normals[m, 0], normals[m, 1],
             -normals[m, 0] * (q[k, 1] - x[1]) + normals[m, 1] * (q[k, 0] - x[0]))
        for u in range(3):
            g[u] += j[u] * r[k]
            for v in range(3):
                H[u, v] += j[u] * j[v]
        kept += 1
        squares += r[k] * r[k]
    w = 1.0 / sigma**2
    return w * H, w * g, kept, squares


def _icp_python(src: FloatArray, points: FloatArray, normals: FloatArray, origin: FloatArray,
                cell: float, width: int, height: int, start: NDArray[np.int64],
                order: NDArray[np.int64], x0: FloatArray, has_prior: bool, omega: FloatArray,
                max_iterations: int, max_distance: float, trim: float, sigma: float,
                tolerance: float, x: FloatArray, it: int, step: FloatArray, kept: int
                ) -> tuple[FloatArray, FloatArray, FloatArray, int, float, bool, int, bool]:
    # pragma: no cover - compiled by numba
    """:func:`icp`'s Gauss–Newton loop, held at ``x0`` with information ``omega`` when
    ``has_prior``: from ``x`` at iteration ``it`` (0: the start), whose ``step`` (found with
    ``kept`` pairs) is still to be taken when ``it > 0``.

    Returns ``(pose, H, g, pairs kept, sum of their squared residuals, converged,
    iterations, singular)``, ``H`` and the pairs evaluated at the pose. If an iteration's
    system is exactly singular the loop stops there instead, with ``singular`` true and
    the system in ``H`` and ``g``: the caller solves it by least squares (numpy's, which
    compiles slowly in numba) and resumes with that step."""
    converged = False
    while True:
        if it > 0:
            new = x + step
            new[2] = _wrap(new[2])
            moved = max(abs(new[0] - x[0]), abs(new[1] - x[1]), abs(_wrap(new[2] - x[2])))
            x = new
            if kept < 3:
                break
            if moved < tolerance:
                converged = True
                break
        if it == max_iterations:
            break
        it += 1
        H, g, kept, _ = _normal_equations(src, points, normals, origin, cell, width, height,
                                          start, order, x, max_distance, trim, sigma)
        A = H
        if has_prior:
            d = x - x0
            d[2] = _wrap(d[2])
            A = H + omega
            g = g + omega @ d
        step, solved = _solve3(A, g)
        if not solved:
            return x, A, g, kept, 0.0, False, it, True
        step = -step
    H, g, kept, squares = _normal_equations(src, points, normals, origin, cell, width, height,
                                            start, order, x, max_distance, trim, sigma)
    return x, H, g, kept, squares, converged, it, False


_nearest, _wrap, _normal_equations = _nearest_python, _wrap_python, _normal_equations_python
_smallest, _solve3 = _smallest_python, _solve3_python
_COMPILED: list = []


def _compiled_icp() -> Callable[..., tuple[FloatArray, FloatArray, FloatArray, int, float, bool,
                                            int, bool]]:
    """:func:`_icp_python` compiled once (``cache=True``: later sessions load it)."""
    global _nearest, _wrap, _normal_equations, _smallest, _solve3
    if not _COMPILED:
        import numba

        jit = numba.njit(cache=True, nogil=True)
        _nearest, _wrap = jit(_nearest_python), jit(_wrap_python)
        _smallest, _solve3 = jit(_smallest_python), jit(_solve3_python)
        _normal_equations = jit(_normal_equations_python)
        _COMPILED.append(jit(_icp_python))
    return _COMPILED[0]

"""Correlative, multi-resolution scan matching (Olson, "Real-time correlative scan matching",
ICRA 2009; the matcher of Karto and SLAM Toolbox).

The reference (another scan, or a local map of many) is rasterised into a likelihood field
``L = exp(−d² / 2σ²)``, ``d`` the distance from a cell's centre to the nearest reference
point's cell, and every pose of a search window (x, y, θ) around a guess is scored by the mean
of ``L`` at the moved source points — the *response*, 0…1 — optionally times a penalty for
straying from the guess (Karto's ``distance_variance_penalty``):

.. math:: s(Δx, Δy, Δθ) = \\frac{1}{M}\\sum_m L(R(θ) p_m + t)
          \\cdot \\left(1 - κ \\left(\\frac{Δx^2 + Δy^2}{w^2} + \\frac{Δθ^2}{a^2}\\right)\\right)

with ``w`` and ``a`` the linear and angular half-windows and ``κ`` the ``penalty``.

A coarse table holding, per cell, the maximum of ``L`` over the ``f × f`` fine offsets it
stands for bounds every fine score from above, so fine offsets are only scored inside the
coarse blocks that could still beat the best fine score found (branch and bound), and within
a block only in the sub-blocks a table of half its size says could: the answer is the
exhaustive search's. The covariance comes from the responses around the best pose, as Karto
computes it.

The search and the rasterisation run compiled (numba, ``cache=True``); ``method="numpy"``
runs the plain versions the tests hold them to.

Poses are ``T_reference_source``: the source points' frame in the reference frame.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry

__all__ = ["LikelihoodField", "MatchResult", "correlative_match", "likelihood_field"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
Method = Literal["numba", "numpy"]


@dataclass(frozen=True)
class MatchResult:
    """A matcher's answer: the pose ``T_reference_source`` and how sure it is."""

    pose: FloatArray
    covariance: FloatArray
    """3×3 over (x [m], y [m], θ [rad])."""
    converged: bool
    iterations: int = 0
    inlier_fraction: float = 0.0
    """ICP: share of source points paired with the reference at the end."""
    rmse: float = 0.0
    """ICP: root mean square point-to-line residual of the kept pairs [m]."""
    response: float = 0.0
    """Correlative: mean likelihood of the moved points at the best pose (0…1), without the
    penalty."""


def check_points(points: ArrayLike, name: str) -> FloatArray:
    """``points`` as an ``(M, 2)`` float array, or a ``ValueError`` naming ``name``."""
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"{name} must have shape (M, 2) [m]; got shape {p.shape}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"{name} contains NaN or infinite values")
    return p


@dataclass(frozen=True, eq=False)
class LikelihoodField:
    """``values[row, col]`` = likelihood at the centre of cell (col, row); cell (0, 0)'s corner
    is at ``origin`` (x, y) [m] in the reference frame."""

    values: FloatArray
    origin: FloatArray
    resolution: float
    _coarse: dict[int, FloatArray] = field(default_factory=dict, repr=False)

    def coarse(self, factor: int) -> FloatArray:
        """``C[r + f − 1, c + f − 1] = max(L[r : r + f, c : c + f])`` for every block that
        overlaps the field (``r, c ≥ −(f − 1)``): the best any fine offset of a block can
        score, so a coarse score bounds the fine ones from above."""
        table = self._coarse.get(factor)
        if table is None:
            table = _compiled()[3](self.values, int(factor))
            self._coarse[factor] = table
        return table


def likelihood_field(points: ArrayLike, resolution: float = 0.05, sigma: float = 0.05,
                     margin: float = 1.0, method: Method = "numba") -> LikelihoodField:
    """Rasterise reference points into ``L = exp(−d² / 2σ²)``, ``d`` the distance from a cell
    centre to the nearest reference point's cell, over their bounding box plus ``margin``.

    ``method="numba"`` smears each point's cell into its neighbours within ``4σ`` (where ``L``
    has fallen to ``e⁻⁸``; farther cells stay 0); ``"numpy"`` takes the exact distance
    transform.

    >>> f = likelihood_field([[0.0, 0.0]], resolution=0.1, sigma=0.1, margin=0.3)
    >>> f.values.shape, float(f.values.max())
    ((7, 7), 1.0)
    """
    p = check_points(points, "points")
    if len(p) == 0:
        raise ValueError("a likelihood field needs at least one reference point")
    if resolution <= 0 or sigma <= 0 or margin < 0:
        raise ValueError("resolution and sigma must be positive, margin non-negative")
    lo = p.min(axis=0) - margin
    shape = np.floor((p.max(axis=0) + margin - lo) / resolution + 1e-9).astype(int) + 1
    cells = np.floor((p - lo) / resolution).astype(np.int64)
    if method == "numba":
        values = np.zeros((shape[1], shape[0]))
        radius = math.ceil(4.0 * sigma / resolution)
        kernel = np.exp(-0.5 * (resolution * np.hypot(*np.mgrid[-radius:radius + 1,
                                                             -radius:radius + 1]) / sigma) ** 2)
        _, first = np.unique(cell_keys(cells), return_index=True)
        _compiled()[0](values, cells[first], kernel)
    elif method == "numpy":
        from scipy.ndimage import distance_transform_edt

        hit = np.ones((shape[1], shape[0]), dtype=bool)
        hit[cells[:, 1], cells[:, 0]] = False
        d = distance_transform_edt(hit) * resolution
        values = np.exp(-0.5 * (d / sigma) ** 2)
    else:
        raise ValueError(f"method is 'numba' or 'numpy'; got {method!r}")
    return LikelihoodField(values, lo, float(resolution))


def cell_keys(cells: IntArray) -> IntArray:
    """One integer per cell ``(i, j)`` of ``cells`` (shape (N, 2)), equal exactly where the
    cells are: what ``np.unique(cells, axis=0)`` sorts, without its row-by-row comparisons.

    >>> cell_keys(np.array([[2, 5], [0, 7], [2, 5]])).tolist()
    [6, 2, 6]
    """
    lo = cells.min(axis=0)
    return (cells[:, 0] - lo[0]) * (int(np.max(cells[:, 1]) - lo[1]) + 1) + (cells[:, 1] - lo[1])


# ----------------------------------------------------------------------------- the search
def _cells(src: FloatArray, ref: LikelihoodField, x0: FloatArray, angles: FloatArray
           ) -> tuple[IntArray, IntArray]:
    """Cells ``(ix, iy)``, each ``(K, M)``, of the source points rotated by each of the
    ``K`` angles and moved to ``x0``'s position."""
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    qx = x0[0] + c * src[:, 0] - s * src[:, 1]
    qy = x0[1] + s * src[:, 0] + c * src[:, 1]
    ix = np.floor((qx - ref.origin[0]) / ref.resolution).astype(np.int64)
    iy = np.floor((qy - ref.origin[1]) / ref.resolution).astype(np.int64)
    return ix, iy


def _scores_python(values: FloatArray, ix: IntArray, iy: IntArray, k: IntArray, ox: IntArray,
                   oy: IntArray) -> FloatArray:  # pragma: no cover - compiled by numba
    """Mean of ``values`` at the cells ``(ix[k_n] + ox_n, iy[k_n] + oy_n)`` for each
    candidate ``n``; cells off the table score 0."""
    h, w = values.shape
    m = ix.shape[1]
    out = np.empty(len(k))
    for n in range(len(k)):
        s = 0.0
        for j in range(m):
            cx, cy = ix[k[n], j] + ox[n], iy[k[n], j] + oy[n]
            if 0 <= cx < w and 0 <= cy < h:
                s += values[cy, cx]
        out[n] = s / m
    return out


def _block_bounds_python(coarse: FloatArray, ix: IntArray, iy: IntArray, half: int,
                         factor: int, angle_penalty: FloatArray, linear_penalty: float
                         ) -> FloatArray:  # pragma: no cover - compiled by numba
    """Every block's bound, ``bound[(k nb + a) nb + b]`` for angle ``k`` and the block at x
    and y offsets ``starts[a]``, ``starts[b]`` (``starts`` from ``−half`` in steps of
    ``factor``, ``nb`` of them): the mean of ``coarse`` at the moved points times the penalty
    at the block's offset nearest the guess. Each sum runs over the points in their order
    (``j`` ascending), point by point for all blocks at once."""
    k_count, m = ix.shape
    f = factor
    starts = np.arange(-half, half + 1, f)
    nb = len(starts)
    ch, cw = coarse.shape
    # the coarse table's columns by their remainder mod f, columns[r, row, q] =
    # coarse[row, r + q f]: a point's blocks along x are then read one after another
    nq = (cw + f - 1) // f
    columns = np.zeros((f, ch, nq))
    for r in range(f):
        for row in range(ch):
            q = 0
            for col in range(r, cw, f):
                columns[r, row, q] = coarse[row, col]
                q += 1
    sums = np.zeros((k_count, nb, nb))           # [k, y block, x block]
    for k in range(k_count):
        for j in range(m):
            base = ix[k, j] + f - 1 - half        # coarse column of x block a: base + a f
            cy0 = iy[k, j] + f - 1
            a_lo = 0 if base >= 0 else (f - 1 - base) // f
            a_hi = min(nb, (cw - 1 - base) // f + 1) if base <= cw - 1 else 0
            na = a_hi - a_lo
            if na <= 0:
                continue
            col0 = base + a_lo * f
            r = col0 % f
            q0 = col0 // f
            a_lo, q0 = max(a_lo, 0), max(q0, 0)   # (both ≥ 0: lets the compiler vectorise)
            for b in range(nb):
                cy = cy0 + starts[b]
                if cy < 0 or cy >= ch:
                    continue
                for t in range(na):
                    sums[k, b, a_lo + t] += columns[r, cy, q0 + t]
    bound = np.empty(k_count * nb * nb)
    for k in range(k_count):
        for a in range(nb):
            for b in range(nb):
                ox, oy = starts[a], starts[b]
                nx = 0 if ox <= 0 < ox + f else min(abs(ox), abs(ox + f - 1))
                ny = 0 if oy <= 0 < oy + f else min(abs(oy), abs(oy + f - 1))
                pen = angle_penalty[k] - linear_penalty * (nx * nx + ny * ny)
                bound[(k * nb + a) * nb + b] = sums[k, b, a] / m * max(pen, 0.0)
    return bound


def _live_sub_blocks_python(sub: FloatArray, ix: IntArray, iy: IntArray, k: int, ox: int,
                            oy: int, x_end: int, y_end: int, g: int, angle_penalty: FloatArray,
                            linear_penalty: float, best: float, live: NDArray[np.bool_]
                            ) -> bool:  # pragma: no cover - compiled by numba
    """Which of the block's 2 × 2 sub-blocks (``live[v, u]``: the one at ``(ox + u g,
    oy + v g)``, cut short at ``x_end``, ``y_end``) have a bound on ``sub`` that beats
    ``best``; True if any does. The four sums run over the points in their order."""
    m = ix.shape[1]
    sh, sw = sub.shape
    s00 = s01 = s10 = s11 = 0.0             # the sub-blocks' bound sums, s[v][u]
    for j in range(m):
        cx = ix[k, j] + g - 1 + ox
        cy = iy[k, j] + g - 1 + oy
        if 0 <= cx and cx + g < sw and 0 <= cy and cy + g < sh:
            s00 += sub[cy, cx]
            s01 += sub[cy, cx + g]
            s10 += sub[cy + g, cx]
            s11 += sub[cy + g, cx + g]
        else:
            in_y0 = 0 <= cy < sh
            in_y1 = 0 <= cy + g < sh
            in_x0 = 0 <= cx < sw
            in_x1 = 0 <= cx + g < sw
            if in_y0 and in_x0:
                s00 += sub[cy, cx]
            if in_y0 and in_x1:
                s01 += sub[cy, cx + g]
            if in_y1 and in_x0:
                s10 += sub[cy + g, cx]
            if in_y1 and in_x1:
                s11 += sub[cy + g, cx + g]
    any_live = False
    for v in range(2):
        for u in range(2):
            sx, sy = ox + u * g, oy + v * g
            if sx >= x_end or sy >= y_end:
                live[v, u] = False
                continue
            ssum = (s00 if u == 0 else s01) if v == 0 else (s10 if u == 0 else s11)
            nx = 0 if sx <= 0 < sx + g else min(abs(sx), abs(sx + g - 1))
            ny = 0 if sy <= 0 < sy + g else min(abs(sy), abs(sy + g - 1))
            pen = angle_penalty[k] - linear_penalty * (nx * nx + ny * ny)
            live[v, u] = pen > 0.0 and ssum / m * pen > best
            any_live = any_live or live[v, u]
    return any_live


def _branch_and_bound_python(values: FloatArray, coarse: FloatArray, sub: FloatArray,
                             ix: IntArray, iy: IntArray, half: int, factor: int,
                             sub_factor: int, angle_penalty: FloatArray, linear_penalty: float
                             ) -> tuple[int, int, int, float]:
    # pragma: no cover - compiled by numba
    """The best ``(angle index, dx, dy [cells], score)`` over angles and offsets in
    ``[−half, half]²``: blocks of ``factor²`` offsets scored on ``coarse`` (an upper bound,
    :func:`_block_bounds_python`), best bound first; a block's fine offsets are scored only
    while its bound beats the best score found, in the order a block lists them, and the
    first that beats the best score found so far becomes the best.

    Inside a block, its 2 × 2 sub-blocks of ``sub_factor²`` offsets (``sub_factor`` =
    ⌈factor / 2⌉; those past the window's edge are cut short) are first bounded the same way
    on ``sub``, the coarse table of ``sub_factor``, and only those whose bound beats the best
    score at the block's start are scored (:func:`_live_sub_blocks_python`). A sum of larger
    terms in the same order is never smaller in floating point, nor is it after the same
    division and a larger penalty, so an offset skipped could not have beaten the best: the
    answer is the one scoring every offset of the block gives, to the bit (ties included)."""
    k_count, m = ix.shape
    f, g = factor, sub_factor
    starts = np.arange(-half, half + 1, f)
    nb = len(starts)
    bound = _block_bounds(coarse, ix, iy, half, f, angle_penalty, linear_penalty)
    order = np.argsort(-bound)
    best_k, best_x, best_y, best = k_count // 2, 0, 0, -1.0
    h, w = values.shape
    fine = np.zeros((f, f))                     # [dy − oy, dx − ox]
    live = np.zeros((2, 2), dtype=np.bool_)     # [v, u]: sub-block (oy + v g, ox + u g)
    for n in order:
        if bound[n] <= best:
            break
        k = n // (nb * nb)
        ox, oy = starts[(n // nb) % nb], starts[n % nb]
        x_end, y_end = min(ox + f, half + 1), min(oy + f, half + 1)
        if not _live_sub_blocks(sub, ix, iy, k, ox, oy, x_end, y_end, g, angle_penalty,
                                linear_penalty, best, live):
            continue
        for v in range(2):
            for u in range(2):
                if not live[v, u]:
                    continue
                sx, sy = ox + u * g, oy + v * g
                sx_end, sy_end = min(sx + g, x_end), min(sy + g, y_end)
                for yy in range(sy - oy, sy_end - oy):
                    for xx in range(sx - ox, sx_end - ox):
                        fine[yy, xx] = 0.0
                for j in range(m):
                    px, py = ix[k, j], iy[k, j]
                    for dy in range(sy, sy_end):
                        cy = py + dy
                        if cy < 0 or cy >= h:
                            continue
                        for dx in range(sx, sx_end):
                            cx = px + dx
                            if 0 <= cx < w:
                                fine[dy - oy, dx - ox] += values[cy, cx]
        for dx in range(ox, x_end):
            u = (dx - ox) // g
            for dy in range(oy, y_end):
                if not live[(dy - oy) // g, u]:
                    continue
                pen = angle_penalty[k] - linear_penalty * (dx * dx + dy * dy)
                if pen <= 0.0:
                    continue
                s = fine[dy - oy, dx - ox] / m * pen
                if s > best:
                    best_k, best_x, best_y, best = k, dx, dy, s
    return best_k, best_x, best_y, best


# what the search calls: the plain functions until _compiled() puts the compiled ones here,
# before it compiles the search (numba reads them from the module when it compiles it)
_block_bounds: Callable[..., Any] = _block_bounds_python
_live_sub_blocks: Callable[..., Any] = _live_sub_blocks_python


def _coarse_table_python(values: FloatArray, factor: int
                         ) -> FloatArray:  # pragma: no cover - compiled by numba
    """:meth:`LikelihoodField.coarse`'s table: ``C[R, C] = max(L[R − f + 1 : R + 1,
    C − f + 1 : C + 1])`` (0 outside ``L``), shape ``(h + 2f − 2, w + 2f − 2)``; the
    maximum along rows first, then along columns (a maximum is exact in any order)."""
    h, w = values.shape
    f = factor
    along = np.zeros((h, w + 2 * (f - 1)))
    for r in range(h):
        for shift in range(f):
            for c in range(w):
                if values[r, c] > along[r, c + shift]:
                    along[r, c + shift] = values[r, c]
    out = np.zeros((h + 2 * (f - 1), w + 2 * (f - 1)))
    for r in range(h):
        for shift in range(f):
            for c in range(w + 2 * (f - 1)):
                if along[r, c] > out[r + shift, c]:
                    out[r + shift, c] = along[r, c]
    return out


def _smear_python(values: FloatArray, cells: IntArray, kernel: FloatArray
                  ) -> None:  # pragma: no cover - compiled by numba
    """``values[r, c] = max(values[r, c], kernel[..])`` around each cell ``(col, row)``."""
    h, w = values.shape
    radius = kernel.shape[0] // 2
    for n in range(cells.shape[0]):
        c0, r0 = cells[n, 0], cells[n, 1]
        for i in range(-radius, radius + 1):
            r = r0 + i
            if r < 0 or r >= h:
                continue
            for j in range(-radius, radius + 1):
                c = c0 + j
                if 0 <= c < w and kernel[i + radius, j + radius] > values[r, c]:
                    values[r, c] = kernel[i + radius, j + radius]


_COMPILED: tuple = ()


def _compiled() -> tuple:
    """The loops compiled once (``cache=True``: later sessions load them from disk)."""
    global _COMPILED, _block_bounds, _live_sub_blocks
    if not _COMPILED:
        import numba

        jit = numba.njit(cache=True, nogil=True)
        _block_bounds, _live_sub_blocks = jit(_block_bounds_python), jit(_live_sub_blocks_python)
        _COMPILED = (jit(_smear_python), jit(_scores_python), jit(_branch_and_bound_python),
                     jit(_coarse_table_python))
    return _COMPILED


def _search_numpy(values: FloatArray, coarse: FloatArray, ix: IntArray, iy: IntArray,
                  half: int, factor: int, angle_penalty: FloatArray, linear_penalty: float
                  ) -> tuple[int, int, int, float]:
    """:func:`_branch_and_bound_python`'s answer by an exhaustive numpy search."""
    off = np.arange(-half, half + 1)
    ox, oy = (g.ravel() for g in np.meshgrid(off, off, indexing="ij"))
    best = (len(ix) // 2, 0, 0, -1.0)
    h, w = values.shape
    for k in range(len(ix)):
        cx, cy = ix[k][:, None] + ox, iy[k][:, None] + oy
        inside = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
        s = np.where(inside, values[np.clip(cy, 0, h - 1), np.clip(cx, 0, w - 1)], 0.0)
        pen = angle_penalty[k] - linear_penalty * (ox * ox + oy * oy)
        score = s.mean(axis=0) * pen
        score[pen <= 0] = -np.inf
        j = int(np.argmax(score))
        if score[j] > best[3]:
            best = (k, int(ox[j]), int(oy[j]), float(score[j]))
    return best


def correlative_match(source: ArrayLike, reference: LikelihoodField, initial: ArrayLike,
                      linear_window: float = 0.5, angular_window: float = 0.35,
                      angular_step: float | None = None, coarse_factor: int = 4,
                      penalty: float = 0.0, method: Method = "numba", subcell: bool = False
                      ) -> MatchResult:
    """The pose within ``initial ± (linear_window, linear_window, angular_window)`` [m, m,
    rad] where the source points best fit the likelihood field, to one cell and one angular
    step, with Karto's covariance of the responses around it.

    Parameters
    ----------
    source : (M, 2)
        Points in the source frame [m].
    reference
        The reference's :func:`likelihood_field`.
    initial : (3,)
        The guess ``T_reference_source``, centre of the search window.
    angular_step
        Defaults to the angle that moves the farthest source point by one cell.
    coarse_factor
        Fine cells per coarse cell along each axis (branch and bound).
    penalty
        ``κ`` above, in [0, 1): how much a pose at the window's edge is scored down against
        the guess (0: not at all). It decides between poses a corridor cannot tell apart.
    method
        ``"numba"`` (branch and bound, compiled) or ``"numpy"`` (exhaustive; slow).
    subcell
        Refine the best pose between the grid's cells and angular steps: along each of
        x, y and θ the parabola through the responses one step either side of the best has
        its vertex at ``best + h (s₋ − s₊) / (2 (s₋ − 2 s₀ + s₊))`` (kept within half a
        step).

    Returns
    -------
    MatchResult
        ``response`` is the mean likelihood at the best pose (without the penalty).
    """
    src = check_points(source, "source")
    x0 = geometry.check_pose(initial, "initial")
    if len(src) == 0:
        raise ValueError("correlative_match needs source points")
    if not 0.0 <= penalty < 1.0:
        raise ValueError(f"penalty is a fraction in [0, 1); got {penalty}")
    if method not in ("numba", "numpy"):
        raise ValueError(f"method is 'numba' or 'numpy'; got {method!r}")
    res = reference.resolution
    reach = max(float(np.hypot(src[:, 0], src[:, 1]).max()), res)
    step = angular_step if angular_step is not None else min(res / reach, 0.05)
    n_ang = math.floor(angular_window / step + 1e-9)
    angles = x0[2] + step * np.arange(-n_ang, n_ang + 1)
    f = max(1, int(coarse_factor))
    half = max(1, math.floor(linear_window / res + 1e-9))
    ix, iy = _cells(src, reference, x0, angles)
    turn = step * np.arange(-n_ang, n_ang + 1)
    angle_penalty = np.asarray(1.0 - penalty * (turn / max(angular_window, 1e-12)) ** 2,
                               dtype=np.float64)
    linear_penalty = penalty / half**2
    if method == "numba":
        g = (f + 1) // 2
        best = _compiled()[2](reference.values, reference.coarse(f), reference.coarse(g), ix,
                              iy, half, f, g, angle_penalty, linear_penalty)
    else:
        best = _search_numpy(reference.values, reference.coarse(f), ix, iy, half, f,
                             angle_penalty, linear_penalty)
    k, dx, dy = int(best[0]), int(best[1]), int(best[2])
    pose = np.array([x0[0] + dx * res, x0[1] + dy * res, angles[k]])
    response = float(_score_at(reference.values, ix, iy, [k], [dx], [dy], method)[0])
    cov = _response_covariance(reference, ix, iy, angles, (k, dx, dy, response), method)
    if subcell:
        pose = pose + _vertex(src, reference, pose, res, step, method)
    return MatchResult(pose, cov, True, response=response)


def _vertex(src: FloatArray, ref: LikelihoodField, pose: FloatArray, res: float, step: float,
            method: Method) -> FloatArray:
    """The offset from ``pose`` to the vertex of the parabola through the responses one
    cell (x, y) or one angular step (θ) either side, per axis, within half a step."""
    out = np.zeros(3)
    for axis, h in ((0, res), (1, res), (2, step)):
        scores = []
        for sign in (-1.0, 0.0, 1.0):
            p = pose.copy()
            p[axis] += sign * h
            ix, iy = _cells(src, ref, p, np.array([p[2]]))
            scores.append(float(_score_at(ref.values, ix, iy, [0], [0], [0], method)[0]))
        minus, centre, plus = scores
        curvature = minus - 2.0 * centre + plus
        if curvature < 0.0:
            out[axis] = float(np.clip(0.5 * h * (minus - plus) / curvature, -0.5 * h, 0.5 * h))
    return out


def _score_at(values: FloatArray, ix: IntArray, iy: IntArray, k: ArrayLike, ox: ArrayLike,
              oy: ArrayLike, method: Method) -> FloatArray:
    kk, xx, yy = (np.asarray(v, dtype=np.int64) for v in (k, ox, oy))
    if method == "numba":
        return np.asarray(_compiled()[1](values, ix, iy, kk, xx, yy))
    h, w = values.shape
    cx, cy = ix[kk] + xx[:, None], iy[kk] + yy[:, None]
    inside = (cx >= 0) & (cx < w) & (cy >= 0) & (cy < h)
    return np.asarray(np.where(inside, values[np.clip(cy, 0, h - 1), np.clip(cx, 0, w - 1)],
                               0.0).mean(axis=1), dtype=np.float64)


def _response_covariance(ref: LikelihoodField, ix: IntArray, iy: IntArray, angles: FloatArray,
                         best: tuple[int, int, int, float], method: Method, reach: int = 3
                         ) -> FloatArray:
    """Karto's estimate: the response-weighted spread of the poses within ``reach`` cells and
    angular steps of the best whose response is within 10 % of it, floored at a quarter cell
    and a quarter step."""
    res = ref.resolution
    step = float(angles[1] - angles[0]) if len(angles) > 1 else 0.01
    off = np.arange(-reach, reach + 1)
    ks = np.arange(max(0, best[0] - reach), min(len(angles), best[0] + reach + 1))
    kk, ox, oy = (g.ravel() for g in np.meshgrid(ks, off + best[1], off + best[2],
                                                 indexing="ij"))
    s = _score_at(ref.values, ix, iy, kk, ox, oy, method)
    table = np.column_stack([(ox - best[1]) * res, (oy - best[2]) * res,
                             (kk - best[0]) * step])
    response = best[3]
    near = s >= response - 0.1 * max(response, 1e-9)
    floor = np.diag([(0.25 * res) ** 2, (0.25 * res) ** 2, (0.25 * step) ** 2])
    if not near.any() or s[near].sum() <= 0:
        return floor
    w = s[near] / s[near].sum()
    d = table[near]
    mean = w @ d
    cov = (d * w[:, None]).T @ d - np.outer(mean, mean)
    return np.asarray(0.5 * (cov + cov.T) + floor, dtype=np.float64)

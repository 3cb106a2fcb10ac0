"""A 2-D pose graph: SE(2) nodes, relative-pose edges with information matrices, and their
least-squares solution by sparse Gauss–Newton or Levenberg–Marquardt.

Conventions (g2o's ``EDGE_SE2``, which every file format here follows):

* Node ``k`` is the pose ``x_k = (x, y, θ)`` of the robot in the ``map`` frame.
* An edge ``(i, j, z, Ω)`` says: node ``j`` seen from node ``i`` is ``z = x_i⁻¹ ⊕ x_j``, with
  information (inverse covariance) ``Ω`` over ``(x, y, θ)`` of that relative pose.
* Its error is ``e = t2v(Z⁻¹ · X_i⁻¹ · X_j)``: written out with ``R(θ)`` the rotation,
  ``t`` the translations,

  .. math:: e_{xy} = R(θ_z)^T \\left(R(θ_i)^T (t_j - t_i) - t_z\\right), \\quad
            e_θ = \\mathrm{wrap}(θ_j - θ_i - θ_z)

  and the objective is ``χ² = Σ eᵀ Ω e`` (no ½, as g2o prints it), or ``Σ ρ(eᵀ Ω e)`` with a
  robust kernel ``ρ``.
* Updates are additive, ``x ← x + Δx`` with the angle wrapped (g2o's ``VertexSE2``). gtsam's
  ``BetweenFactor<Pose2>`` measures the error with the SE(2) logarithm instead of ``t2v``;
  both have the same minimiser only when every edge is met exactly, so compare optima in one
  metric (:func:`chi2` evaluates this one for any poses).
* The first node is held fixed (the gauge): the other ``N − 1`` poses are solved for.

The normal equations ``H Δx = −g`` are assembled for all edges at once (numpy) and solved by
a sparse Cholesky factorisation. The sparsity pattern of ``H`` depends only on which nodes the
edges join, so its fill-reducing ordering and symbolic analysis are computed once per graph
structure and reused in every iteration (QDLDL, ``qdldl.Solver.update``).
"""

from __future__ import annotations

import gzip
import itertools
import math
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry

__all__ = [
    "KERNELS",
    "OptimizationResult",
    "PoseGraph",
    "PoseGraphError",
    "chi2",
    "edge_error",
    "edge_errors",
    "edge_jacobians",
    "gauss_newton_step",
    "read_g2o",
    "read_toro",
    "robust_weight",
    "write_g2o",
    "write_toro",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

KERNELS = ("none", "huber", "cauchy")
"""Robust kernels: ``none`` (ρ(s) = s), ``huber`` and ``cauchy`` (g2o's definitions)."""


class PoseGraphError(ValueError):
    """A graph that cannot be optimised or a file that cannot be read; names the edge or line."""


# ----------------------------------------------------------------------------- one edge
def edge_error(x_i: ArrayLike, x_j: ArrayLike, z: ArrayLike) -> FloatArray:
    """The error ``e = t2v(Z⁻¹ X_i⁻¹ X_j)`` of one edge, shape ``(3,)`` (metres, radians).

    Zero when node ``j`` seen from node ``i`` is exactly the measurement ``z``.

    >>> edge_error([0, 0, 0], [1, 0, np.pi / 2], [1, 0, np.pi / 2]).round(12).tolist()
    [0.0, 0.0, 0.0]
    >>> edge_error([0, 0, np.pi / 2], [0, 1, np.pi / 2], [0.9, 0, 0]).round(12).tolist()
    [0.1, 0.0, 0.0]
    """
    return geometry.relative(z, geometry.relative(x_i, x_j))


def edge_jacobians(x_i: ArrayLike, x_j: ArrayLike, z: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """Jacobians ``A = ∂e/∂x_i`` and ``B = ∂e/∂x_j`` of :func:`edge_error`, each ``(3, 3)``.

    With ``R = R(θ_i + θ_z)`` and ``(a, b) = R(θ_i)ᵀ (t_j − t_i)``:

    .. math:: A = \\begin{bmatrix} -R^T & R(θ_z)^T (b, -a)^T \\\\ 0 & -1 \\end{bmatrix},\\quad
              B = \\begin{bmatrix} R^T & 0 \\\\ 0 & 1 \\end{bmatrix}
    """
    xi, xj, zz = (geometry.check_pose(v) for v in (x_i, x_j, z))
    ci, si = math.cos(xi[2]), math.sin(xi[2])
    dx, dy = xj[0] - xi[0], xj[1] - xi[1]
    a, b = ci * dx + si * dy, -si * dx + ci * dy
    cz, sz = math.cos(zz[2]), math.sin(zz[2])
    c, s = math.cos(xi[2] + zz[2]), math.sin(xi[2] + zz[2])
    rot_t = np.array([[c, s], [-s, c]])
    A = np.zeros((3, 3))
    A[:2, :2] = -rot_t
    A[:2, 2] = [cz * b - sz * a, -sz * b - cz * a]
    A[2, 2] = -1.0
    B = np.zeros((3, 3))
    B[:2, :2] = rot_t
    B[2, 2] = 1.0
    return A, B


def robust_weight(s: ArrayLike, kernel: str = "none", delta: float = 1.0
                  ) -> tuple[FloatArray, FloatArray]:
    """``(ρ(s), ρ'(s))`` of a robust kernel at squared errors ``s = eᵀ Ω e``.

    Huber: ``ρ = s`` for ``s ≤ δ²``, else ``2δ√s − δ²``. Cauchy: ``ρ = δ² log(1 + s/δ²)``.
    ``ρ'`` is the weight iteratively reweighted least squares gives each edge's ``Ω``.

    >>> [float(v) for v in robust_weight(9.0, "huber", 1.0)]
    [5.0, 0.3333333333333333]
    """
    s = np.asarray(s, dtype=np.float64)
    if kernel == "none":
        return s.copy(), np.ones_like(s)
    if not delta > 0:
        raise ValueError(f"a robust kernel's delta must be positive; got {delta}")
    if kernel not in KERNELS:
        raise ValueError(f"kernel must be one of {KERNELS}; got {kernel!r}")
    return _kernel_rows(s, kernel, np.full_like(s, float(delta)))


# ----------------------------------------------------------------------------- all edges
def edge_errors(poses: FloatArray, i: IntArray, j: IntArray, z: FloatArray) -> FloatArray:
    """:func:`edge_error` of every edge at once, shape ``(E, 3)``."""
    xi, xj = poses[i], poses[j]
    ci, si = np.cos(xi[:, 2]), np.sin(xi[:, 2])
    dx, dy = xj[:, 0] - xi[:, 0], xj[:, 1] - xi[:, 1]
    a = ci * dx + si * dy - z[:, 0]
    b = -si * dx + ci * dy - z[:, 1]
    cz, sz = np.cos(z[:, 2]), np.sin(z[:, 2])
    return np.column_stack([cz * a + sz * b, -sz * a + cz * b,
                            geometry.wrap_angle(xj[:, 2] - xi[:, 2] - z[:, 2])])


def _errors_and_jacobians(poses: FloatArray, i: IntArray, j: IntArray, z: FloatArray
                          ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Errors ``(E, 3)`` and Jacobians ``A, B`` ``(E, 3, 3)`` of every edge."""
    xi, xj = poses[i], poses[j]
    ci, si = np.cos(xi[:, 2]), np.sin(xi[:, 2])
    dx, dy = xj[:, 0] - xi[:, 0], xj[:, 1] - xi[:, 1]
    a = ci * dx + si * dy
    b = -si * dx + ci * dy
    cz, sz = np.cos(z[:, 2]), np.sin(z[:, 2])
    e = np.column_stack([cz * (a - z[:, 0]) + sz * (b - z[:, 1]),
                         -sz * (a - z[:, 0]) + cz * (b - z[:, 1]),
                         geometry.wrap_angle(xj[:, 2] - xi[:, 2] - z[:, 2])])
    c, s = np.cos(xi[:, 2] + z[:, 2]), np.sin(xi[:, 2] + z[:, 2])
    n = len(i)
    A = np.zeros((n, 3, 3))
    B = np.zeros((n, 3, 3))
    B[:, 0, 0] = B[:, 1, 1] = c
    B[:, 0, 1] = s
    B[:, 1, 0] = -s
    B[:, 2, 2] = 1.0
    A[:, :2, :2] = -B[:, :2, :2]
    A[:, 0, 2] = cz * b - sz * a
    A[:, 1, 2] = -sz * b - cz * a
    A[:, 2, 2] = -1.0
    return e, A, B


def chi2(poses: ArrayLike, i: ArrayLike, j: ArrayLike, z: ArrayLike, information: ArrayLike
         ) -> float:
    """``Σ eᵀ Ω e`` over the edges for ``poses`` ``(N, 3)`` (g2o's χ², without kernels)."""
    e = edge_errors(np.asarray(poses, float), np.asarray(i), np.asarray(j), np.asarray(z, float))
    return float(np.einsum("ei,eij,ej->", e, np.asarray(information, float), e))


# ----------------------------------------------------------------------------- the solver
_PATTERNS = itertools.count()  # a new number for every sparsity pattern built


class _Cholesky:
    """A sparse symmetric positive-definite solver whose ordering and symbolic factorisation
    are reused while the sparsity pattern stays the same (QDLDL; scipy's ``spsolve`` if the
    ``qdldl`` package is missing)."""

    def __init__(self) -> None:
        self._solver: Any = None
        self._pattern: tuple[int, int] | None = None

    def solve(self, H: Any, rhs: FloatArray, pattern: tuple[int, int]) -> FloatArray:
        try:
            import qdldl
        except ImportError:  # pragma: no cover - qdldl is a dependency
            from scipy.sparse.linalg import spsolve

            return np.asarray(spsolve(H.tocsc(), rhs), dtype=np.float64)
        try:
            if self._solver is None or self._pattern != pattern:
                self._solver = qdldl.Solver(H)
                self._pattern = pattern
            else:
                self._solver.update(H)
        except (ValueError, RuntimeError) as exc:  # QDLDL: a zero pivot
            raise PoseGraphError(f"the normal equations are singular ({exc}): is every node "
                                 f"connected to the fixed one?") from None
        return np.asarray(self._solver.solve(rhs), dtype=np.float64)


@dataclass
class _Structure:
    """Where each edge's 3×3 blocks go in the upper triangle of the reduced ``H`` (CSC)."""

    n_vars: int
    var: IntArray          # node -> first variable index, −1 for fixed nodes
    inverse: IntArray      # every block entry -> its slot among the unique entries
    keep: NDArray[np.bool_]
    indptr: IntArray
    indices: IntArray
    key: tuple[int, int]


def _structure(n_nodes: int, fixed: NDArray[np.bool_], i: IntArray, j: IntArray) -> _Structure:
    var = np.full(n_nodes, -1, dtype=np.int64)
    free = np.flatnonzero(~fixed)
    var[free] = 3 * np.arange(len(free))
    n_vars = 3 * len(free)
    r3 = np.arange(3)
    rows, cols = [], []
    for p, q in ((i, i), (i, j), (j, i), (j, j)):
        rows.append((var[p][:, None, None] + r3[None, :, None]).repeat(3, axis=2))
        cols.append((var[q][:, None, None] + r3[None, None, :]).repeat(3, axis=1))
    row, col = np.stack(rows, 1).ravel(), np.stack(cols, 1).ravel()
    fixed_entry = (np.repeat(var[np.stack([i, i, j, j], 1)], 9, axis=1) < 0).ravel() | \
        (np.repeat(var[np.stack([i, j, i, j], 1)], 9, axis=1) < 0).ravel()
    keep = ~fixed_entry & (row <= col)
    # column-major keys give CSC order of the upper triangle
    keys = col[keep] * max(n_vars, 1) + row[keep]
    unique, inverse = np.unique(keys, return_inverse=True)
    ucol, urow = np.divmod(unique, max(n_vars, 1))
    indptr = np.zeros(n_vars + 1, dtype=np.int64)
    np.add.at(indptr, ucol + 1, 1)
    return _Structure(n_vars, var, inverse.astype(np.int64), keep, np.cumsum(indptr), urow,
                      (next(_PATTERNS), len(i)))


@dataclass(frozen=True)
class OptimizationResult:
    """What :meth:`PoseGraph.optimize` did."""

    iterations: int
    initial_cost: float
    cost: float
    """Final objective ``Σ ρ(eᵀΩe)`` (the χ² when no edge has a kernel)."""
    converged: bool
    history: tuple[float, ...] = ()


# ----------------------------------------------------------------------------- the graph
@dataclass
class PoseGraph:
    """Nodes (poses) and edges (relative-pose measurements with information matrices).

    Build one with :meth:`add_node` / :meth:`add_edge`, read one with :func:`read_g2o` or
    :func:`read_toro`, and solve it with :meth:`optimize`.

    >>> g = PoseGraph()
    >>> for pose in ([0, 0, 0], [1.1, 0, 0], [2.1, 0.1, 0]):
    ...     _ = g.add_node(pose)
    >>> g.add_edge(0, 1, [1, 0, 0], np.eye(3))
    >>> g.add_edge(1, 2, [1, 0, 0], np.eye(3))
    >>> g.optimize().converged, g.poses.round(6).tolist()
    (True, [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    """

    ids: list[int] = field(default_factory=list)
    """The file's id of each node (``ids[k]`` for node index ``k``)."""
    fixed: set[int] = field(default_factory=lambda: {0})
    """Node indices held fixed while optimising (the gauge)."""
    _poses: list[FloatArray] = field(default_factory=list)
    _edges: list[tuple[IntArray, IntArray, FloatArray, FloatArray, IntArray, FloatArray]] = \
        field(default_factory=list)
    _cache: dict[str, Any] = field(default_factory=dict)

    # ------------------------------------------------------------------ building
    def add_node(self, pose: ArrayLike, node_id: int | None = None) -> int:
        """Add a node at ``pose`` ``(x, y, θ)``; returns its index."""
        p = geometry.check_pose(pose, "pose")
        if p.shape != (3,):
            raise ValueError(f"add_node takes one pose of shape (3,); got {p.shape}")
        index = len(self._poses)
        self._poses.append(p.copy())
        self.ids.append(index if node_id is None else int(node_id))
        stacked = self._cache.pop("poses", None)
        if stacked is not None and len(stacked) == index:  # one row more, not all restacked
            self._cache["poses"] = np.vstack([stacked, p[None]])
        return index

    def add_edge(self, i: int, j: int, measurement: ArrayLike, information: ArrayLike,
                 kernel: str = "none", delta: float = 1.0) -> None:
        """Add the edge ``x_i⁻¹ ⊕ x_j = measurement`` with a 3×3 information matrix ``Ω``
        (the inverse of the measurement's covariance), optionally under a robust kernel.

        Raises
        ------
        PoseGraphError
            Unknown nodes, a NaN, or an information matrix that is not symmetric positive
            definite.
        """
        self.add_edges([i], [j], np.reshape(np.asarray(measurement, dtype=np.float64), (1, -1)),
                       np.asarray(information, dtype=np.float64)[None], kernel, delta)

    def add_edges(self, i: ArrayLike, j: ArrayLike, measurements: ArrayLike,
                  information: ArrayLike, kernel: str = "none", delta: float = 1.0,
                  where: Sequence[str] | None = None) -> None:
        """Add many edges at once: ``i, j`` shape ``(E,)``, ``measurements`` ``(E, 3)``,
        ``information`` ``(E, 3, 3)``; checked as :meth:`add_edge` checks one (``where``
        names each edge in an error message, e.g. its file and line)."""
        ii = np.asarray(i, dtype=np.int64).ravel()
        jj = np.asarray(j, dtype=np.int64).ravel()
        z = np.asarray(measurements, dtype=np.float64)
        omega = np.asarray(information, dtype=np.float64)
        m = len(ii)
        names = list(where) if where is not None else [f"edge {a} -> {b}"
                                                        for a, b in zip(ii, jj, strict=True)]
        n = len(self._poses)
        if jj.shape != (m,) or z.shape != (m, 3) or omega.shape != (m, 3, 3):
            raise PoseGraphError(f"edges need i, j of shape (E,), measurements (E, 3) and "
                                 f"information (E, 3, 3); got {ii.shape}, {jj.shape}, "
                                 f"{z.shape}, {omega.shape}")
        bad = np.flatnonzero((ii < 0) | (ii >= n) | (jj < 0) | (jj >= n) | (ii == jj))
        if len(bad):
            k = int(bad[0])
            raise PoseGraphError(f"{names[k]}: an edge joins two different existing nodes "
                                 f"(0..{n - 1}); got {ii[k]} -> {jj[k]}")
        bad = np.flatnonzero(~np.all(np.isfinite(z), axis=1))
        if len(bad):
            raise PoseGraphError(f"{names[int(bad[0])]}: the measurement must be 3 finite "
                                 f"numbers (x [m], y [m], θ [rad]); got {z[bad[0]]}")
        _check_information(omega, names)
        if kernel not in KERNELS:
            raise ValueError(f"kernel must be one of {KERNELS}; got {kernel!r}")
        if kernel != "none" and not delta > 0:
            raise ValueError(f"a robust kernel's delta must be positive; got {delta}")
        self._edges.append((ii, jj, z.copy(), omega.copy(),
                            np.full(m, KERNELS.index(kernel), dtype=np.int64),
                            np.full(m, float(delta))))
        self._edges_changed()

    def _edges_changed(self) -> None:
        """Forget what was derived from the edges (the poses stay)."""
        for key in ("edges", "structure", "solver"):
            self._cache.pop(key, None)

    # ------------------------------------------------------------------ arrays
    @property
    def poses(self) -> FloatArray:
        """``(N, 3)`` node poses (a copy)."""
        stacked = self._cache.get("poses")
        if stacked is None or len(stacked) != len(self._poses):
            stacked = np.array(self._poses, dtype=np.float64).reshape(-1, 3)
            self._cache["poses"] = stacked
        return np.array(stacked)

    @poses.setter
    def poses(self, value: ArrayLike) -> None:
        p = geometry.check_pose(value, "poses")
        if p.shape != (len(self._poses), 3):
            raise ValueError(f"poses must have shape ({len(self._poses)}, 3); got {p.shape}")
        self._poses = list(p.copy())
        self._cache["poses"] = np.array(p, dtype=np.float64)

    @property
    def num_nodes(self) -> int:
        return len(self._poses)

    @property
    def num_edges(self) -> int:
        return sum(len(block[0]) for block in self._edges)

    def edges(self) -> tuple[IntArray, IntArray, FloatArray, FloatArray]:
        """``(i, j, z, Ω)`` of every edge: shapes ``(E,), (E,), (E, 3), (E, 3, 3)``."""
        arrays = self._cache.get("edges")
        if arrays is None:
            blocks = self._edges
            if not blocks:
                blocks = [(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 3)),
                           np.zeros((0, 3, 3)), np.zeros(0, np.int64), np.zeros(0))]
            arrays = tuple(np.concatenate([b[k] for b in blocks]) for k in range(6))
            self._cache["edges"] = arrays
            self._edges = [arrays]  # one block: the next edges are joined to it alone
        return arrays[0], arrays[1], arrays[2], arrays[3]

    def _kernels(self) -> tuple[IntArray, FloatArray]:
        self.edges()
        arrays = self._cache["edges"]
        return arrays[4], arrays[5]

    def chi2(self) -> float:
        """``Σ eᵀ Ω e`` at the current poses (kernels not applied)."""
        return chi2(self.poses, *self.edges())

    def copy(self) -> PoseGraph:
        """An independent graph with the same nodes, edges, kernels and fixed nodes."""
        graph = PoseGraph(ids=list(self.ids), fixed=set(self.fixed))
        graph._poses = [p.copy() for p in self._poses]
        graph._edges = [(i.copy(), j.copy(), z.copy(), info.copy(), kernel.copy(), delta.copy())
                        for i, j, z, info, kernel, delta in self._edges]
        return graph

    def edge_chi2(self, poses: FloatArray | None = None) -> FloatArray:
        """Every edge's own ``eᵀ Ω e`` (kernels not applied), shape ``(E,)``, in the order of
        :meth:`edges`: after an optimisation, an edge the others disagree with stands out.

        >>> g = PoseGraph()
        >>> for pose in ([0, 0, 0], [1, 0, 0]):
        ...     _ = g.add_node(pose)
        >>> g.add_edge(0, 1, [1.5, 0, 0], np.eye(3) * 4)
        >>> g.edge_chi2().tolist()
        [1.0]
        """
        p = self.poses if poses is None else poses
        i, j, z, omega = self.edges()
        e = edge_errors(p, i, j, z)
        return np.asarray(np.einsum("ei,eij,ej->e", e, omega, e), dtype=np.float64)

    def remove_edges(self, indices: ArrayLike) -> None:
        """Drop the edges at ``indices`` (positions in :meth:`edges`); the rest keep their
        order, kernels and information.

        Raises
        ------
        PoseGraphError
            An index that names no edge.
        """
        drop = np.asarray(indices, dtype=np.int64).ravel()
        n = self.num_edges
        if np.any((drop < 0) | (drop >= n)):
            raise PoseGraphError(f"edge indices must lie in 0..{n - 1}; got {drop.tolist()}")
        if len(drop) == 0:
            return
        self.edges()
        keep = np.ones(n, dtype=bool)
        keep[drop] = False
        arrays = self._cache["edges"]
        self._edges = [tuple(a[keep] for a in arrays)]
        self._edges_changed()

    def cost(self, poses: FloatArray | None = None, robust: bool = True) -> float:
        """``Σ ρ(eᵀ Ω e)``: the objective :meth:`optimize` minimises (``robust=False``: the
        plain ``Σ eᵀ Ω e``, every kernel off)."""
        p = self.poses if poses is None else poses
        i, j, z, omega = self.edges()
        e = edge_errors(p, i, j, z)
        return float(self._robust(np.einsum("ei,eij,ej->e", e, omega, e), robust)[0].sum())

    def _robust(self, s: FloatArray, robust: bool = True) -> tuple[FloatArray, FloatArray]:
        rho, weight = s.copy(), np.ones_like(s)
        if not robust:
            return rho, weight
        kinds, deltas = self._kernels()
        for k, name in enumerate(KERNELS[1:], start=1):
            sel = kinds == k
            if sel.any():
                rho[sel], weight[sel] = _kernel_rows(s[sel], name, deltas[sel])
        return rho, weight

    # ------------------------------------------------------------------ solving
    def linearize(self, poses: FloatArray | None = None, robust: bool = True
                  ) -> tuple[Any, FloatArray, float]:
        """The reduced normal equations at ``poses``: ``H`` (upper triangle, CSC, over the
        free nodes' variables), the gradient ``g`` and the objective (``robust=False``:
        every kernel off).

        ``H = Σ Jᵀ w Ω J`` and ``g = Σ Jᵀ w Ω e`` with ``J = [A B]`` placed at the edge's two
        nodes and ``w = ρ'(eᵀΩe)`` (1 without a kernel).
        """
        from scipy.sparse import csc_matrix

        p = self.poses if poses is None else poses
        i, j, z, omega = self.edges()
        if len(i) == 0:
            raise PoseGraphError("the graph has no edges to optimise")
        st = self._structure()
        e, A, B = _errors_and_jacobians(p, i, j, z)
        s = np.einsum("ei,eij,ej->e", e, omega, e)
        rho, w = self._robust(s, robust)
        W = omega * w[:, None, None]
        WA, WB = W @ A, W @ B
        At, Bt = A.transpose(0, 2, 1), B.transpose(0, 2, 1)
        blocks = np.stack([At @ WA, At @ WB, Bt @ WA, Bt @ WB], axis=1).ravel()
        data = np.bincount(st.inverse, weights=blocks[st.keep], minlength=len(st.indices))
        H = csc_matrix((data, st.indices, st.indptr), shape=(st.n_vars, st.n_vars))
        g = np.zeros(st.n_vars)
        We = np.einsum("eij,ej->ei", W, e)
        for nodes, J in ((i, At), (j, Bt)):
            v = st.var[nodes]
            sel = v >= 0
            contrib = np.einsum("eij,ej->ei", J[sel], We[sel])
            np.add.at(g, (v[sel][:, None] + np.arange(3)).ravel(), contrib.ravel())
        return H, g, float(rho.sum())

    def _structure(self) -> _Structure:
        st = self._cache.get("structure")
        fixed = np.zeros(self.num_nodes, dtype=bool)
        bad = [k for k in self.fixed if not 0 <= k < self.num_nodes]
        if bad:
            raise PoseGraphError(f"fixed nodes {bad} do not exist (0..{self.num_nodes - 1})")
        fixed[list(self.fixed)] = True
        if st is None or st.var.shape[0] != self.num_nodes or \
                not np.array_equal(st.var < 0, fixed):
            i, j, _, _ = self.edges()
            st = _structure(self.num_nodes, fixed, i, j)
            self._cache["structure"] = st
        return st

    def relative_marginal(self, i: int, j: int) -> tuple[FloatArray, FloatArray]:
        """Node ``j`` seen from node ``i`` at the current poses, ``z = x_i⁻¹ ⊕ x_j``, and its
        covariance under the graph's linearisation: ``J H⁻¹ Jᵀ`` with ``J = [A B]`` the
        Jacobians of :func:`edge_error` at ``z`` and ``H⁻¹`` the two nodes' joint block of the
        inverse normal matrix (robust kernels' weights included). How far a new measurement
        of ``z`` may disagree with everything the graph already knows.

        >>> g = PoseGraph()
        >>> for pose in ([0, 0, 0], [1, 0, 0], [2, 0, 0]):
        ...     _ = g.add_node(pose)
        >>> g.add_edge(0, 1, [1, 0, 0], np.eye(3))
        >>> g.add_edge(1, 2, [1, 0, 0], np.eye(3))
        >>> z, cov = g.relative_marginal(1, 2)
        >>> z.tolist(), np.diag(cov).round(6).tolist()
        ([1.0, 0.0, 0.0], [1.0, 1.0, 1.0])
        """
        n = self.num_nodes
        if not (0 <= i < n and 0 <= j < n) or i == j:
            raise PoseGraphError(f"relative_marginal needs two different nodes in 0..{n - 1}; "
                                 f"got {i}, {j}")
        poses = self.poses
        H, _, _ = self.linearize(poses)
        st = self._structure()
        columns = [int(st.var[k]) + r for k in (i, j) if st.var[k] >= 0 for r in range(3)]
        block = np.zeros((6, 6))
        if columns:
            import qdldl

            try:
                solver = qdldl.Solver(H)
            except (ValueError, RuntimeError) as exc:
                raise PoseGraphError(f"the normal equations are singular ({exc})") from None
            unit = np.zeros(st.n_vars)
            inv_cols = np.empty((st.n_vars, len(columns)))
            for k, c in enumerate(columns):
                unit[c] = 1.0
                inv_cols[:, k] = solver.solve(unit)
                unit[c] = 0.0
            rows = [(0 if k == i else 3) + r for k in (i, j) if st.var[k] >= 0 for r in range(3)]
            block[np.ix_(rows, rows)] = inv_cols[columns]
        z = geometry.relative(poses[i], poses[j])
        A, B = edge_jacobians(poses[i], poses[j], z)
        J = np.hstack([A, B])
        cov = J @ block @ J.T
        return z, np.asarray(0.5 * (cov + cov.T), dtype=np.float64)

    def _apply(self, poses: FloatArray, dx: FloatArray) -> FloatArray:
        st = self._structure()
        free = st.var >= 0
        new = poses.copy()
        new[free] += dx.reshape(-1, 3)
        new[:, 2] = geometry.wrap_angle(new[:, 2])
        return new

    def optimize(self, method: str = "gn", max_iterations: int = 50,
                 tolerance: float = 1e-9, initial_lambda: float = 1e-4, robust: bool = True,
                 step: GaussNewtonStep | None = None) -> OptimizationResult:
        """Minimise ``Σ ρ(eᵀΩe)`` over the free nodes' poses; updates :attr:`poses`.

        Parameters
        ----------
        method
            ``"gn"`` Gauss–Newton (a full step each iteration) or ``"lm"``
            Levenberg–Marquardt (``H + λ diag(H)``; a step that raises the cost is refused
            and λ grows tenfold, an accepted one shrinks it threefold).
        max_iterations
            Linearisations at most.
        tolerance
            Stop when the cost falls by less than this fraction in an iteration.
        robust
            ``False`` turns every edge's kernel off: plain least squares, whose basin is
            wide (a robust kernel barely pulls at an edge far from being met), as a first
            solve before the robust one.
        step
            A Gauss–Newton step written elsewhere (a lab's), used for each iteration in
            place of the sparse solve: ``step(poses (N, 3), edges) -> new poses (N, 3)``
            with ``edges`` a list of ``(i, j, z (3,), Ω (3, 3))`` and node 0 held fixed.
            Robust kernels enter as iteratively reweighted least squares: each edge's
            ``Ω`` is handed over scaled by its kernel weight ``ρ'(eᵀΩe)`` at the current
            poses (what the built-in step does too). Only with ``method="gn"`` and node 0
            the one fixed node.
        """
        if method not in ("gn", "lm"):
            raise ValueError(f"method must be 'gn' or 'lm'; got {method!r}")
        if max_iterations < 1:
            raise ValueError(f"max_iterations must be at least 1; got {max_iterations}")
        if step is not None:
            if method != "gn" or self.fixed != {0}:
                raise ValueError("a step function needs method 'gn' and node 0 as the one "
                                 "fixed node")
            return self._optimize_with(step, max_iterations, tolerance, robust)
        solver = self._cache.setdefault("solver", _Cholesky())
        poses = self.poses
        H, g, cost = self.linearize(poses, robust)
        initial, history = cost, [cost]
        lam, converged, it = initial_lambda, False, 0
        for it in range(1, max_iterations + 1):  # noqa: B007 - it is reported
            st = self._structure()
            if method == "gn":
                dx = -solver.solve(H, g, st.key)
                new_poses = self._apply(poses, dx)
                H_new, g_new, new_cost = self.linearize(new_poses, robust)
            else:
                new_cost, dx = math.inf, np.zeros_like(g)
                diag = H.diagonal()
                for _ in range(20):
                    damped = H + _diag_upper(lam * np.maximum(diag, 1e-12), H)
                    dx = -solver.solve(damped, g, st.key)
                    new_poses = self._apply(poses, dx)
                    new_cost = self.cost(new_poses, robust)
                    if new_cost <= cost:
                        lam = max(lam / 3.0, 1e-12)
                        break
                    lam *= 10.0
                if new_cost > cost:
                    converged = True  # no step lowers the cost: a minimum to precision
                    break
                H_new, g_new, new_cost = self.linearize(new_poses, robust)
            decrease = cost - new_cost
            poses, H, g, cost = new_poses, H_new, g_new, new_cost
            history.append(cost)
            if abs(decrease) <= tolerance * max(cost, 1e-300) or \
                    float(np.max(np.abs(dx), initial=0.0)) < 1e-12:
                converged = True
                break
        self.poses = poses
        return OptimizationResult(it, initial, cost, converged, tuple(history))


    def _optimize_with(self, step: GaussNewtonStep, max_iterations: int, tolerance: float,
                       robust: bool = True) -> OptimizationResult:
        """:meth:`optimize` with ``step`` making each Gauss–Newton iteration."""
        i, j, z, omega = self.edges()
        if len(i) == 0:
            raise PoseGraphError("the graph has no edges to optimise")
        poses = self.poses
        cost = initial = self.cost(poses, robust)
        history, converged, it = [cost], False, 0
        for it in range(1, max_iterations + 1):  # noqa: B007 - it is reported
            e = edge_errors(poses, i, j, z)
            _, w = self._robust(np.einsum("ei,eij,ej->e", e, omega, e), robust)
            edges = [(int(a), int(b), z[k].copy(), omega[k] * w[k])
                     for k, (a, b) in enumerate(zip(i, j, strict=True))]
            new = geometry.check_pose(step(poses.copy(), edges), "the step's poses")
            if new.shape != poses.shape:
                raise ValueError(f"the step must return poses of shape {poses.shape}; got "
                                 f"{new.shape}")
            new_cost = self.cost(new, robust)
            decrease, moved = cost - new_cost, float(np.max(np.abs(new - poses)))
            poses, cost = new, new_cost
            history.append(cost)
            if abs(decrease) <= tolerance * max(cost, 1e-300) or moved < 1e-12:
                converged = True
                break
        self.poses = poses
        return OptimizationResult(it, initial, cost, converged, tuple(history))


GaussNewtonStep = Callable[[FloatArray, list[tuple[int, int, FloatArray, FloatArray]]], ArrayLike]
"""``step(poses, edges) -> poses``: one Gauss–Newton step of a pose graph (see
:meth:`PoseGraph.optimize`)."""


def _diag_upper(values: FloatArray, like: Any) -> Any:
    from scipy.sparse import diags

    return diags(values, format="csc", shape=like.shape)


def _kernel_rows(s: FloatArray, name: str, deltas: FloatArray) -> tuple[FloatArray, FloatArray]:
    """:func:`robust_weight` with a delta per edge."""
    d2 = deltas * deltas
    if name == "huber":
        root = np.sqrt(np.maximum(s, d2))
        inside = s <= d2
        return np.where(inside, s, 2.0 * deltas * root - d2), np.where(inside, 1.0,
                                                                       deltas / root)
    return d2 * np.log1p(s / d2), 1.0 / (1.0 + s / d2)


def _check_information(omega: FloatArray, names: Sequence[str]) -> None:
    """Raise :class:`PoseGraphError` for the first of ``omega`` ``(E, 3, 3)`` that holds a NaN
    or is not symmetric positive definite."""
    bad = np.flatnonzero(~np.all(np.isfinite(omega), axis=(1, 2)))
    if len(bad):
        k = int(bad[0])
        raise PoseGraphError(f"{names[k]}: the information matrix contains NaN or inf:\n"
                             f"{omega[k]}")
    scale = np.maximum(np.abs(omega).max(axis=(1, 2)), 1.0)
    asym = np.abs(omega - omega.transpose(0, 2, 1)).max(axis=(1, 2)) > 1e-9 * scale
    bad = np.flatnonzero(asym)
    if len(bad):
        k = int(bad[0])
        raise PoseGraphError(f"{names[k]}: the information matrix must be symmetric:\n"
                             f"{omega[k]}")
    smallest = np.linalg.eigvalsh(omega)[:, 0] if len(omega) else np.zeros(0)
    bad = np.flatnonzero(smallest <= 0.0)
    if len(bad):
        k = int(bad[0])
        raise PoseGraphError(f"{names[k]}: the information matrix is not positive definite "
                             f"(eigenvalues {np.linalg.eigvalsh(omega[k])}); it must be the "
                             f"inverse of a covariance")


def gauss_newton_step(graph: PoseGraph) -> FloatArray:
    """One Gauss–Newton step: the new poses ``x + Δx`` with ``H Δx = −g`` (not applied).

    The textbook form, on dense matrices: fine for the small graphs of a lab, and the
    reference the sparse :meth:`PoseGraph.optimize` is tested against.
    """
    poses = graph.poses
    i, j, z, omega = graph.edges()
    n = graph.num_nodes
    H = np.zeros((3 * n, 3 * n))
    g = np.zeros(3 * n)
    for k in range(len(i)):
        a, b = int(i[k]), int(j[k])
        e = edge_error(poses[a], poses[b], z[k])
        A, B = edge_jacobians(poses[a], poses[b], z[k])
        sa, sb = slice(3 * a, 3 * a + 3), slice(3 * b, 3 * b + 3)
        H[sa, sa] += A.T @ omega[k] @ A
        H[sa, sb] += A.T @ omega[k] @ B
        H[sb, sa] += B.T @ omega[k] @ A
        H[sb, sb] += B.T @ omega[k] @ B
        g[sa] += A.T @ omega[k] @ e
        g[sb] += B.T @ omega[k] @ e
    free = np.ones(3 * n, dtype=bool)
    for f in graph.fixed:
        free[3 * f:3 * f + 3] = False
    dx = np.zeros(3 * n)
    dx[free] = np.linalg.solve(H[np.ix_(free, free)], -g[free])
    new = poses + dx.reshape(n, 3)
    new[:, 2] = geometry.wrap_angle(new[:, 2])
    return new


# ----------------------------------------------------------------------------- files
def _open_text(path: str | Path) -> list[str]:
    p = Path(path)
    try:
        if p.suffix == ".gz":
            with gzip.open(p, "rt", encoding="utf-8") as f:
                return f.read().splitlines()
        return p.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        raise PoseGraphError(f"{p}: no such file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise PoseGraphError(f"{p}: unreadable ({exc})") from None


def _numbers(fields: Sequence[str], count: int, where: str) -> list[float]:
    if len(fields) < count:
        raise PoseGraphError(f"{where}: expected {count} numbers after the tag; got "
                             f"{len(fields)}")
    try:
        return [float(v) for v in fields[:count]]
    except ValueError:
        raise PoseGraphError(f"{where}: not a number in {' '.join(fields)!r}") from None


def _read_graph(path: str | Path, vertex_tag: str, edge_tag: str, toro: bool) -> PoseGraph:
    vertices: dict[int, list[float]] = {}
    edges: list[tuple[int, int, list[float], FloatArray, str]] = []
    fixed: set[int] = set()
    for n, line in enumerate(_open_text(path), start=1):
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        where = f"{path}:{n}"
        tag, rest = fields[0], fields[1:]
        if tag == vertex_tag:
            v = _numbers(rest, 4, where)
            vertices[int(v[0])] = v[1:]
        elif tag == edge_tag:
            v = _numbers(rest, 11, where)
            if toro:  # I_xx I_xy I_yy I_tt I_xt I_yt
                xx, xy, yy, tt, xt, yt = v[5:]
            else:     # I11 I12 I13 I22 I23 I33
                xx, xy, xt, yy, yt, tt = v[5:]
            omega = np.array([[xx, xy, xt], [xy, yy, yt], [xt, yt, tt]])
            edges.append((int(v[0]), int(v[1]), v[2:5], omega, where))
        elif tag == "FIX":
            fixed.update(int(_numbers([f], 1, where)[0]) for f in rest)
        else:
            raise PoseGraphError(f"{where}: unsupported line {tag!r} (this reader takes "
                                 f"{vertex_tag}, {edge_tag}, FIX and # comments)")
    return _assemble(vertices, edges, fixed, str(path))


def _assemble(vertices: dict[int, list[float]],
              edges: list[tuple[int, int, list[float], FloatArray, str]],
              fixed: set[int], name: str) -> PoseGraph:
    ids = sorted(set(vertices) | {e[0] for e in edges} | {e[1] for e in edges})
    if not ids:
        raise PoseGraphError(f"{name}: no vertices or edges")
    index = {node: k for k, node in enumerate(ids)}
    missing = [node for node in ids if node not in vertices]
    poses: FloatArray = np.zeros((len(ids), 3))
    for node, v in vertices.items():
        poses[index[node]] = v
    if missing:
        poses = _initial_guess(len(ids), [(index[a], index[b], np.array(z)) for a, b, z, _, _
                                          in edges], poses,
                               {index[node] for node in vertices}, name)
    graph = PoseGraph(ids=[], fixed={index[f] for f in fixed if f in index} or {0})
    for node, pose in zip(ids, poses, strict=True):
        graph.add_node(pose, node)
    if edges:
        graph.add_edges([index[e[0]] for e in edges], [index[e[1]] for e in edges],
                        [e[2] for e in edges], np.array([e[3] for e in edges]),
                        where=[e[4] for e in edges])
    return graph


def _initial_guess(n: int, edges: Iterable[tuple[int, int, FloatArray]], poses: FloatArray,
                   known: set[int], name: str) -> FloatArray:
    """Poses for nodes without a vertex line: along the odometry chain (edges ``k → k+1``)
    first, then outward over any edge (breadth first) from the nodes already placed."""
    adjacency: list[list[tuple[int, FloatArray]]] = [[] for _ in range(n)]
    chain: dict[int, FloatArray] = {}
    for a, b, z in edges:
        adjacency[a].append((b, z))
        adjacency[b].append((a, geometry.inverse(z)))
        if b == a + 1:
            chain.setdefault(a, z)
    placed = set(known) or {0}
    out = poses.copy()
    for k in range(n - 1):
        if k in placed and k + 1 not in placed and k in chain:
            out[k + 1] = geometry.compose(out[k], chain[k])
            placed.add(k + 1)
    queue = deque(sorted(placed))
    while queue:
        a = queue.popleft()
        for b, z in adjacency[a]:
            if b not in placed:
                out[b] = geometry.compose(out[a], z)
                placed.add(b)
                queue.append(b)
    if len(placed) < n:
        raise PoseGraphError(f"{name}: {n - len(placed)} nodes are not connected to the "
                             f"rest; they have no initial guess")
    return out


def read_g2o(path: str | Path) -> PoseGraph:
    """Read a 2-D g2o file (``VERTEX_SE2``, ``EDGE_SE2``, ``FIX``; ``.gz`` too).

    A file with edges only (``manhattan.g2o``) gets its initial guess from the odometry
    chain. Raises :class:`PoseGraphError` naming the line of anything malformed.
    """
    return _read_graph(path, "VERTEX_SE2", "EDGE_SE2", toro=False)


def read_toro(path: str | Path) -> PoseGraph:
    """Read a TORO ``.graph`` file (``VERTEX2``, ``EDGE2`` whose information entries come in
    the order ``I_xx I_xy I_yy I_θθ I_xθ I_yθ``)."""
    return _read_graph(path, "VERTEX2", "EDGE2", toro=True)


def _format(v: float) -> str:
    return f"{v:.9g}"


def _write(graph: PoseGraph, path: str | Path, toro: bool) -> None:
    lines = []
    vtag, etag = ("VERTEX2", "EDGE2") if toro else ("VERTEX_SE2", "EDGE_SE2")
    for node, pose in zip(graph.ids, graph.poses, strict=True):
        lines.append(f"{vtag} {node} " + " ".join(map(_format, pose)))
    i, j, z, omega = graph.edges()
    for a, b, m, w in zip(i, j, z, omega, strict=True):
        if toro:
            info = (w[0, 0], w[0, 1], w[1, 1], w[2, 2], w[0, 2], w[1, 2])
        else:
            info = (w[0, 0], w[0, 1], w[0, 2], w[1, 1], w[1, 2], w[2, 2])
        lines.append(f"{etag} {graph.ids[a]} {graph.ids[b]} " +
                     " ".join(map(_format, (*m, *info))))
    if not toro:
        lines.extend(f"FIX {graph.ids[f]}" for f in sorted(graph.fixed))
    Path(path).write_text("\n".join(lines) + "\n", encoding="utf-8")


def write_g2o(graph: PoseGraph, path: str | Path) -> None:
    """Write ``graph`` as a 2-D g2o file (vertices, edges, the fixed nodes as ``FIX``)."""
    _write(graph, path, toro=False)


def write_toro(graph: PoseGraph, path: str | Path) -> None:
    """Write ``graph`` as a TORO ``.graph`` file."""
    _write(graph, path, toro=True)

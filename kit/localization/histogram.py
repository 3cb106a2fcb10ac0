"""Markov localization on a histogram: the belief is a probability per cell.

**1-D** — a robot in a corridor along x (the three pillars, or the textbook's coloured
cells). The Bayes filter alternates

* *sense*: ``bel(x) ∝ p(z | x) · bel(x)`` — multiply by the measurement's likelihood in every
  cell, then normalise;
* *move*: ``bel'(x) = Σ_k p(k) · bel(x − u − k)`` — shift by the commanded cells ``u``,
  spreading by the motion's error distribution ``p(k)`` (undershoot, exact, overshoot).

In a closed ring (the textbook's cyclic world) the belief wraps round; in a corridor a robot
that would pass the end wall stays in the last cell.

**3-D** — :class:`GridLocalization` keeps a belief over ``(θ, y, x)`` cells of a small map;
*move* shifts each heading's layer by the odometry's motion and blurs it by the motion noise,
*sense* multiplies by the likelihood field of the scan at every cell centre. It is the exact
Bayes filter the particle filter approximates, affordable only on small maps: a 20 m × 12 m
office at 0.2 m and 10° is 216 000 states.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry
from kit.localization.likelihood_field import (
    LikelihoodField,
    LikelihoodFieldModel,
    likelihood_field_weights,
)
from kit.localization.particles import normalize_log_weights
from kit.models import odometry_control

__all__ = [
    "GridLocalization",
    "binary_likelihood",
    "move",
    "sense",
]

FloatArray = NDArray[np.float64]


def _check_belief(belief: ArrayLike) -> FloatArray:
    b = np.asarray(belief, dtype=np.float64)
    if b.ndim != 1 or len(b) == 0:
        raise ValueError(f"a 1-D belief is a non-empty array of probabilities; got shape "
                         f"{b.shape}")
    if np.any(b < 0) or not np.all(np.isfinite(b)):
        raise ValueError("a belief holds finite non-negative probabilities")
    return b


def binary_likelihood(world: Sequence[object], measurement: object, p_hit: float,
                      p_miss: float) -> FloatArray:
    """``p(z | x)`` of a sensor that reports what is in the robot's cell: ``p_hit`` in the
    cells where the world shows ``measurement``, ``p_miss`` elsewhere.

    >>> binary_likelihood(["door", "wall", "door"], "door", 0.6, 0.2).tolist()
    [0.6, 0.2, 0.6]
    """
    if not (p_hit >= 0 and p_miss >= 0 and p_hit + p_miss > 0):
        raise ValueError(f"p_hit and p_miss are non-negative likelihoods; got {p_hit}, {p_miss}")
    return np.array([p_hit if cell == measurement else p_miss for cell in world],
                    dtype=np.float64)


def sense(belief: ArrayLike, likelihood: ArrayLike) -> FloatArray:
    """The measurement update: ``bel(x) ∝ p(z | x) bel(x)``, normalised.

    >>> sense([0.2] * 5, [0.2, 0.6, 0.6, 0.2, 0.2]).round(4).tolist()
    [0.1111, 0.3333, 0.3333, 0.1111, 0.1111]
    """
    b = _check_belief(belief)
    lik = np.asarray(likelihood, dtype=np.float64)
    if lik.shape != b.shape or np.any(lik < 0):
        raise ValueError(f"the likelihood needs one non-negative value per cell, shape "
                         f"{b.shape}; got {lik.shape}")
    posterior = b * lik
    total = posterior.sum()
    if not total > 0:
        raise ValueError("the measurement is impossible under this belief (every cell has "
                         "probability 0)")
    return posterior / total


def move(belief: ArrayLike, shift: int, kernel: Mapping[int, float] | None = None,
         cyclic: bool = True) -> FloatArray:
    """The motion update: ``bel'(x) = Σ_k p(k) bel(x − shift − k)``.

    Parameters
    ----------
    belief : array_like, shape (N,)
        Probabilities per cell.
    shift : int
        Commanded motion in cells (positive: towards higher indices).
    kernel : mapping of int to float, optional
        ``p(k)``: the probability that the robot moves ``shift + k`` cells (``{-1: 0.1, 0:
        0.8, 1: 0.1}`` for undershoot, exact and overshoot). Default: exact motion.
    cyclic : bool
        True wraps round (a ring of cells); False keeps a robot at the end cells that would
        drive past them (a corridor between walls).

    >>> move([0, 1, 0, 0, 0], 1, {-1: 0.1, 0: 0.8, 1: 0.1}).round(6).tolist()
    [0.0, 0.1, 0.8, 0.1, 0.0]
    """
    b = _check_belief(belief)
    if not isinstance(shift, (int, np.integer)):
        raise TypeError(f"shift is a whole number of cells; got {shift!r}")
    k = {0: 1.0} if kernel is None else dict(kernel)
    if any(p < 0 for p in k.values()) or not math.isclose(sum(k.values()), 1.0, abs_tol=1e-9):
        raise ValueError(f"the motion kernel's probabilities must be >= 0 and sum to 1; got {k}")
    n = len(b)
    out = np.zeros(n)
    source = np.arange(n)
    for offset, p in k.items():
        target = source + int(shift) + int(offset)
        if cyclic:
            target %= n
        else:
            target = np.clip(target, 0, n - 1)
        np.add.at(out, target, p * b)
    return out


@dataclass
class GridLocalization:
    """Histogram localization over ``(θ, y, x)`` on a small map.

    Parameters
    ----------
    field_ : LikelihoodField
        The map (any resolution).
    cell_size : float
        [m] of the belief's x–y cells (coarser than the map's, e.g. 0.2 m).
    theta_bins : int
        Headings per cell (36: 10° each); bin ``k`` is centred on ``−π + (k + ½) 2π/K``.
    model : LikelihoodFieldModel
        The sensor model for :meth:`sense`.
    translation_noise, rotation_noise : float
        Standard deviation of the motion's error per metre travelled [m/m] and per radian
        turned [rad/rad], plus ``minimum_noise`` cells of blur in every step (the
        discretisation's own uncertainty).

    The belief starts uniform over the free cells. ``belief`` has shape
    ``(theta_bins, rows, cols)`` over the map's extent.
    """

    field_: LikelihoodField
    cell_size: float = 0.2
    theta_bins: int = 36
    model: LikelihoodFieldModel = field(default_factory=LikelihoodFieldModel)
    translation_noise: float = 0.1
    rotation_noise: float = 0.1
    minimum_noise: float = 0.5
    belief: FloatArray = field(init=False)

    def __post_init__(self) -> None:
        if not (self.cell_size > 0 and self.theta_bins >= 4):
            raise ValueError(f"need cell_size > 0 [m] and theta_bins >= 4; got "
                             f"{self.cell_size}, {self.theta_bins}")
        h, w = self.field_.shape
        rows = max(1, int(h * self.field_.resolution / self.cell_size))
        cols = max(1, int(w * self.field_.resolution / self.cell_size))
        rr, cc = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
        local = np.column_stack([(cc.ravel() + 0.5) * self.cell_size,
                                 (rr.ravel() + 0.5) * self.cell_size])
        self._xy = geometry.transform_points(self.field_.origin, local)
        mr, mc = self.field_.cells_of(self._xy)
        self.free = self.field_.free[np.clip(mr, 0, h - 1), np.clip(mc, 0, w - 1)].reshape(
            rows, cols)
        if not self.free.any():
            raise ValueError("no belief cell lies on the map's free space")
        self.thetas = -math.pi + (np.arange(self.theta_bins) + 0.5) * 2 * math.pi / \
            self.theta_bins
        self.belief = np.broadcast_to(self.free, (self.theta_bins, rows, cols)).astype(float)
        self.belief /= self.belief.sum()

    @property
    def poses(self) -> FloatArray:
        """The pose at the centre of every state, shape (theta_bins · rows · cols, 3), in the
        belief's order."""
        n = len(self._xy)
        return np.column_stack([np.tile(self._xy, (self.theta_bins, 1)),
                                np.repeat(self.thetas, n)])

    def sense(self, endpoints: ArrayLike, range_max: float) -> None:
        """Measurement update with a scan's beam endpoints in ``base`` (M, 2)."""
        ll = likelihood_field_weights(self.poses, endpoints, self.field_, self.model,
                                      range_max).reshape(self.belief.shape)
        with np.errstate(divide="ignore"):
            log_b = np.log(self.belief) + ll
        self.belief = normalize_log_weights(log_b.ravel()).reshape(self.belief.shape)

    def move(self, odom_previous: ArrayLike, odom_current: ArrayLike) -> None:
        """Motion update by the odometry's motion between two odometry poses."""
        from scipy.ndimage import gaussian_filter, shift

        rot1, trans, rot2 = odometry_control(odom_previous, odom_current)
        yaw = float(self.field_.origin[2])
        moved = np.empty_like(self.belief)
        for k, theta in enumerate(self.thetas):
            heading = theta + rot1 - yaw                     # in the grid's own frame
            d = np.array([trans * math.sin(heading), trans * math.cos(heading)])
            moved[k] = shift(self.belief[k], d / self.cell_size, order=1, mode="constant")
        bins = (rot1 + rot2) / (2 * math.pi / self.theta_bins)
        moved = shift(moved, (bins, 0.0, 0.0), order=1, mode="grid-wrap")
        sigma_xy = (self.translation_noise * trans) / self.cell_size + self.minimum_noise
        sigma_t = (self.rotation_noise * (abs(rot1) + abs(rot2))) / \
            (2 * math.pi / self.theta_bins) + self.minimum_noise
        moved = gaussian_filter(moved, (sigma_t, sigma_xy, sigma_xy),
                                mode=("wrap", "constant", "constant"))
        moved *= self.free
        total = moved.sum()
        if not total > 0:
            raise ValueError("the motion moved all the belief off the map's free space")
        self.belief = moved / total

    def most_likely(self) -> FloatArray:
        """The pose ``(x, y, θ)`` of the most probable state."""
        k = int(np.argmax(self.belief))
        return self.poses[k]

    def marginal_xy(self) -> FloatArray:
        """The belief summed over headings, shape (rows, cols)."""
        return self.belief.sum(axis=0)

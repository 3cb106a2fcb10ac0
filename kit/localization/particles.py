"""The particle filter of Monte Carlo localization, in AMCL's design.

A belief over poses ``(x, y, θ)`` in ``map`` is held as ``N`` particles with normalised
weights. One step of the filter (Thrun, Burgard & Fox, *Probabilistic Robotics*, ch. 8):

1. **predict** — move every particle by the odometry's motion with sampled noise
   (:func:`kit.models.sample_odometry_motion`);
2. **weigh** — multiply each weight by the scan's likelihood at that particle (a sensor
   model of :mod:`kit.localization.likelihood_field`), in logs so that nothing underflows;
3. **resample** — only when the weights have degenerated: when the effective sample size
   ``N_eff = 1 / Σ w²`` drops below ``ess_threshold · N`` (resampling a healthy set only adds
   noise). Selection is the low-variance (systematic) sampler (table 4.4); the number of
   particles drawn is adapted by KLD-sampling (Fox 2003): enough that, with probability given
   by the standard-normal quantile ``pf_z``, the KL divergence between the particle
   histogram (bins of 0.5 m × 0.5 m × 10°, as AMCL) and the true posterior stays under
   ``pf_err``, between ``min_particles`` and ``max_particles``;
4. **recover** (augmented MCL, table 8.3) — keep a slow and a fast average of the scans'
   mean likelihood, ``w_slow += α_slow (w_avg − w_slow)`` and likewise ``w_fast``; when the
   recent likelihood falls below the long-term one, resampling draws a share
   ``max(0, 1 − w_fast / w_slow)`` of the new particles uniformly over free space (a
   kidnapped robot), and then happens whatever the effective sample size. Since those random
   particles fill many histogram bins, KLD-sampling raises the count towards
   ``max_particles`` — which is how AMCL searches the whole map again.

AMCL itself cannot combine the low-variance sampler with KLD's stopping rule (it says so in
``pf.c``) and draws independently instead. The kit draws a full systematic sample, shuffles
it, and stops KLD's count on that order: every prefix of a shuffled systematic sample is an
unbiased sample of the weighted set, with less variance than independent draws.

The pose estimate is AMCL's: the particles are clustered (histogram bins that touch,
26-neighbourhood, θ wrapping round), the heaviest cluster's weighted mean is the pose, and
the covariance is the whole set's (x–y block; for θ the circular variance
``−2 log R``).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from kit import geometry
from kit.localization.likelihood_field import LikelihoodField
from kit.models import Control, sample_odometry_motion

__all__ = [
    "BIN_SIZE",
    "ParticleFilter",
    "cluster_labels",
    "effective_sample_size",
    "histogram_bins",
    "kld_resample",
    "kld_sample_limit",
    "low_variance_resample",
    "normalize_log_weights",
    "pose_estimate",
    "random_particle_share",
    "uniform_free_poses",
    "update_recovery_averages",
]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BIN_SIZE = (0.5, 0.5, math.radians(10.0))
"""AMCL's histogram bins (pf_kdtree.c): 0.5 m, 0.5 m, 10°."""
_THETA_BINS = 36


def normalize_log_weights(log_weights: ArrayLike) -> FloatArray:
    """Weights summing to 1 from log-weights, without underflow:
    ``w_i = exp(l_i − max l) / Σ exp(l_j − max l)``.

    Multiplying sixty beam likelihoods of 0.01 gives 1e-120, and two such products no longer
    differ in float64 for long; their logs (−276) are ordinary numbers.

    >>> normalize_log_weights([-1000.0, -1000.0 + np.log(3.0)]).round(6).tolist()
    [0.25, 0.75]
    """
    lw = np.asarray(log_weights, dtype=np.float64)
    if lw.ndim != 1 or len(lw) == 0:
        raise ValueError(f"log_weights must be a non-empty 1-D array; got shape {lw.shape}")
    if np.any(np.isnan(lw)) or np.any(lw == np.inf):
        raise ValueError("log_weights contain NaN or +inf")
    top = np.max(lw)
    if top == -np.inf:
        raise ValueError("every particle has zero likelihood (all log-weights are -inf)")
    w = np.exp(lw - top)
    return w / w.sum()


def effective_sample_size(weights: ArrayLike) -> float:
    """``N_eff = 1 / Σ w_i²`` of normalised weights: ``N`` for equal weights, 1 when one
    particle holds everything (Liu & Chen 1998).

    >>> effective_sample_size([0.25] * 4), effective_sample_size([1.0, 0.0, 0.0])
    (4.0, 1.0)
    """
    w = np.asarray(weights, dtype=np.float64)
    total = w.sum()
    if w.ndim != 1 or len(w) == 0 or np.any(w < 0) or not total > 0:
        raise ValueError("weights must be a non-empty 1-D array of non-negative numbers with "
                         "a positive sum")
    w = w / total
    return float(1.0 / np.sum(w * w))


def low_variance_resample(weights: ArrayLike, n: int, rng: np.random.Generator) -> IntArray:
    """Indices of ``n`` particles drawn by the low-variance (systematic) sampler
    (*Probabilistic Robotics*, table 4.4): one random offset ``r ∈ [0, 1/n)``, then the
    particles under the pointers ``r + m/n`` of the cumulative weights. Particle ``i`` is
    drawn ``⌊n wᵢ⌋`` or ``⌈n wᵢ⌉`` times, never by chance more or fewer.

    >>> low_variance_resample([0.5, 0.0, 0.5], 4, np.random.default_rng(1)).tolist()
    [0, 0, 2, 2]
    """
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 1 or len(w) == 0 or np.any(w < 0) or not w.sum() > 0:
        raise ValueError("weights must be a non-empty 1-D array of non-negative numbers with "
                         "a positive sum")
    if not (isinstance(n, (int, np.integer)) and n >= 1):
        raise ValueError(f"n is a number of particles >= 1; got {n!r}")
    cumulative = np.cumsum(w / w.sum())
    cumulative[-1] = 1.0  # rounding must not leave the last pointer past the end
    pointers = (rng.uniform(0.0, 1.0 / n) + np.arange(n) / n)
    return np.searchsorted(cumulative, pointers, side="right").astype(np.int64)


def kld_sample_limit(k: int, pf_err: float = 0.05, pf_z: float = 0.99,
                     min_particles: int = 500, max_particles: int = 2000) -> int:
    """KLD-sampling's particle count for ``k`` occupied histogram bins (Fox 2003, with the
    Wilson–Hilferty approximation of the χ² quantile, as AMCL's ``pf_resample_limit``):

    .. math:: n = \\left\\lceil \\frac{k-1}{2ε}\\left(1 - \\frac{2}{9(k-1)} +
              \\sqrt{\\frac{2}{9(k-1)}}\\, z\\right)^3 \\right\\rceil

    clipped to ``[min_particles, max_particles]``; ``k <= 1`` gives ``max_particles``.
    ``pf_err`` is ε, ``pf_z`` the upper standard-normal quantile z (Nav2's default 0.99 is
    used as z itself, exactly as Nav2 does).

    >>> kld_sample_limit(100, 0.05, 3.0, 1, 10**6)
    1467
    """
    if not (pf_err > 0 and math.isfinite(pf_z) and 1 <= min_particles <= max_particles):
        raise ValueError(f"need pf_err > 0, finite pf_z and 1 <= min_particles <= "
                         f"max_particles; got {pf_err}, {pf_z}, {min_particles}, "
                         f"{max_particles}")
    if k <= 1:
        return int(max_particles)
    b = 2.0 / (9.0 * (k - 1))
    n = math.ceil((k - 1) / (2.0 * pf_err) * (1.0 - b + math.sqrt(b) * pf_z) ** 3)
    return int(min(max(n, min_particles), max_particles))


def histogram_bins(poses: ArrayLike, size: tuple[float, float, float] = BIN_SIZE) -> IntArray:
    """The histogram bin ``(⌊x/sx⌋, ⌊y/sy⌋, ⌊θ/sθ⌋ mod 36)`` of each pose, shape (N, 3)."""
    p = geometry.check_pose(poses, "poses").reshape(-1, 3)
    keys = np.floor(p / np.asarray(size)).astype(np.int64)
    keys[:, 2] %= max(1, round(2 * math.pi / size[2]))
    return keys


def _bin_codes(keys: IntArray) -> IntArray:
    """One int64 per bin key (x and y offset to stay non-negative)."""
    return ((keys[:, 0] + (1 << 20)) * (1 << 21) + (keys[:, 1] + (1 << 20))) * _THETA_BINS \
        + keys[:, 2]


Sampler = Callable[[FloatArray, int, float], ArrayLike]
"""``sampler(weights (N,), n, r) -> indices (n,)``: a low-variance sampler given its offset
``r ∈ [0, 1/n)`` (a lab's ``low_variance_resample``)."""


def _sample(w: FloatArray, n: int, rng: np.random.Generator, sampler: Sampler | None
            ) -> IntArray:
    """``n`` indices by :func:`low_variance_resample`, or by ``sampler`` with the same one
    draw of the offset from ``rng`` (so a correct sampler gives the same particles)."""
    if sampler is None:
        return low_variance_resample(w, n, rng)
    drawn = np.asarray(sampler(w, n, float(rng.uniform(0.0, 1.0 / n))))
    if drawn.shape != (n,) or drawn.dtype.kind not in "iu" or \
            (n and (drawn.min() < 0 or drawn.max() >= len(w))):
        raise ValueError(f"the sampler must return {n} integer indices in [0, {len(w)}); got "
                         f"shape {drawn.shape}, dtype {drawn.dtype}")
    return drawn.astype(np.int64)


def kld_resample(poses: ArrayLike, weights: ArrayLike, rng: np.random.Generator, *,
                 pf_err: float = 0.05, pf_z: float = 0.99, min_particles: int = 500,
                 max_particles: int = 2000, random_share: float = 0.0,
                 random_poses: Callable[[int], FloatArray] | None = None,
                 sampler: Sampler | None = None) -> FloatArray:
    """Resample ``poses`` (N, 3) by their ``weights`` with the low-variance sampler, as many
    as KLD-sampling asks for (:func:`kld_sample_limit`).

    Candidates are drawn until ``max_particles``: each one, with probability
    ``random_share``, a random pose from ``random_poses(n)`` (augmented MCL's injection),
    otherwise the next of a shuffled systematic sample of the weighted set. They are taken
    one by one, counting the histogram bins they fill, until the count exceeds the limit for
    the bins filled so far (AMCL's stopping rule) — so a large random share, which fills many
    bins, brings the set up to ``max_particles``, as in AMCL. Returns the new particles
    (their weights are equal). ``sampler`` replaces :func:`low_variance_resample` (see
    :data:`Sampler`).
    """
    p = geometry.check_pose(poses, "poses").reshape(-1, 3)
    w = np.asarray(weights, dtype=np.float64)
    if w.shape != (len(p),):
        raise ValueError(f"weights must have shape ({len(p)},); got {w.shape}")
    if not 0.0 <= random_share <= 1.0:
        raise ValueError(f"random_share is a probability; got {random_share}")
    m = int(max_particles)
    is_random = rng.random(m) < random_share if random_share > 0 else np.zeros(m, dtype=bool)
    n_random = int(is_random.sum())
    if n_random and random_poses is None:
        raise ValueError("random_share > 0 needs random_poses to draw the random particles")
    candidates = np.empty((m, 3))
    if n_random < m:
        drawn = _sample(w, m - n_random, rng, sampler)
        candidates[~is_random] = p[rng.permutation(drawn)]
    if n_random:
        assert random_poses is not None
        candidates[is_random] = random_poses(n_random)
    codes = _bin_codes(histogram_bins(candidates))
    _, first = np.unique(codes, return_index=True)
    new_bin = np.zeros(len(codes), dtype=bool)
    new_bin[first] = True
    k = np.cumsum(new_bin)                     # bins filled by the first n samples
    count = np.arange(1, len(codes) + 1)
    limits = np.array([kld_sample_limit(int(kk), pf_err, pf_z, min_particles, max_particles)
                       for kk in range(int(k[-1]) + 1)])
    enough = np.flatnonzero(count > limits[k])
    n = int(enough[0]) + 1 if len(enough) else len(codes)
    return candidates[:n].copy()


def uniform_free_poses(field_: LikelihoodField, n: int, rng: np.random.Generator
                       ) -> FloatArray:
    """``n`` poses spread uniformly over the map's free cells (a uniform position inside a
    uniformly chosen free cell) with uniform headings in [−π, π): global localization's
    starting belief, and augmented MCL's random particles."""
    free_rows, free_cols = np.nonzero(field_.free)
    if len(free_rows) == 0:
        raise ValueError("the map has no free cell to spread particles over")
    pick = rng.integers(0, len(free_rows), n)
    local = np.column_stack([(free_cols[pick] + rng.random(n)) * field_.resolution,
                             (free_rows[pick] + rng.random(n)) * field_.resolution])
    xy = geometry.transform_points(field_.origin, local)
    return np.column_stack([xy, rng.uniform(-math.pi, math.pi, n)])


def update_recovery_averages(w_slow: float, w_fast: float, w_avg: float, alpha_slow: float,
                             alpha_fast: float) -> tuple[float, float]:
    """Augmented MCL's averages (*Probabilistic Robotics*, table 8.3, as AMCL: an average of
    0 starts at the first value): ``w += α (w_avg − w)`` for both.

    >>> update_recovery_averages(0.0, 0.0, 2.0, 0.001, 0.1)
    (2.0, 2.0)
    >>> tuple(round(v, 4) for v in update_recovery_averages(2.0, 2.0, 1.0, 0.001, 0.1))
    (1.999, 1.9)
    """
    if not (0 <= alpha_slow <= 1 and 0 <= alpha_fast <= 1):
        raise ValueError(f"recovery_alpha_slow and recovery_alpha_fast lie in [0, 1]; got "
                         f"{alpha_slow}, {alpha_fast}")
    w_slow = w_avg if w_slow == 0.0 else w_slow + alpha_slow * (w_avg - w_slow)
    w_fast = w_avg if w_fast == 0.0 else w_fast + alpha_fast * (w_avg - w_fast)
    return w_slow, w_fast


def random_particle_share(w_slow: float, w_fast: float) -> float:
    """``max(0, 1 − w_fast / w_slow)``: the share of the belief to replace by random poses
    (0 while the averages are not running).

    >>> random_particle_share(2.0, 1.5)
    0.25
    """
    if w_slow <= 0.0:
        return 0.0
    return max(0.0, 1.0 - w_fast / w_slow)


def cluster_labels(poses: ArrayLike, size: tuple[float, float, float] = BIN_SIZE) -> IntArray:
    """Cluster label of every particle: particles whose histogram bins touch (any of the 26
    neighbours, θ wrapping round) share a label, as AMCL's ``pf_kdtree_cluster``."""
    keys = histogram_bins(poses, size)
    # one int64 code per bin, in the keys' lexicographic order: the bins are the unique codes
    sorted_codes, first, inverse = np.unique(_bin_codes(keys), return_index=True,
                                             return_inverse=True)
    unique = keys[first]
    offsets = np.array([(dx, dy, dt) for dx in (-1, 0, 1) for dy in (-1, 0, 1)
                        for dt in (-1, 0, 1) if (dx, dy, dt) != (0, 0, 0)])
    neighbour = unique[:, None, :] + offsets[None, :, :]          # (bins, 26, 3)
    neighbour[..., 2] %= _THETA_BINS
    ncodes = _bin_codes(neighbour.reshape(-1, 3))
    at = np.minimum(np.searchsorted(sorted_codes, ncodes), len(sorted_codes) - 1)
    hit = sorted_codes[at] == ncodes
    r = np.flatnonzero(hit) // len(offsets)
    c = at[hit]
    bin_label = _components(len(unique), r, c)
    return bin_label[np.asarray(inverse).reshape(-1)]


@njit(cache=True)
def _components(n: int, a: IntArray, b: IntArray) -> IntArray:
    """Connected components of ``n`` nodes joined by the edges ``a[k]–b[k]`` (union–find),
    labelled 0, 1, … in the order of each component's lowest node, as
    ``scipy.sparse.csgraph.connected_components`` numbers them."""
    parent = np.arange(n)
    for k in range(len(a)):
        x, y = a[k], b[k]
        while parent[x] != x:
            parent[x] = parent[parent[x]]
            x = parent[x]
        while parent[y] != y:
            parent[y] = parent[parent[y]]
            y = parent[y]
        if x != y:
            if x < y:
                parent[y] = x
            else:
                parent[x] = y
    label = np.full(n, -1, dtype=np.int64)
    count = 0
    for i in range(n):
        root = i
        while parent[root] != root:
            root = parent[root]
        if label[root] < 0:
            label[root] = count
            count += 1
        label[i] = label[root]
    return label


def _weighted_stats(poses: FloatArray, w: FloatArray) -> tuple[FloatArray, FloatArray]:
    total = w.sum()
    mx, my = (w @ poses[:, 0]) / total, (w @ poses[:, 1]) / total
    c, s = (w @ np.cos(poses[:, 2])) / total, (w @ np.sin(poses[:, 2])) / total
    cov = np.zeros((3, 3))
    d = poses[:, :2] - [mx, my]
    cov[:2, :2] = (d * w[:, None]).T @ d / total
    cov[2, 2] = -2.0 * math.log(max(math.hypot(c, s), 1e-300))
    return np.array([mx, my, math.atan2(s, c)]), cov


def pose_estimate(poses: ArrayLike, weights: ArrayLike) -> tuple[FloatArray, FloatArray]:
    """AMCL's estimate: the weighted mean of the heaviest cluster (θ by circular mean) and the
    covariance of the whole set, shape (3,) and (3, 3) over (x, y, θ).

    The θ variance is the circular ``−2 log R`` (R the mean resultant length), AMCL's
    formula; x–θ and y–θ covariances are 0, as AMCL publishes them.
    """
    p = geometry.check_pose(poses, "poses").reshape(-1, 3)
    w = np.asarray(weights, dtype=np.float64)
    if w.shape != (len(p),) or not w.sum() > 0:
        raise ValueError(f"weights must have shape ({len(p)},) and a positive sum")
    labels = cluster_labels(p)
    cluster_weight = np.bincount(labels, weights=w)
    best = labels == int(np.argmax(cluster_weight))
    mean, _ = _weighted_stats(p[best], w[best])
    _, cov = _weighted_stats(p, w)
    return mean, cov


@dataclass
class ParticleFilter:
    """A particle set and its recovery averages; methods call the pure functions above.

    ``poses`` (N, 3) in ``map``, ``weights`` (N,) normalised.
    """

    poses: FloatArray
    weights: FloatArray
    rng: np.random.Generator
    w_slow: float = 0.0
    w_fast: float = 0.0

    @classmethod
    def from_poses(cls, poses: ArrayLike, rng: np.random.Generator) -> ParticleFilter:
        p = geometry.check_pose(poses, "poses").reshape(-1, 3).copy()
        return cls(p, np.full(len(p), 1.0 / len(p)), rng)

    @classmethod
    def gaussian(cls, mean: ArrayLike, covariance: ArrayLike, n: int,
                 rng: np.random.Generator) -> ParticleFilter:
        """``n`` particles drawn from a normal distribution over (x, y, θ) (AMCL's
        ``pf_init``)."""
        m = geometry.check_pose(mean, "mean")
        cov = np.asarray(covariance, dtype=np.float64)
        if cov.shape != (3, 3) or not np.allclose(cov, cov.T) or \
                np.any(np.linalg.eigvalsh(cov) < -1e-12):
            raise ValueError("covariance must be a symmetric positive semi-definite 3 x 3 "
                             "matrix over (x [m], y [m], θ [rad])")
        p = rng.multivariate_normal(m, cov, int(n), method="eigh")
        p[:, 2] = geometry.wrap_angle(p[:, 2])
        return cls.from_poses(p, rng)

    def __len__(self) -> int:
        return len(self.poses)

    def predict(self, odom_previous: ArrayLike, odom_current: ArrayLike,
                alphas: ArrayLike, control: Control | None = None) -> None:
        """Move the particles by the odometry's motion (:func:`sample_odometry_motion`;
        ``control`` replaces its :func:`kit.models.odometry_control`)."""
        self.poses = sample_odometry_motion(self.poses, odom_previous, odom_current, alphas,
                                            self.rng, control=control)

    def weigh(self, log_likelihoods: ArrayLike, alpha_slow: float = 0.0,
              alpha_fast: float = 0.0, beams: int = 1,
              normalize: Callable[[FloatArray], ArrayLike] | None = None) -> float:
        """Multiply the weights by the likelihoods (given as logs), normalise, and update the
        recovery averages with the mean likelihood; returns that mean.

        The mean is the weighted mean likelihood ``Σ wᵢ p(z | xᵢ)`` (the textbook's
        ``w_avg`` for an equally weighted set), taken to the power ``1 / beams``. AMCL
        divides it by the particle count as well, which makes its averages jump whenever
        KLD-sampling changes the count; the kit does not. With ``beams`` = the number of
        beams of a product likelihood, the averages follow the typical *beam's* likelihood
        (a geometric mean), which moves by tens of percent from scan to scan where the
        product itself swings over orders of magnitude — and those swings would read as
        lost track. ``normalize(log_weights) -> weights`` replaces
        :func:`normalize_log_weights`.
        """
        ll = np.asarray(log_likelihoods, dtype=np.float64)
        if ll.shape != self.weights.shape:
            raise ValueError(f"one log-likelihood per particle: shape {self.weights.shape}; "
                             f"got {ll.shape}")
        with np.errstate(divide="ignore"):
            log_w = np.log(self.weights) + ll
        if normalize is None:
            self.weights = normalize_log_weights(log_w)
        else:
            w = np.asarray(normalize(log_w), dtype=np.float64)
            if w.shape != log_w.shape or not np.all(np.isfinite(w)) or np.any(w < 0) or \
                    not w.sum() > 0:
                raise ValueError(f"normalize must return {len(log_w)} finite non-negative "
                                 f"weights with a positive sum; got {w[:4]}…")
            self.weights = w
        top = float(np.max(log_w))
        if not (isinstance(beams, (int, np.integer)) and beams >= 1):
            raise ValueError(f"beams is a count >= 1; got {beams!r}")
        log_avg = (top + math.log(float(np.sum(np.exp(log_w - top))))) / beams
        w_avg = math.exp(min(max(log_avg, -700.0), 700.0))  # kept a positive float
        if alpha_slow > 0 or alpha_fast > 0:
            self.w_slow, self.w_fast = update_recovery_averages(self.w_slow, self.w_fast,
                                                                w_avg, alpha_slow, alpha_fast)
        return w_avg

    def effective_sample_size(self) -> float:
        return effective_sample_size(self.weights)

    def random_share(self) -> float:
        """Augmented MCL's share of random particles now (:func:`random_particle_share`)."""
        return random_particle_share(self.w_slow, self.w_fast)

    def resample(self, pf_err: float = 0.05, pf_z: float = 0.99, min_particles: int = 500,
                 max_particles: int = 2000,
                 random_poses: Callable[[int], FloatArray] | None = None,
                 reset_averages: bool = True, sampler: Sampler | None = None) -> int:
        """KLD low-variance resampling (:func:`kld_resample`), the weights becoming equal.

        With ``random_poses``, augmented MCL's share of the new particles are random poses;
        when that share is positive and ``reset_averages`` is set, the recovery averages
        restart (AMCL's rule, against "spiralling off into randomness"; the textbook's table
        8.3 keeps them, and goes on injecting until the likelihood is back to its long-term
        level). Returns the number of particles. ``sampler``: see :func:`kld_resample`.
        """
        share = self.random_share() if random_poses is not None else 0.0
        self.poses = kld_resample(self.poses, self.weights, self.rng, pf_err=pf_err, pf_z=pf_z,
                                  min_particles=min_particles, max_particles=max_particles,
                                  random_share=share, random_poses=random_poses,
                                  sampler=sampler)
        self.weights = np.full(len(self.poses), 1.0 / len(self.poses))
        if share > 0.0 and reset_averages:
            self.w_slow = self.w_fast = 0.0
        return len(self.poses)

    def estimate(self) -> tuple[FloatArray, FloatArray]:
        """:func:`pose_estimate` of the set."""
        return pose_estimate(self.poses, self.weights)

    def spread(self) -> float:
        """The largest distance [m] of a particle from the set's weighted mean position."""
        mean = self.weights @ self.poses[:, :2]
        return float(np.max(np.linalg.norm(self.poses[:, :2] - mean, axis=1)))

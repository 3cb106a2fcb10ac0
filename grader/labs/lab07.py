"""Lab 07 — localization (think): the exercises, their cases and their known mistakes.

Students write the histogram filter's sense and move steps, the odometry motion model's
control, the likelihood field's log-weights, the normalisation of log-weights, the effective
sample size test and the low-variance sampler; :mod:`kit.localization` and :mod:`kit.models`
are the references.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from grader.spec import Case, Diagnostic, Exercise, LabSpec
from kit import geometry, models
from kit.localization import histogram as hist
from kit.localization import particles as pf
from kit.localization.likelihood_field import (
    LikelihoodField,
    LikelihoodFieldModel,
    likelihood_field_weights,
)

_BLOCKED = (
    "kit.localization.histogram:sense", "kit.localization.histogram:move",
    "kit.localization.histogram:binary_likelihood", "kit.models:odometry_control",
    "kit.localization.likelihood_field:likelihood_field_weights",
    "kit.localization.likelihood_field:likelihood_field_weight",
    "kit.localization.particles:normalize_log_weights",
    "kit.localization.particles:effective_sample_size",
    "kit.localization.particles:low_variance_resample",
)

WORLD = ("wall", "pillar", "wall", "wall", "pillar", "wall", "wall", "wall", "pillar", "wall")
"""The corridor of ten cells with its three pillars."""


# ---------------------------------------------------------------- sense and move

def _sense(belief: Any, world: Any, measurement: str, p_hit: float, p_miss: float) -> Any:
    return hist.sense(belief, hist.binary_likelihood(list(world), measurement, p_hit, p_miss))


def _sense_unnormalised(belief: Any, world: Any, measurement: str, p_hit: float,
                        p_miss: float) -> Any:
    return np.asarray(belief, float) * hist.binary_likelihood(list(world), measurement, p_hit,
                                                              p_miss)


def _sense_added(belief: Any, world: Any, measurement: str, p_hit: float,
                 p_miss: float) -> Any:
    b = np.asarray(belief, float) + hist.binary_likelihood(list(world), measurement, p_hit,
                                                           p_miss)
    return b / b.sum()


def _belief(rng: np.random.Generator, n: int) -> Any:
    b = rng.random(n) + 0.05
    return b / b.sum()


def _sense_hidden(rng: np.random.Generator) -> list[Case]:
    return [Case(f"random {i}", (_belief(rng, len(WORLD)), WORLD,
                                 str(rng.choice(["wall", "pillar"])),
                                 float(rng.uniform(0.5, 0.9)), float(rng.uniform(0.05, 0.3))))
            for i in range(3)]


sense = Exercise(
    id="lab07.sense", function="sense", title="Sense: Bayes' rule on a histogram",
    reference=_sense, points=2,
    public=(Case("uniform, a pillar seen", (np.full(10, 0.1), WORLD, "pillar", 0.6, 0.2)),
            Case("a belief, a wall seen", (np.array([0.3, 0.2, 0.1, 0.1, 0.1, 0.05, 0.05, 0.04,
                                                     0.03, 0.03]), WORLD, "wall", 0.8, 0.1))),
    hidden=_sense_hidden, rtol=1e-9, atol=1e-12,
    diagnostics=(
        Diagnostic("weights not normalised", _sense_unnormalised,
                   "divide by the sum after multiplying: a belief must add up to 1"),
        Diagnostic("likelihood added, not multiplied", _sense_added,
                   "Bayes' rule multiplies: bel(x) ∝ p(z | x) · bel(x)"),
    ),
    blocked=_BLOCKED,
)


def _move(belief: Any, shift: int, p_under: float, p_exact: float, p_over: float) -> Any:
    return hist.move(belief, int(shift), {-1: p_under, 0: p_exact, 1: p_over}, cyclic=True)


def _move_backwards(belief: Any, shift: int, p_under: float, p_exact: float,
                    p_over: float) -> Any:
    return hist.move(belief, -int(shift), {1: p_under, 0: p_exact, -1: p_over}, cyclic=True)


def _move_exact(belief: Any, shift: int, p_under: float, p_exact: float, p_over: float) -> Any:
    return np.roll(np.asarray(belief, float), int(shift))


def _move_hidden(rng: np.random.Generator) -> list[Case]:
    cases = []
    for i in range(3):
        under, over = (float(v) for v in rng.uniform(0.02, 0.2, 2))
        cases.append(Case(f"random {i}", (_belief(rng, 10), int(rng.integers(1, 4)), under,
                                          1.0 - under - over, over)))
    return cases


move = Exercise(
    id="lab07.move", function="move", title="Move: shift and blur",
    reference=_move, points=2,
    public=(Case("one cell, the textbook's noise", (np.eye(10)[2], 1, 0.1, 0.8, 0.1)),
            Case("three cells round the ring", (np.array([0.0] * 8 + [0.5, 0.5]), 3, 0.2, 0.7,
                                                0.1))),
    hidden=_move_hidden, rtol=1e-9, atol=1e-12,
    diagnostics=(
        Diagnostic("moved the wrong way", _move_backwards,
                   "a robot that moves +shift cells takes its belief to higher indices: "
                   "bel'(x) = Σ p(k) bel(x − shift − k)"),
        Diagnostic("the motion noise left out", _move_exact,
                   "spread the belief: p_under to shift − 1, p_exact to shift, p_over to "
                   "shift + 1"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- the odometry control

def _control(odom_previous: Any, odom_current: Any) -> Any:
    return models.odometry_control(odom_previous, odom_current)


def _control_degrees(odom_previous: Any, odom_current: Any) -> Any:
    u = models.odometry_control(odom_previous, odom_current)
    return np.array([math.degrees(u[0]), u[1], math.degrees(u[2])])


def _control_atan_swapped(odom_previous: Any, odom_current: Any) -> Any:
    a, b = (np.asarray(p, float) for p in (odom_previous, odom_current))
    dx, dy = b[0] - a[0], b[1] - a[1]
    trans = math.hypot(dx, dy)
    rot1 = 0.0 if trans < models.IN_PLACE_TRANSLATION else \
        float(geometry.wrap_angle(math.atan2(dx, dy) - a[2]))
    return np.array([rot1, trans, float(geometry.wrap_angle(b[2] - a[2] - rot1))])


def _control_unwrapped(odom_previous: Any, odom_current: Any) -> Any:
    a, b = (np.asarray(p, float) for p in (odom_previous, odom_current))
    dx, dy = b[0] - a[0], b[1] - a[1]
    trans = math.hypot(dx, dy)
    rot1 = 0.0 if trans < models.IN_PLACE_TRANSLATION else math.atan2(dy, dx) - a[2]
    return np.array([rot1, trans, b[2] - a[2] - rot1])


def _control_no_spot_rule(odom_previous: Any, odom_current: Any) -> Any:
    a, b = (np.asarray(p, float) for p in (odom_previous, odom_current))
    rot1 = float(geometry.wrap_angle(math.atan2(b[1] - a[1], b[0] - a[0]) - a[2]))
    return np.array([rot1, math.hypot(b[0] - a[0], b[1] - a[1]),
                     float(geometry.wrap_angle(b[2] - a[2] - rot1))])


def _control_hidden(rng: np.random.Generator) -> list[Case]:
    """A drive whose heading and direction of travel cross ±π (δrot1 and δrot2 both need
    wrapping), a move of a few millimetres (a turn on the spot), and two random steps."""
    def step(a: list[float], heading: float, length: float, turn: float) -> list[float]:
        return [a[0] + length * math.cos(heading), a[1] + length * math.sin(heading),
                float(geometry.wrap_angle(a[2] + turn))]

    def start(theta: float) -> list[float]:
        return [float(rng.uniform(-5, 5)), float(rng.uniform(-5, 5)), theta]

    side = float(rng.choice([-1.0, 1.0]))
    a0 = start(side * (math.pi - float(rng.uniform(0.02, 0.3))))
    # travelling just across ±π from the heading, and turning through ±π on the way
    b0 = step(a0, side * (math.pi + float(rng.uniform(0.05, 0.3))), float(rng.uniform(0.1, 0.5)),
              side * float(rng.uniform(0.35, 0.8)))
    a1 = start(float(rng.uniform(-3, 3)))
    b1 = step(a1, float(rng.uniform(-math.pi, math.pi)), float(rng.uniform(0.002, 0.008)),
              float(rng.uniform(-1, 1)))
    cases = [Case("random 0", (a0, b0)), Case("random 1", (a1, b1))]
    for i in (2, 3):
        a = start(float(rng.uniform(-3, 3)))
        cases.append(Case(f"random {i}", (a, step(a, float(rng.uniform(-math.pi, math.pi)),
                                                  float(rng.uniform(0.05, 0.5)),
                                                  float(rng.uniform(-1, 1))))))
    return cases


odometry_control = Exercise(
    id="lab07.odometry_control", function="odometry_control",
    title="The odometry motion model's control", reference=_control, points=2,
    public=(Case("diagonal, a quarter turn", ([0.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2])),
            Case("a turn on the spot", ([2.0, 1.0, 0.3], [2.0, 1.0, 0.8])),
            Case("across ±π", ([1.0, 2.0, 3.0], [0.7, 2.05, -3.1])),
            Case("driving north-west", ([0.0, 0.0, 2.0], [-0.2, 0.45, 2.1]))),
    hidden=_control_hidden, rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("degrees", _control_degrees, "δrot1 and δrot2 in radians, as every angle"),
        Diagnostic("atan2(dx, dy)", _control_atan_swapped,
                   "the direction of travel is atan2(Δy, Δx): y first"),
        Diagnostic("rotations not wrapped", _control_unwrapped,
                   "wrap δrot1 and δrot2 to [-π, π): a small turn across ±π is not ±2π"),
        Diagnostic("a move under 1 cm not taken as a turn on the spot", _control_no_spot_rule,
                   "when δtrans < 0.01 m the direction of travel means nothing (it is noise): "
                   "δrot1 = 0 and the whole turn goes into δrot2, as Nav2 does"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- likelihood field weights

def _field(distance: Any, resolution: float, origin: Any, max_distance: float) -> Any:
    d = np.asarray(distance, dtype=float)
    return LikelihoodField(float(resolution), np.array([origin[0], origin[1], 0.0]),
                           d == 0, d > 0, d, float(max_distance))


def _log_weights(poses: Any, endpoints: Any, distance: Any, resolution: float, origin: Any,
                 z_hit: float, z_rand: float, sigma_hit: float, range_max: float) -> Any:
    field = _field(distance, resolution, origin, float(np.max(distance)))
    model = LikelihoodFieldModel(z_hit, z_rand, sigma_hit, "product")
    return likelihood_field_weights(poses, endpoints, field, model, range_max, method="numpy")


def _pz(poses: Any, endpoints: Any, distance: Any, resolution: float, origin: Any,
        z_hit: float, z_rand: float, sigma_hit: float, range_max: float, *,
        rotate: bool = True, off_grid: str = "largest", transposed: bool = False) -> Any:
    """Every beam's p_k, shape (N, M); the mistakes' variants by keyword: endpoints not
    rotated by the particle's θ, an off-grid endpoint taken from the nearest edge cell
    (``off_grid="edge"``), the distance looked up as ``distance[col, row]``."""
    p = np.asarray(poses, float).reshape(-1, 3)
    e = np.asarray(endpoints, float)
    d = np.asarray(distance, float)
    th = p[:, 2:3] if rotate else np.zeros((len(p), 1))
    x = p[:, 0:1] + np.cos(th) * e[None, :, 0] - np.sin(th) * e[None, :, 1]
    y = p[:, 1:2] + np.sin(th) * e[None, :, 0] + np.cos(th) * e[None, :, 1]
    col = np.floor((x - origin[0]) / resolution).astype(int)
    row = np.floor((y - origin[1]) / resolution).astype(int)
    if transposed:
        row, col = col, row
    inside = (row >= 0) & (row < d.shape[0]) & (col >= 0) & (col < d.shape[1])
    edge = d[row.clip(0, d.shape[0] - 1), col.clip(0, d.shape[1] - 1)]
    dist = edge if off_grid == "edge" else np.where(inside, edge, d.max())
    return z_hit * np.exp(-dist ** 2 / (2 * sigma_hit ** 2)) + z_rand / range_max


def _log_weights_product(*args: Any) -> Any:
    with np.errstate(divide="ignore"):
        return np.log(np.prod(_pz(*args), axis=1))


def _log_weights_unrotated(poses: Any, endpoints: Any, distance: Any, resolution: float,
                           origin: Any, z_hit: float, z_rand: float, sigma_hit: float,
                           range_max: float) -> Any:
    return np.sum(np.log(_pz(poses, endpoints, distance, resolution, origin, z_hit, z_rand,
                             sigma_hit, range_max, rotate=False)), axis=1)


def _log_weights_edge(*args: Any) -> Any:
    return np.sum(np.log(_pz(*args, off_grid="edge")), axis=1)


def _log_weights_transposed(*args: Any) -> Any:
    return np.sum(np.log(_pz(*args, transposed=True)), axis=1)


def _room(n: int = 40, resolution: float = 0.1) -> Any:
    from scipy.ndimage import distance_transform_edt

    occupied = np.zeros((n, n), dtype=bool)
    occupied[[0, -1], :] = occupied[:, [0, -1]] = True
    occupied[n // 2, n // 4:n // 2] = True
    return np.minimum(distance_transform_edt(~occupied) * resolution, 1.0)


def _scan_of(n_beams: int, reach: float) -> Any:
    angles = np.linspace(-np.pi, np.pi, n_beams, endpoint=False)
    return np.column_stack([reach * np.cos(angles), reach * np.sin(angles)])


def _weights_hidden(rng: np.random.Generator) -> list[Case]:
    """Twenty particles per case anywhere in the room, headings near ±π among them, scans
    that reach off the grid; the first case has a few hundred sharp beams (a lidar's worth,
    σ 5 cm), whose product underflows to 0 for every particle that does not fit."""
    d = _room()
    cases = []
    for i in range(3):
        poses = np.column_stack([rng.uniform(0.5, 3.5, 20), rng.uniform(0.5, 3.5, 20),
                                 rng.uniform(-np.pi, np.pi, 20)])
        poses[:2, 2] = [np.pi - rng.uniform(0, 0.1), -np.pi + rng.uniform(0, 0.1)]
        if i == 0:
            cases.append(Case(f"random {i}", (poses, _scan_of(int(rng.integers(300, 400)),
                                                              float(rng.uniform(1.6, 1.9))),
                                              d, 0.1, (0.0, 0.0), 0.95, 0.001, 0.05, 30.0)))
            continue
        cases.append(Case(f"random {i}", (poses, _scan_of(int(rng.integers(30, 80)),
                                                          float(rng.uniform(1.5, 1.9))),
                                          d, 0.1, (0.0, 0.0), 0.5, 0.5, 0.2, 12.0)))
    return cases


_ROOM = _room()
_POSES = np.array([[2.0, 2.0, 0.0], [1.0, 3.0, 1.2], [3.2, 0.8, -2.5]])

log_likelihoods = Exercise(
    id="lab07.log_likelihoods", function="log_likelihoods",
    title="Likelihood-field log-weights", reference=_log_weights, points=3,
    public=(Case("three particles, 36 beams", (_POSES, _scan_of(36, 1.5), _ROOM, 0.1, (0.0, 0.0),
                                               0.5, 0.5, 0.2, 12.0)),
            Case("360 beams off the walls", (_POSES, _scan_of(360, 1.9), _ROOM, 0.1,
                                             (0.0, 0.0), 0.95, 0.001, 0.05, 30.0))),
    hidden=_weights_hidden, rtol=1e-9, atol=1e-9,
    diagnostics=(
        Diagnostic("likelihoods multiplied until they underflow", _log_weights_product,
                   "sum the logs of the beams' probabilities: a product of hundreds of small "
                   "numbers underflows to 0 (log 0 = −inf)"),
        Diagnostic("beam angles in the wrong frame", _log_weights_unrotated,
                   "the endpoints are in the robot's frame: rotate them by each particle's θ "
                   "before adding its position"),
        Diagnostic("off-grid endpoints read from the edge cell", _log_weights_edge,
                   "an endpoint off the grid is not in the nearest edge cell: it counts as "
                   "the largest distance in the field (distance.max())"),
        Diagnostic("row and column swapped", _log_weights_transposed,
                   "the grid is indexed distance[row, col] with row from y and col from x: "
                   "row = floor((y − origin_y) / resolution)"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- normalising, ESS

def _normalize(log_weights: Any) -> Any:
    return pf.normalize_log_weights(log_weights)


def _normalize_naive(log_weights: Any) -> Any:
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        w = np.exp(np.asarray(log_weights, float))
        return w / w.sum()


def _normalize_unnormalised(log_weights: Any) -> Any:
    lw = np.asarray(log_weights, float)
    return np.exp(lw - lw.max())


def _normalize_from_min(log_weights: Any) -> Any:
    lw = np.asarray(log_weights, float)
    with np.errstate(invalid="ignore", over="ignore"):
        w = np.exp(lw - lw.min())
        return w / w.sum()


def _normalize_hidden(rng: np.random.Generator) -> list[Case]:
    """Log-weights of scans whose every likelihood underflows (all below −745) lying within
    a few units of each other, so that several particles keep weight; a set with one
    particle more than 709 below the best; and a set of ordinary size."""
    n = [int(v) for v in rng.integers(3, 20, 3)]
    close = float(rng.uniform(-3000, -800)) - rng.uniform(0, 6, n[0])
    spread = rng.uniform(-600, -500, n[1])
    spread[int(rng.integers(n[1]))] = float(rng.uniform(-3000, -1300))
    small = float(rng.uniform(-60, -5)) - rng.uniform(0, 4, n[2])
    return [Case("random 0", (close,)), Case("random 1", (spread,)), Case("random 2", (small,))]


normalize_log_weights = Exercise(
    id="lab07.normalize_log_weights", function="normalize_log_weights",
    title="Weights from log-weights", reference=_normalize, points=2,
    public=(Case("three small numbers", (np.log([0.2, 0.3, 0.5]),)),
            Case("sixty beams' worth", (np.array([-1380.0, -1381.5, -1379.2, -1400.0]),)),
            Case("one particle that fits nothing", (np.array([-250.0, -1200.0, -251.3]),))),
    hidden=_normalize_hidden, rtol=1e-9, atol=1e-12,
    diagnostics=(
        Diagnostic("exp of the log-weights as they are", _normalize_naive,
                   "subtract the largest log-weight before exp: exp(−1380) is 0 in doubles"),
        Diagnostic("weights not normalised", _normalize_unnormalised,
                   "divide by the sum: the weights must add up to 1"),
        Diagnostic("the smallest log-weight subtracted", _normalize_from_min,
                   "subtract the largest log-weight, not the smallest: exp of a difference "
                   "above 709 overflows to inf (and inf / inf is NaN)"),
    ),
    blocked=_BLOCKED,
)


def _should_resample(weights: Any, threshold: float) -> bool:
    w = np.asarray(weights, float)
    return bool(pf.effective_sample_size(w) < threshold * len(w))


def _always(weights: Any, threshold: float) -> bool:
    return True


def _ess_against_the_share(weights: Any, threshold: float) -> bool:
    w = np.asarray(weights, float)
    return bool(1.0 / np.sum(w ** 2) < threshold)


def _skewed(rng: np.random.Generator) -> Any:
    w = rng.random(40) ** int(rng.integers(1, 8))
    return w / w.sum()


def _resample_hidden(rng: np.random.Generator) -> list[Case]:
    """Nearly even weights (N_eff near N: no resampling), a few heavy particles (N_eff of a
    few: resample), and two random spreads."""
    even = 1.0 + 0.3 * rng.random(int(rng.integers(30, 80)))
    heavy = np.full(int(rng.integers(30, 80)), 0.001)
    heavy[rng.choice(len(heavy), int(rng.integers(2, 5)), replace=False)] = 1.0
    cases = [Case("random 0", (even / even.sum(), float(rng.uniform(0.3, 0.7)))),
             Case("random 1", (heavy / heavy.sum(), float(rng.uniform(0.3, 0.7))))]
    return cases + [Case(f"random {i}", (_skewed(rng), float(rng.uniform(0.3, 0.7))))
                    for i in (2, 3)]


should_resample = Exercise(
    id="lab07.should_resample", function="should_resample",
    title="Resample only when the effective sample size drops", reference=_should_resample,
    points=1,
    public=(Case("even weights", (np.full(100, 0.01), 0.5)),
            Case("one heavy particle", (np.array([0.9] + [0.1 / 99] * 99), 0.5)),
            Case("half the particles dead, N_eff exactly at the threshold",
                 (np.array([1 / 64] * 64 + [0.0] * 64), 0.5)),
            Case("a mild spread", (np.linspace(1, 2, 50) / np.linspace(1, 2, 50).sum(), 0.5))),
    hidden=_resample_hidden,
    # An answer of one bit cannot tell every mistake apart case by case: each hint says
    # what is true of the case (resampling due or not) and the mistakes that give its answer.
    diagnostics=(
        Diagnostic("resampling every step", _always,
                   "here N_eff = 1 / Σ w² is not below threshold · N, so keep the particles: "
                   "resample only when N_eff < threshold · N — resampling every step throws "
                   "particles away for nothing (and so does the comparison turned round, "
                   "N_eff > threshold · N)"),
        Diagnostic("N_eff compared with the share itself", _ess_against_the_share,
                   "here N_eff = 1 / Σ w² is below threshold · N, so resample: threshold is "
                   "a share of the particles — compare N_eff with threshold · N, N the number "
                   "of particles — and resample when N_eff is the smaller (<, not >)"),
    ),
    blocked=_BLOCKED,
)


# ---------------------------------------------------------------- low-variance resampling

class _Offset:
    """Stands in for the generator: its one uniform draw is the given offset r."""

    def __init__(self, r: float) -> None:
        self.r = r

    def uniform(self, low: float, high: float) -> float:
        return self.r


def _resample(weights: Any, n: int, r: float) -> Any:
    return pf.low_variance_resample(weights, int(n), _Offset(float(r)))  # type: ignore[arg-type]


def _resample_left(weights: Any, n: int, r: float) -> Any:
    w = np.asarray(weights, float)
    c = np.cumsum(w / w.sum())
    return np.searchsorted(c, r + np.arange(n) / n, side="left")


def _resample_unnormalised(weights: Any, n: int, r: float) -> Any:
    c = np.cumsum(np.asarray(weights, float))
    return np.searchsorted(c, r + np.arange(n) / n, side="right")


def _lv_hidden(rng: np.random.Generator) -> list[Case]:
    """Weights as they come (not normalised) in every case. The first: eight particles with
    whole-number weights summing to 16 (dead ones among them) and sixteen pointers from
    r = 0 — every cumulative weight is a multiple of 1/16 in binary, so pointers land on the
    boundaries exactly, whichever correct way they are computed. Then two random sets."""
    counts = rng.multinomial(16, np.full(8, 1 / 8)).astype(float)
    cases = [Case("random 0", (counts, 16, 0.0))]
    for i in (1, 2):
        w = rng.random(12) ** 3
        cases.append(Case(f"random {i}", (w * float(rng.uniform(2.0, 40.0)) / w.sum(), 20,
                                          float(rng.uniform(0, 1 / 20)))))
    return cases


low_variance_resample = Exercise(
    id="lab07.low_variance_resample", function="low_variance_resample",
    title="The low-variance sampler", reference=_resample, points=2,
    public=(Case("the textbook's comb", (np.array([1.0, 2.0, 3.0, 4.0]), 4, 0.07)),
            Case("pointers on the edges", (np.array([1.0, 1.0, 1.0, 1.0]), 8, 0.0)),
            Case("dead particles", (np.array([0.0, 0.5, 0.0, 0.3, 0.2]), 6, 0.1))),
    hidden=_lv_hidden,
    diagnostics=(
        Diagnostic("a pointer on a boundary taken to the left", _resample_left,
                   "a pointer equal to a cumulative weight belongs to the next particle: "
                   "c_{i−1} <= u < c_i (searchsorted side='right'; in the book's loop, move "
                   "on while u >= c), so that a dead particle (weight 0) is never drawn"),
        Diagnostic("weights not normalised first", _resample_unnormalised,
                   "the weights need not sum to 1: divide by their sum before the cumulative "
                   "sum, or the pointers (all below 1) cover only part of it"),
    ),
    blocked=_BLOCKED,
)


SPEC = LabSpec(name="lab07", title="Localization",
               exercises=(sense, move, odometry_control, log_likelihoods,
                          normalize_log_weights, should_resample, low_variance_resample))

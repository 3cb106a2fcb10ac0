"""The people's rules of :mod:`sim.simulation`, compiled (numba).

One call decides where every person walks for the next tenth of a second, person after
person in order, as ``Simulation._walk_reference`` (the readable Python, kept as the
reference) does: the same arithmetic, operation for operation and in the same order, so the
two give the same velocities and states to the last bit (``tests/sim/test_walk.py`` runs both
side by side). Three things make that hold:

* ``math.hypot`` here is CPython's own algorithm (:func:`hypot`), not the C library's, whose
  last bit differs from Python's in about one call in two hundred;
* Python's ``min``/``max`` keep their first argument on a tie and skip a NaN the same way
  the explicit comparisons below do;
* the rules that draw random numbers (a new walking speed at each route point) are split off:
  :func:`arrive` says who needs one, the caller draws them in order, then :func:`walk` runs.

The robots' outlines are computed by the caller with ``kit.geometry.transform_points`` (numpy's
matrix product, which may use fused multiply-adds): they are inputs here, never recomputed.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from sim.world import _along_walls, _free_distance_one

__all__ = ["arrive", "hypot", "walk"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]

PERSON_RADIUS = 0.25
WALK_PERIOD = 0.1
ALCOVE_REACH = 10.0
_T27 = 134217729.0          # 2**27 + 1, Veltkamp's splitting constant
_DBL_MIN = 2.2250738585072014e-308
_NAN = math.hypot(math.nan, 0.0)
"""The NaN CPython's hypot returns: its sign bit is set on 3.10 (``Py_NAN`` was
``Py_HUGE_VAL * 0.``) and clear from 3.11, so it is taken from the interpreter running (numba
keeps it as a constant; its cache is kept per Python version)."""


@njit(cache=True)
def hypot(x: float, y: float) -> float:  # pragma: no cover - compiled
    """``math.hypot(x, y)`` as CPython 3.10–3.13 computes it (``vector_norm`` in
    ``Modules/mathmodule.c``): scaled by a power of two, squares split exactly (Veltkamp),
    compensated sums and one differential correction of the square root. A test compares it
    with ``math.hypot`` on millions of random pairs."""
    ax, ay = abs(x), abs(y)
    mx = 0.0
    if ax > mx:
        mx = ax
    if ay > mx:
        mx = ay
    if math.isinf(mx):
        return mx
    if math.isnan(x) or math.isnan(y):
        return _NAN
    if mx == 0.0:
        return mx
    unscale = 1.0
    _, max_e = math.frexp(mx)
    if max_e < -1023:                  # subnormal: make them normal first
        ax, ay, mx, unscale = ax / _DBL_MIN, ay / _DBL_MIN, mx / _DBL_MIN, _DBL_MIN
        _, max_e = math.frexp(mx)
    scale = math.ldexp(1.0, -max_e)
    csum, frac1, frac2, frac3 = 1.0, 0.0, 0.0, 0.0
    for v in (ax, ay):
        v = v * scale
        t = v * _T27
        hi = t - (t - v)
        lo = v - hi
        v = hi * hi
        old = csum
        csum += v
        frac1 += (old - csum) + v
        v = 2.0 * hi * lo
        old = csum
        csum += v
        frac2 += (old - csum) + v
        frac3 += lo * lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2 + frac3))
    t = h * _T27
    hi = t - (t - h)
    lo = h - hi
    v = -hi * hi
    old = csum
    csum += v
    frac1 += (old - csum) + v
    v = -2.0 * hi * lo
    old = csum
    csum += v
    frac2 += (old - csum) + v
    v = -lo * lo
    old = csum
    csum += v
    frac3 += (old - csum) + v
    v = csum - 1.0 + (frac1 + frac2 + frac3)
    return unscale * ((h + v / (2.0 * h)) / scale)


@njit(cache=True)
def _nearest_on_polygon(x: float, y: float, polygon: FloatArray, n: int
                        ) -> tuple[float, float, float]:  # pragma: no cover - compiled
    best, bx, by = math.inf, x, y
    for i in range(n):
        x0, y0 = polygon[i, 0], polygon[i, 1]
        j = (i + 1) % n
        x1, y1 = polygon[j, 0], polygon[j, 1]
        ex, ey = x1 - x0, y1 - y0
        length2 = ex * ex + ey * ey
        if length2 <= 0.0:
            t = 0.0
        else:
            t = ((x - x0) * ex + (y - y0) * ey) / length2
            t = t if t > 0.0 else 0.0          # max(0.0, t)
            t = t if t < 1.0 else 1.0          # min(1.0, t)
        d = hypot(x - x0 - t * ex, y - y0 - t * ey)
        if d < best:
            best, bx, by = d, x0 + t * ex, y0 + t * ey
    return best, bx, by


@njit(cache=True)
def _keep_clear(px: float, py: float, vx: float, vy: float, robots: FloatArray,
                velocities: FloatArray, outlines: FloatArray, corners: IntArray
                ) -> tuple[float, float]:  # pragma: no cover - compiled
    for k in range(robots.shape[0]):
        rx, ry = robots[k, 0], robots[k, 1]
        if hypot(px - rx, py - ry) >= 4.0:
            continue
        gap, qx, qy = _nearest_on_polygon(px, py, outlines[k], corners[k])
        if 1e-6 < gap < 3.0:
            ax, ay = (px - qx) / gap, (py - qy) / gap
            clearance = gap - PERSON_RADIUS
            coming = velocities[k, 0] * ax + velocities[k, 1] * ay
            coming = 0.0 if 0.0 > coming else coming          # max(coming, 0.0)
            room = clearance - 0.2
            room = 0.0 if 0.0 > room else room                # max(room, 0.0)
            allowed = math.sqrt(2.0 * 1.0 * room) - coming
            toward = -(vx * ax + vy * ay)
            if toward > allowed:
                cut = toward - allowed
                vx, vy = vx + ax * cut, vy + ay * cut
    return vx, vy


@njit(cache=True)
def _room(segments: FloatArray, x: float, y: float, dx: float, dy: float, reach: float
          ) -> float:  # pragma: no cover - compiled
    return _free_distance_one(segments, x, y, dx, dy, reach)


@njit(cache=True)
def _step_round_robots(segments: FloatArray, px: float, py: float, vx: float, vy: float,
                       ux: float, uy: float, pace: float, robots: FloatArray
                       ) -> tuple[float, float]:  # pragma: no cover - compiled
    for k in range(robots.shape[0]):
        ax, ay = px - robots[k, 0], py - robots[k, 1]
        gap = hypot(ax, ay)
        if 1e-6 < gap < 1.5:
            push = (1.5 - gap) / gap * (2.0 if gap < 0.9 else 1.0)
            vx, vy = vx + ax * push, vy + ay * push
            if -(ax * ux + ay * uy) > 0.5 * gap:
                away = -1.0 if ux * ay - uy * ax > 0.0 else 1.0
                if _room(segments, px, py, uy * away, -ux * away, 1.5) < 0.8 and \
                        0.8 <= _room(segments, px, py, -uy * away, ux * away, 1.5):
                    away = -away
                side = pace * (1.5 - gap) / 1.5 * away
                vx, vy = vx + uy * side, vy - ux * side
    return vx, vy


@njit(cache=True)
def _step_round_walls(segments: FloatArray, px: float, py: float, vx: float, vy: float,
                      ux: float, uy: float, pace: float, dist: float
                      ) -> tuple[float, float]:  # pragma: no cover - compiled
    reach = dist if dist < 0.8 else 0.8                       # min(0.8, dist)
    if reach <= 0.0:
        return vx, vy
    edge = PERSON_RADIUS - 0.05
    left = _free_distance_one(segments, px - uy * edge, py + ux * edge, ux, uy, reach)
    right = _free_distance_one(segments, px + uy * edge, py - ux * edge, ux, uy, reach)
    centre = _free_distance_one(segments, px, py, ux, uy, reach)
    ahead = left
    if right < ahead:
        ahead = right
    if centre < ahead:
        ahead = centre
    if ahead >= reach:
        return vx, vy
    if (left < reach) == (right < reach):
        away = 1.0 if _room(segments, px, py, uy, -ux, 1.5) > \
            _room(segments, px, py, -uy, ux, 1.5) else -1.0
    else:
        away = 1.0 if left < right else -1.0
    side = pace * (1.0 - ahead / reach) * away
    return vx + uy * side, vy - ux * side


@njit(cache=True)
def _pass_people(i: int, speed: float, positions: FloatArray, px: float, py: float,
                 vx: float, vy: float, ux: float, uy: float
                 ) -> tuple[float, float]:  # pragma: no cover - compiled
    for q in range(positions.shape[0]):
        if q == i:
            continue
        ax, ay = px - positions[q, 0], py - positions[q, 1]
        gap = hypot(ax, ay)
        if 1e-6 < gap < 1.5:
            if -(ax * ux + ay * uy) > 0.7 * gap:
                side = 0.5 * speed * (1.5 - gap) / 1.5
                vx, vy = vx + uy * side, vy - ux * side
            room = gap - 2 * PERSON_RADIUS - 0.1
            room = 0.0 if 0.0 > room else room                # max(room, 0.0)
            allowed = math.sqrt(2.0 * 1.0 * room)
            toward = -(vx * ax + vy * ay) / gap
            if toward > allowed:
                cut = toward - allowed
                vx, vy = vx + ax / gap * cut, vy + ay / gap * cut
    return vx, vy


@njit(cache=True)
def _slide(segments: FloatArray, px: float, py: float, vx: float, vy: float
           ) -> tuple[float, float]:  # pragma: no cover - compiled
    out = _along_walls(segments, px, py, vx, vy, PERSON_RADIUS + 0.03)
    return out[0], out[1]


@njit(cache=True)
def _at_most_walking_speed(vx: float, vy: float) -> tuple[float, float]:  # pragma: no cover
    speed = hypot(vx, vy)
    if speed > 1.5:
        return vx * 1.5 / speed, vy * 1.5 / speed
    return vx, vy


@njit(cache=True)
def _in_doorway(px: float, py: float, fx: float, fy: float, bx: float, by: float
                ) -> bool:  # pragma: no cover - compiled
    return hypot(bx - px, by - py) <= hypot(bx - fx, by - fy)


@njit(cache=True)
def _crosses(segments: FloatArray, ax: float, ay: float, bx: float, by: float
             ) -> bool:  # pragma: no cover - compiled
    length = hypot(bx - ax, by - ay)
    if length == 0.0:
        return False
    dx, dy = (bx - ax) / length, (by - ay) / length
    return _free_distance_one(segments, ax, ay, dx, dy, length) < length


@njit(cache=True)
def _alcove_for(i: int, px: float, py: float, robots: FloatArray, alcoves: FloatArray,
                alcove: IntArray, segments: FloatArray) -> int:  # pragma: no cover
    if alcoves.shape[0] == 0 or robots.shape[0] == 0:
        return -1
    nearest, nearest_d = 0, hypot(px - robots[0, 0], py - robots[0, 1])
    for k in range(1, robots.shape[0]):            # min(robots, key=distance): the first
        d = hypot(px - robots[k, 0], py - robots[k, 1])
        if d < nearest_d:
            nearest, nearest_d = k, d
    rx, ry = robots[nearest, 0], robots[nearest, 1]
    gap = hypot(px - rx, py - ry)
    if gap > 1e-9:
        ax, ay = (px - rx) / gap, (py - ry) / gap
    else:
        ax, ay = 0.0, 0.0
    best, chosen = ALCOVE_REACH, -1
    for a in range(alcoves.shape[0]):
        taken = False
        for q in range(alcove.shape[0]):
            if alcove[q] == a:
                taken = True
                break
        if taken:
            continue
        fx, fy, bx, by = alcoves[a, 0], alcoves[a, 1], alcoves[a, 2], alcoves[a, 3]
        if _in_doorway(px, py, fx, fy, bx, by):
            fx, fy = bx, by
        d = hypot(fx - px, fy - py)
        if d < best and (fx - px) * ax + (fy - py) * ay > -0.3 and \
                not _crosses(segments, px, py, fx, fy):
            best, chosen = d, a
    return chosen


@njit(cache=True)
def _no_way_past(segments: FloatArray, px: float, py: float, ux: float, uy: float,
                 robots: FloatArray, velocities: FloatArray, widths: FloatArray
                 ) -> bool:  # pragma: no cover - compiled
    for k in range(robots.shape[0]):
        rx, ry = robots[k, 0], robots[k, 1]
        d = hypot(rx - px, ry - py)
        if d >= 3.5 or (rx - px) * ux + (ry - py) * uy <= 0.5 * d:
            continue
        rvx, rvy = velocities[k, 0], velocities[k, 1]
        if (rvx * (px - rx) + rvy * (py - ry)) / d < -0.1:
            continue
        across = _room(segments, px, py, -uy, ux, 3.0) + _room(segments, px, py, uy, -ux, 3.0)
        other = _room(segments, rx, ry, -uy, ux, 3.0) + _room(segments, rx, ry, uy, -ux, 3.0)
        if other < across:                            # min over (person, robot): the first
            across = other
        if across - widths[k] < 2 * PERSON_RADIUS + 0.3:
            return True
    return False


@njit(cache=True)
def _step_aside(i: int, speed: float, px: float, py: float, alcoves: FloatArray,
                alcove: IntArray, stage: IntArray, robots: FloatArray, velocities: FloatArray,
                outlines: FloatArray, corners: IntArray
                ) -> tuple[float, float]:  # pragma: no cover - compiled
    a = alcove[i]
    fx, fy, bx, by = alcoves[a, 0], alcoves[a, 1], alcoves[a, 2], alcoves[a, 3]
    if stage[i] == 1 and _in_doorway(px, py, fx, fy, bx, by):
        stage[i] = 2
    if stage[i] == 3:
        for k in range(robots.shape[0]):
            rx, ry = robots[k, 0], robots[k, 1]
            rvx, rvy = velocities[k, 0], velocities[k, 1]
            d = hypot(fx - rx, fy - ry)
            closing = ((fx - rx) * rvx + (fy - ry) * rvy) / d if d > 1e-9 else 0.0
            if _nearest_on_polygon(px, py, outlines[k], corners[k])[0] < 2.0 or \
                    (d < 8.0 and closing > 0.05) or (d < 6.0 and closing > -0.05):
                return 0.0, 0.0
        stage[i] = 4
    if stage[i] == 2:
        gx, gy = bx, by
    else:
        gx, gy = fx, fy
    dist = hypot(gx - px, gy - py)
    if dist < (0.1 if stage[i] == 2 else 0.2):
        if stage[i] == 4:
            alcove[i], stage[i] = -1, 0
        else:
            stage[i] += 1
        return 0.0, 0.0
    pace = 2.0 * dist if 2.0 * dist < speed else speed     # min(speed, 2.0 * dist)
    return (gx - px) / dist * pace, (gy - py) / dist * pace


@njit(cache=True)
def _walk_aside(i: int, speed: float, px: float, py: float, positions: FloatArray,
                segments: FloatArray, alcoves: FloatArray, alcove: IntArray, stage: IntArray,
                robots: FloatArray, velocities: FloatArray, outlines: FloatArray,
                corners: IntArray) -> tuple[float, float]:  # pragma: no cover - compiled
    vx, vy = _step_aside(i, speed, px, py, alcoves, alcove, stage, robots, velocities,
                         outlines, corners)
    vx, vy = _pass_people(i, speed, positions, px, py, vx, vy, 0.0, 0.0)
    vx, vy = _slide(segments, px, py, vx, vy)
    vx, vy = _keep_clear(px, py, vx, vy, robots, velocities, outlines, corners)
    return _at_most_walking_speed(vx, vy)


@njit(cache=True)
def arrive(positions: FloatArray, routes: FloatArray, route_start: IntArray,
           route_length: IntArray, alcove: IntArray, target: IntArray, direction: IntArray
           ) -> IntArray:  # pragma: no cover - compiled
    """People at their route's next point (within 0.3 m) turn to the one after it (back along
    the route at its ends); returns who need a new walking speed, in order (the caller draws
    them). People stepping aside are left alone."""
    new_speed = np.zeros(positions.shape[0], dtype=np.bool_)
    for i in range(positions.shape[0]):
        if alcove[i] >= 0:
            continue
        px, py = positions[i, 0], positions[i, 1]
        g = route_start[i] + target[i]
        if hypot(routes[g, 0] - px, routes[g, 1] - py) < 0.3:
            if route_length[i] > 1:
                nxt = target[i] + direction[i]
                if not 0 <= nxt < route_length[i]:
                    direction[i] = -direction[i]
                    nxt = target[i] + direction[i]
                target[i] = nxt
            new_speed[i] = True
    return np.flatnonzero(new_speed)


@njit(cache=True)
def walk(positions: FloatArray, body_velocities: FloatArray, speed: FloatArray,
         routes: FloatArray, route_start: IntArray, route_length: IntArray, target: IntArray,
         direction: IntArray, blocked: FloatArray, alcove: IntArray, stage: IntArray,
         robots: FloatArray, velocities: FloatArray, outlines: FloatArray, corners: IntArray,
         widths: FloatArray, segments: FloatArray, alcoves: FloatArray, walkers: int
         ) -> FloatArray:  # pragma: no cover - compiled
    """Every walking person's velocity (P, 2) [m/s] for the next tenth of a second, and
    their states (``target``, ``direction``, ``blocked``, ``alcove``, ``stage``) updated in
    place.

    ``positions`` (P + B, 2): where the ``walkers`` = P walking people are, then the B
    bystanders (a scenario moves them; the walkers pass them as they pass each other);
    ``body_velocities`` (P, 2): how fast the walkers really move; ``routes`` (all routes'
    points stacked), ``route_start``, ``route_length``: each walker's route; ``robots``,
    ``velocities`` (R, 2): the robots' positions and world velocities; ``outlines``
    (R, K, 2) with ``corners`` (R,) used rows: their footprints in the world; ``widths``
    (R,): their footprints' widths; ``segments`` (M, 4): every wall; ``alcoves`` (A, 4):
    the world's alcoves.
    """
    n = walkers
    out = np.zeros((n, 2))
    has_alcoves = alcoves.shape[0] > 0
    for i in range(n):
        px, py = positions[i, 0], positions[i, 1]
        pace = speed[i]
        if alcove[i] >= 0:
            out[i, 0], out[i, 1] = _walk_aside(i, pace, px, py, positions, segments, alcoves,
                                               alcove, stage, robots, velocities, outlines,
                                               corners)
            continue
        g = route_start[i] + target[i]
        gx, gy = routes[g, 0], routes[g, 1]
        dist = hypot(gx - px, gy - py)
        if dist > 1e-9:
            vx, vy = (gx - px) / dist * pace, (gy - py) / dist * pace
            ux, uy = vx / pace, vy / pace
        else:
            vx = vy = ux = uy = 0.0
        if has_alcoves and _no_way_past(segments, px, py, ux, uy, robots, velocities, widths):
            chosen = _alcove_for(i, px, py, robots, alcoves, alcove, segments)
            if chosen >= 0:                 # step aside now, before meeting it
                alcove[i], stage[i], blocked[i] = chosen, 1, 0.0
                out[i, 0], out[i, 1] = _walk_aside(i, pace, px, py, positions, segments,
                                                   alcoves, alcove, stage, robots, velocities,
                                                   outlines, corners)
                continue
        vx, vy = _step_round_walls(segments, px, py, vx, vy, ux, uy, pace, dist)
        vx, vy = _step_round_robots(segments, px, py, vx, vy, ux, uy, pace, robots)
        vx, vy = _pass_people(i, pace, positions, px, py, vx, vy, ux, uy)
        vx, vy = _slide(segments, px, py, vx, vy)
        vx, vy = _keep_clear(px, py, vx, vy, robots, velocities, outlines, corners)
        near = False
        for k in range(robots.shape[0]):
            if hypot(px - robots[k, 0], py - robots[k, 1]) < 1.5:
                near = True
                break
        bvx, bvy = body_velocities[i, 0], body_velocities[i, 1]
        going = vx * ux + vy * uy
        really = bvx * ux + bvy * uy
        if really < going:                  # min(going, really)
            going = really
        held = near and dist > 1e-9 and going < 0.2 * pace
        # _give_way
        if not held:
            blocked[i] = 0.0
        else:
            blocked[i] += WALK_PERIOD
            chosen = _alcove_for(i, px, py, robots, alcoves, alcove, segments) \
                if blocked[i] >= 1.0 else -1
            if chosen >= 0:
                alcove[i], stage[i], blocked[i] = chosen, 1, 0.0
            elif blocked[i] >= 4.0 and route_length[i] > 1:
                direction[i] = -direction[i]
                t = target[i] + direction[i]
                t = t if t > 0 else 0                                 # max(t, 0)
                target[i] = t if t < route_length[i] - 1 else route_length[i] - 1
                blocked[i] = 0.0
        out[i, 0], out[i, 1] = _at_most_walking_speed(vx, vy)
    return out

"""The compiled scan caster leaves out the people its beams cannot meet: the ranges stay the
same to the bit as casting every beam against every disc."""

from __future__ import annotations

import math

import numpy as np

from sim.raycast import _beam_geometry, _cast_scan
from sim.world import load_world


def _every_disc(ox, oy, angles, segments, circles, people, step, max_range):
    """The caster's arithmetic, operation for operation, in plain Python (``math``'s cos and
    sin are the C library's, as the compiled code's are), with every wall and every disc
    tried for every beam and the nearest hit kept."""
    out = np.empty(len(angles))
    for i in range(len(angles)):
        px, py = float(ox[i]), float(oy[i])
        dx, dy = math.cos(float(angles[i])), math.sin(float(angles[i]))
        hits = [math.inf]
        for x1, y1, x2, y2 in segments.tolist():
            ex, ey = x2 - x1, y2 - y1
            denom = dx * ey - dy * ex
            if denom == 0.0:
                continue
            wx, wy = x1 - px, y1 - py
            t = (wx * ey - wy * ex) / denom
            u = (wx * dy - wy * dx) / denom
            if t > 1e-12 and 0.0 <= u <= 1.0:
                hits.append(t)
        for cx, cy, radius in circles.tolist() + people[step[i]].tolist():
            qx, qy = px - cx, py - cy
            beta = dx * qx + dy * qy
            gamma = (qx * qx + qy * qy) - radius * radius
            disc = beta * beta - gamma
            if gamma > 0.0 and disc >= 0.0:
                t = -beta - math.sqrt(disc)
                if t > 1e-12:
                    hits.append(t)
        best = min(hits)
        out[i] = best if best <= max_range else math.inf
    return out


def _scan(rng, n_people, speed, turn, beams=360):
    """A 10 Hz scan's beams from a lidar driving at ``speed`` and turning at ``turn`` through
    the office, with ``n_people`` discs per physics step, some of them just grazing (by a
    nanometre, in or out, or a tenth of a micrometre) the first or last beam of a step, on
    either side."""
    times = np.arange(12) * 0.01
    x0, y0, yaw0 = rng.uniform(3, 17), rng.uniform(2, 10), rng.uniform(-np.pi, np.pi)
    yaw = yaw0 + turn * times
    poses = np.column_stack([x0 + speed * times * np.cos(yaw), y0 + speed * times * np.sin(yaw),
                             np.arctan2(np.sin(yaw), np.cos(yaw))])
    ox, oy, angles, step = _beam_geometry(times, poses, 0.0, 1.0 / (10.0 * beams), beams,
                                          0.05, 0.0, -np.pi, 2 * np.pi / beams)
    people = np.empty((len(times), n_people, 3))
    people[..., 2] = 0.25
    people[..., 0] = x0 + rng.uniform(-6, 6, n_people)
    people[..., 1] = y0 + rng.uniform(-6, 6, n_people)
    people[:, :, :2] += rng.normal(0, 0.01, (len(times), n_people, 2)).cumsum(axis=0)
    for s in range(len(times)):   # a few discs grazing the first or last beam of their step
        beams_of_s = np.flatnonzero(step == s)
        for k in range(min(4, n_people) if len(beams_of_s) else 0):
            i = int(beams_of_s[0] if k % 2 else beams_of_s[-1])
            d, side = rng.uniform(0.5, 8), rng.choice([-1.0, 1.0])
            offset = 0.25 * (1.0 + rng.choice([-1e-9, 0.0, 1e-9, 1e-7]))
            c, sn = math.cos(angles[i]), math.sin(angles[i])
            people[s, k, :2] = (ox[i] + d * c - side * offset * sn,
                                oy[i] + d * sn + side * offset * c)
    return ox, oy, angles, step, people


def test_culled_people_change_no_range_to_the_bit():
    rng = np.random.default_rng(30)
    world = load_world("office")
    segments = np.ascontiguousarray(world.lidar_segments, dtype=np.float64)
    circles = np.array([[9.0, 6.0, 0.3]])
    compared = met = 0
    for n_people, speed, turn in [(5, 0.5, 0.2), (20, 1.0, -1.5), (20, 0.0, 0.0),
                                  (40, 0.3, 3.0), (1, 1.2, 0.0)]:
        for _ in range(4):
            ox, oy, angles, step, people = _scan(rng, n_people, speed, turn)
            fast = _cast_scan(ox, oy, angles, segments, circles, people, step, 12.0)
            reference = _every_disc(ox, oy, angles, segments, circles, people, step, 12.0)
            assert np.array_equal(fast.view(np.int64), reference.view(np.int64))
            without = _every_disc(ox, oy, angles, segments, circles, people[:, :0], step, 12.0)
            met += int(np.sum(reference != without))
            compared += len(angles)
    assert met > 0.05 * compared   # the people were in sight: many beams end on one


def test_beams_out_of_step_order_and_a_whole_scan_at_once_keep_every_disc_they_meet():
    """The caster takes any beams: steps in any order (blocks of one beam) and a scan taken
    at one instant (a depth camera: one wide wedge, nothing left out)."""
    rng = np.random.default_rng(31)
    segments = np.ascontiguousarray(load_world("office").lidar_segments, dtype=np.float64)
    no_circles = np.empty((0, 3))
    for _ in range(5):
        origins = np.column_stack([rng.uniform(1, 19, 300), rng.uniform(1, 11, 300)])
        angles = rng.uniform(-np.pi, np.pi, 300)
        people = rng.uniform(0, 20, (4, 6, 3))
        people[..., 2] = 0.25
        for step in (rng.integers(0, 4, 300), np.zeros(300, dtype=np.int64)):
            ox, oy = origins[:, 0].copy(), origins[:, 1].copy()
            fast = _cast_scan(ox, oy, angles, segments, no_circles, people, step, 12.0)
            reference = _every_disc(ox, oy, angles, segments, no_circles, people, step, 12.0)
            assert np.array_equal(fast.view(np.int64), reference.view(np.int64))

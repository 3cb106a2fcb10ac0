"""Nodes grouped into turns as Slamtec's SDK groups them, each turn judged for
plausibility, and a turn made into a counter-clockwise ``LaserScan``."""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

import numpy as np

from kit import msgs
from kit.drivers.rplidar._protocol import Node
from kit.geometry import wrap_angle


def angular_span_deg(angles_deg: Iterable[float]) -> float:
    """How far round a set of bearings goes: 360° minus the widest empty gap between them.

    >>> angular_span_deg([350.0, 355.0, 0.0, 90.0, 180.0, 270.0])
    270.0
    >>> angular_span_deg([10.0])
    0.0
    """
    a = np.sort(np.mod(np.fromiter(angles_deg, dtype=float), 360.0))
    if len(a) < 2:
        return 0.0
    gaps = np.diff(np.concatenate([a, [a[0] + 360.0]]))
    return float(360.0 - gaps.max())


@dataclass(frozen=True)
class Turn:
    """One complete turn: its nodes (from one start flag up to the next) and the times of
    its first node and of the start flag that ended it [s, on the driver's stamping clock:
    when they were measured, or arrived, as the caller of :meth:`TurnAssembler.push` says]."""

    nodes: tuple[Node, ...]
    started: float
    ended: float


def _steps_deg(angles: np.ndarray) -> np.ndarray:
    """Consecutive angle steps wrapped to [−180°, 180°)."""
    return (np.diff(angles) + 180.0) % 360.0 - 180.0


class TurnAssembler:
    """Nodes → complete, plausible turns.

    As Slamtec's SDK: a node with the start flag ends the turn in progress and begins a new
    one — wherever it falls: 351–359° on a real A1 — nodes before the first start flag are
    dropped, and a turn is complete when the next start flag comes. Nodes carry no
    checksum, so two things the SDK does not do are added:

    * a start flag ends a turn only where the turn has come round (its bearings span
      ``min_span_deg``) and the flag continues the turn's angles (within ``step_deg`` of
      one of the last three nodes), as a real one does; any other is what line noise makes
      of misaligned bytes, and is dropped (``stray_starts``);
    * a complete turn is kept only if it is plausible, and ``rejected`` counts the others
      by reason:

      - ``"too few nodes"`` / ``"too many nodes"``: fewer than ``min_nodes`` (an A1 takes
        ≥ 200 samples a turn at its fastest, 10 Hz) or more than ``max_nodes`` (8192, the
        SDK's own buffer for one scan);
      - ``"nodes out of order"``: fewer than ``min_in_order`` of the steps between
        consecutive nodes are within ±``step_deg`` (real turns: all of them but a few
        where line noise struck; random bytes: about one in nine);
      - ``"not a whole turn"``: the bearings span less than ``min_span_deg``
        (:func:`angular_span_deg`; a real turn spans ≥ 356°);
      - ``"more than one turn"``: the angles sweep on past 360° + ``step_deg`` (a start flag
        was lost or came where the turn had a hole of lost bytes, so two turns ran
        together).

    ``nodes``, ``starts`` and ``turns`` count what went through.
    """

    def __init__(self, min_nodes: int = 100, max_nodes: int = 8192,
                 min_span_deg: float = 330.0, step_deg: float = 20.0,
                 min_in_order: float = 0.8) -> None:
        if not 1 <= min_nodes <= max_nodes:
            raise ValueError(f"need 1 <= min_nodes <= max_nodes; got {min_nodes}, {max_nodes}")
        if not 0.0 <= min_span_deg <= 360.0:
            raise ValueError(f"min_span_deg is in [0, 360]; got {min_span_deg}")
        if not 0.0 < step_deg < 180.0 or not 0.0 <= min_in_order <= 1.0:
            raise ValueError(f"step_deg is in (0, 180) and min_in_order in [0, 1]; got "
                             f"{step_deg}, {min_in_order}")
        self.min_nodes, self.max_nodes, self.min_span_deg = min_nodes, max_nodes, min_span_deg
        self.step_deg, self.min_in_order = step_deg, min_in_order
        self.nodes = self.starts = self.turns = self.stray_starts = 0
        self.rejected: Counter[str] = Counter()
        self._current: list[Node] | None = None
        self._started = 0.0

    def reset(self) -> None:
        """Forget the turn in progress (a new scan starts)."""
        self._current = None

    def problem(self, nodes: list[Node] | tuple[Node, ...]) -> str | None:
        """Why a complete turn is implausible, or ``None``."""
        if len(nodes) < self.min_nodes:
            return "too few nodes"
        if len(nodes) > self.max_nodes:
            return "too many nodes"
        angles = np.array([n.angle_deg for n in nodes])
        steps = _steps_deg(angles)
        if np.mean(np.abs(steps) <= self.step_deg) < self.min_in_order:
            return "nodes out of order"
        if angular_span_deg(angles) < self.min_span_deg:
            return "not a whole turn"
        if steps.sum() > 360.0 + self.step_deg:
            return "more than one turn"
        return None

    def _ends_turn(self, node: Node, current: list[Node]) -> bool:
        """Whether a start flag can be the real one that ends ``current``."""
        if not any(abs((node.angle_deg - n.angle_deg + 180.0) % 360.0 - 180.0) <= self.step_deg
                   for n in current[-3:]):
            return False
        return angular_span_deg(n.angle_deg for n in current) >= self.min_span_deg

    def push(self, nodes: list[Node], now: float | Sequence[float]) -> list[Turn]:
        """Add nodes, all timed ``now`` or each with its time in ``now``; returns the turns
        they completed."""
        done: list[Turn] = []
        self.nodes += len(nodes)
        times = [now] * len(nodes) if isinstance(now, (int, float)) else list(now)
        if len(times) != len(nodes):
            raise ValueError(f"{len(nodes)} nodes but {len(times)} times")
        for node, t in zip(nodes, times, strict=True):
            current = self._current
            if node.start:
                self.starts += 1
                if current and not self._ends_turn(node, current):
                    self.stray_starts += 1
                    continue
                if current:
                    problem = self.problem(current)
                    if problem is None:
                        self.turns += 1
                        done.append(Turn(tuple(current), self._started, float(t)))
                    else:
                        self.rejected[problem] += 1
                self._current, self._started = [node], float(t)
            elif current is not None:
                current.append(node)
                if len(current) > self.max_nodes:  # no start flag for far too long
                    self.rejected["too many nodes"] += 1
                    self._current = None
        return done

    def summary(self) -> str:
        refused = ", ".join(f"{n} {why}" for why, n in sorted(self.rejected.items()))
        return (f"{self.nodes} nodes, {self.starts} start flags ({self.stray_starts} stray), "
                f"{self.turns} turns kept" + (f", turns refused: {refused}" if refused else ""))


def revolution_to_scan(nodes: list[Node] | tuple[Node, ...], stamp: msgs.Time,
                       frame_id: str = "laser_link", beams: int = 360,
                       scan_time: float = 1 / 5.5, range_min: float = 0.15,
                       range_max: float = 12.0) -> msgs.LaserScan:
    """One turn of nodes → a ``LaserScan`` of ``beams`` counter-clockwise beams over
    [−π, π), each holding the nearest return that falls in it (``inf`` where none does).

    Beam ``i`` looks at ``angle_min + i·increment``; a node at clockwise angle α [deg] is
    at ``wrap(−α)`` in the scan.
    """
    if not nodes:
        raise ValueError("a revolution needs at least one node")
    increment = 2 * math.pi / beams
    ranges = np.full(beams, np.inf)
    intensities = np.zeros(beams)
    for node in nodes:
        if node.distance_mm <= 0:
            continue
        angle = float(wrap_angle(-math.radians(node.angle_deg)))
        index = round((angle + math.pi) / increment) % beams
        r = node.distance_mm / 1000.0
        if r < ranges[index]:
            ranges[index], intensities[index] = r, node.quality
    ranges[(ranges < range_min) | (ranges > range_max)] = np.inf
    return msgs.LaserScan(
        header=msgs.Header(stamp, frame_id), angle_min=-math.pi,
        angle_max=-math.pi + increment * (beams - 1), angle_increment=increment,
        time_increment=scan_time / max(len(nodes), 1), scan_time=scan_time,
        range_min=range_min, range_max=range_max, ranges=ranges.astype(np.float32),
        intensities=intensities.astype(np.float32))


def split_revolutions(nodes: list[Node]) -> list[list[Node]]:
    """Group nodes into turns, each starting at a node with ``start`` set (nodes before the
    first start are dropped; the last, unfinished turn is kept). No plausibility check:
    :class:`TurnAssembler` is the driver's."""
    turns: list[list[Node]] = []
    for node in nodes:
        if node.start:
            turns.append([])
        if turns:
            turns[-1].append(node)
    return turns

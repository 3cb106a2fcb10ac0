"""Closed-loop grading (Lab 11): a student's controller drives seeded office episodes.

:func:`office_episode` is the harness: the student's ``make_controller(robot)`` returns a
controller — ``set_plan(path, goal_yaw)`` and ``compute_velocity_commands(pose, velocity,
costmap) -> (v, ω)``, as :class:`kit.navigation.Controller` — and the kit's navigator
(costmaps, the planner at 1 Hz, recoveries) runs it at 20 Hz for the Uiabot from the
north-west office to the north-east one among walking people, the glass kept out. In every
episode a **bystander** steps into one of the two doorways the route must pass just before the
robot gets there, waits a few seconds and steps back out: a controller that does not stop for
what is in its way touches them.

The notebook's ``check`` runs this in the kernel with the student's own objects; grading
(:mod:`grader.grade`) runs it in the grader's process with the controller living in the
submission's sandboxed process, asked step by step. Either way the same limits hold: each call
of the controller gets :data:`CALL_LIMIT` seconds of CPU time, the episode :data:`EPISODE_CPU`,
and the episode's time is *simulated* time (twice the shortest path at cruise speed, plus the
bystander's wait, plus 10 s), so a loaded machine never fails an honest controller.

An episode passes when the goal is reached in time without touching a wall, the glass, a box
or a person. :class:`EpisodeResult` says why one did not, in two registers: ``message`` (when,
where, how: for the student's own notebook and public cases) and ``category`` (the kind of
failure alone: all a hidden episode's feedback shows).
"""

from __future__ import annotations

import math
import signal
import threading
import time
import traceback
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from kit.navigation import RUNNING, Navigator
from kit.robots import RobotDescription
from sim import scenarios
from sim.runner import Node, Published, Runner, WheelOdometryNode
from sim.simulation import Simulation

__all__ = ["CALL_LIMIT", "CATEGORIES", "EPISODE_CPU", "PEOPLE", "ControllerTimeout",
           "EpisodeResult", "office_episode", "time_allowed", "verdict"]

PEOPLE = 2
"""People walking the office in a graded episode (besides the bystander)."""
CALL_LIMIT = 2.0
"""CPU seconds one call of the controller may take."""
EPISODE_CPU = 60.0
"""CPU seconds the controller may take over a whole episode."""

CATEGORIES = ("reached", "touched a wall", "touched a person", "gave up", "out of time",
              "stuck", "oscillating", "not a controller", "raised", "timed out",
              "too slow", "stopped")
"""Why an episode ends; a hidden episode's feedback says only which."""

DOORS = {
    # the doorway's centre; where the bystander waits, just beside it on the far side from
    # the robot; where they go once they step back out (away from the robot's way)
    "north-west": ((4.45, 7.0), (4.45, 6.2), (2.2, 6.2)),
    "north-east": ((16.45, 7.0), (16.45, 7.8), (18.4, 8.3)),
}


@dataclass
class EpisodeResult:
    """One episode: whether it passed, and why not."""

    passed: bool
    category: str
    message: str
    seconds: float = 0.0
    verdict: dict[str, bool] = field(default_factory=dict)
    events: list[str] = field(default_factory=list)
    """what the navigator did, in order (the decisive last ones are never cut)."""
    trail: Any = None
    """(N, 3) poses the robot drove."""
    costmap: Any = None
    """the navigator's global costmap at the end (a ``kit.planning.Costmap``)."""


class ControllerTimeout(TimeoutError):
    """The controller used up its CPU time on one call (or over the episode)."""


def verdict(row: scenarios.GoalResult, cruise: float, extra: float = 0.0) -> dict[str, bool]:
    """What an episode is graded on."""
    return {"reached": bool(row.reached),
            "no collision": row.collisions_static == 0 and row.collisions_people == 0,
            "in time": bool(row.reached) and
            row.seconds <= time_allowed(row.shortest_length, cruise) + extra}


def time_allowed(shortest: float, cruise: float) -> float:
    """An episode's time [s]: twice the shortest path at cruise speed, plus 10 s."""
    return 2.0 * shortest / cruise + 10.0 if math.isfinite(shortest) else 120.0


# ------------------------------------------------------------------ the bystander

class Bystander(Node):
    """Someone who steps into a doorway as the robot comes, waits, and steps back out."""

    rate = 10.0

    def __init__(self, door: tuple[float, float], waits_at: tuple[float, float],
                 leaves_to: tuple[float, float], trigger: float, stand: float) -> None:
        self.door, self.waits_at, self.leaves_to = door, waits_at, leaves_to
        self.trigger = trigger
        """m: the robot's distance to the doorway when they step in."""
        self.stand = stand
        """s they stand in the doorway."""
        self.stage, self.since, self.index = "waiting", 0.0, -1

    def start(self, sim: Simulation, robot: int) -> Published:
        self.sim, self.robot = sim, robot
        self.index = sim.add_bystander(self.waits_at)
        return ()

    def _walk_to(self, target: tuple[float, float], speed: float = 1.2) -> bool:
        here = self.sim.people_positions()[self.index]
        d = np.asarray(target) - here
        dist = float(np.hypot(*d))
        if dist < 0.05:
            self.sim.move_person(self.index, (0.0, 0.0))
            return True
        self.sim.move_person(self.index, d / dist * min(speed, dist * 5.0))
        return False

    def on_tick(self, time: float) -> Published:
        robot = self.sim.ground_truth(self.robot).pose[:2]
        near = float(np.hypot(*(robot - np.asarray(self.door))))
        if self.stage == "waiting":
            if near < self.trigger:
                # never into a robot already at the door: they let it pass instead
                self.stage, self.since = ("stepping in" if near > 1.2 else "gone"), time
        elif self.stage == "stepping in":
            if self._walk_to(self.door):
                self.stage, self.since = "standing", time
        elif self.stage == "standing":
            self.sim.move_person(self.index, (0.0, 0.0))
            if time - self.since >= self.stand:
                self.stage = "stepping back"
        elif self.stage == "stepping back":        # straight back out of the doorway first
            if self._walk_to(self.waits_at):
                self.stage = "leaving"
        elif self.stage == "leaving" and self._walk_to(self.leaves_to):
            self.stage = "gone"
        return ()

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        return ()


def bystander_for(seed: int) -> Bystander:
    """The episode's bystander: which doorway, when, for how long — all from the seed."""
    rng = np.random.default_rng([int(seed), 11])
    name = "north-west" if rng.random() < 0.5 else "north-east"
    door, waits, leaves = DOORS[name]
    # the robot starts 2.95 m from the north-west doorway: the bystander steps in once it is
    # on its way, and stands long enough for a robot that does not stop to reach them
    return Bystander(door, waits, leaves, trigger=float(rng.uniform(2.0, 2.6)),
                     stand=float(rng.uniform(6.0, 10.0)))


# ------------------------------------------------------------------ limits on the controller

class _Limited:
    """The student's controller in this process, each call within :data:`CALL_LIMIT` CPU
    seconds (an alarm on the process's CPU time: only on the main thread), the episode within
    :data:`EPISODE_CPU`."""

    def __init__(self, controller: Any) -> None:
        self.controller = controller
        self.used = 0.0
        self.commands: list[tuple[float, float]] = []

    def _call(self, name: str, *args: Any) -> Any:
        method = getattr(self.controller, name)
        if threading.current_thread() is not threading.main_thread():
            return method(*args)
        def alarm(signum: int, frame: Any) -> None:
            raise ControllerTimeout(f"{name}() used up its {CALL_LIMIT:g} s of CPU time")

        previous = signal.signal(signal.SIGPROF, alarm)
        start = time.process_time()
        signal.setitimer(signal.ITIMER_PROF, CALL_LIMIT)
        try:
            return method(*args)
        finally:
            signal.setitimer(signal.ITIMER_PROF, 0)
            signal.signal(signal.SIGPROF, previous)
            self.used += time.process_time() - start
            if self.used > EPISODE_CPU:
                raise ControllerTimeout(f"the controller used more than {EPISODE_CPU:g} s of "
                                        f"CPU time in the episode")

    def set_plan(self, *args: Any) -> Any:
        return self._call("set_plan", *args)

    def compute_velocity_commands(self, *args: Any) -> Any:
        commands = _checked_commands(self._call("compute_velocity_commands", *args))
        self.commands.append(commands)
        return commands


def _checked_commands(commands: Any) -> tuple[float, float]:
    if commands is None:
        raise _NotCommands("compute_velocity_commands returned None: a missing return?")
    try:
        v, w = commands
        v, w = float(v), float(w)
    except (TypeError, ValueError):
        raise _NotCommands(f"compute_velocity_commands returned {type(commands).__name__} "
                           f"{str(commands)[:60]!r}, not two numbers (v, ω)") from None
    if not (math.isfinite(v) and math.isfinite(w)):
        raise _NotCommands(f"compute_velocity_commands returned ({v}, {w}): not finite")
    return v, w


class _NotCommands(TypeError):
    """The controller returned something that is not (v, ω)."""


class _Checked:
    """A controller from elsewhere (the grader's proxy): its answers checked the same way."""

    def __init__(self, controller: Any) -> None:
        self.controller = controller
        self.commands: list[tuple[float, float]] = []

    def set_plan(self, *args: Any) -> Any:
        return self.controller.set_plan(*args)

    def compute_velocity_commands(self, *args: Any) -> Any:
        commands = _checked_commands(self.controller.compute_velocity_commands(*args))
        self.commands.append(commands)
        return commands


def _where(exc: BaseException) -> str:
    """', in cell 5, line 12' when the traceback passes through a notebook cell."""
    cells = [f for f in traceback.extract_tb(exc.__traceback__)
             if f.filename.startswith("<cell ") or "ipykernel" in f.filename
             or f.filename.startswith("/tmp/ipykernel")]
    if not cells:
        return ""
    frame = cells[-1]
    return f" (line {frame.lineno}: `{(frame.line or '').strip()[:60]}`)"


# ------------------------------------------------------------------ one episode

def office_episode(make_controller: Callable[[RobotDescription], Any], seed: int
                   ) -> EpisodeResult:
    """One seeded episode with the student's controller, and why it ended as it did."""
    s = scenarios.setup("office", "uiabot", "glass", keepout=True)
    sim = Simulation(world=s.world, robot="uiabot", seed=int(seed), people=PEOPLE,
                     start=s.route.start)
    robot = sim.description()
    bystander = bystander_for(int(seed))
    cruise = robot.cruise_velocity
    limits = [time_allowed(x, cruise) + bystander.stand for x in s.shortest]
    try:
        made = make_controller(robot)
    except Exception as exc:
        return _failed_to_start(exc)
    missing = [m for m in ("set_plan", "compute_velocity_commands")
               if not callable(getattr(made, m, None))]
    if missing:
        return EpisodeResult(False, "not a controller",
                             f"make_controller must return an object with set_plan() and "
                             f"compute_velocity_commands(); it returned "
                             f"{type(made).__name__}, which has no {' and no '.join(missing)}")
    local = not getattr(made, "__kit_remote__", False)
    controller = _Limited(made) if local else _Checked(made)
    nav = Navigator(s.nav_grid, robot, controller=controller, keepout=s.keepout)
    node = scenarios.NavigationNode(nav, scenarios.TruthLocalization(), s.route.goals, limits,
                                    0, s.shortest)
    runner = Runner(sim, [WheelOdometryNode(), node, bystander], record_rate=1.0)
    contact: list[Any] = []

    def touched() -> bool:
        if not contact and sim.collisions:
            contact.append(sim.collisions[0])
        return bool(contact)

    try:
        runner.run(sum(limits) + 1.0, until=lambda r: node.done or touched())
        result = _outcome(node, nav, sim, contact[0] if contact else None, cruise,
                          bystander.stand, limits[0], controller.commands)
    except Exception as exc:
        result = _controller_failed(exc, sim.time, nav, node)
    result.costmap = nav.global_costmap.costmap()
    return result


def _failed_to_start(exc: BaseException) -> EpisodeResult:
    if isinstance(exc, NotImplementedError):
        raise exc  # an unfinished exercise: the check says "not implemented yet"
    if isinstance(exc, (ControllerTimeout, TimeoutError)):
        return EpisodeResult(False, "timed out", f"make_controller: {exc}{_where(exc)}")
    kind = getattr(exc, "kind", type(exc).__name__)
    return EpisodeResult(False, "raised", f"make_controller raised {kind}: "
                         f"{str(exc)[:200]}{_where(exc)}")


def _events(nav: Navigator) -> list[str]:
    return [f"{e.time:.1f} s {e.kind} {e.detail}".strip() for e in nav.events
            if e.kind != "plan"]


def _controller_failed(exc: BaseException, t: float, nav: Navigator,
                       node: scenarios.NavigationNode) -> EpisodeResult:
    events = _events(nav)
    trail = np.array(node.trail) if node.trail else None
    if isinstance(exc, (ControllerTimeout, TimeoutError)):
        return EpisodeResult(False, "timed out", f"at {t:.1f} s the controller did not answer "
                             f"in time: {exc}{_where(exc)} (an endless loop?)", t,
                             events=events, trail=trail)
    if isinstance(exc, _NotCommands):
        return EpisodeResult(False, "raised", f"at {t:.1f} s {exc}", t, events=events,
                             trail=trail)
    if isinstance(exc, ConnectionError) or type(exc).__name__ == "SessionLost":
        return EpisodeResult(False, "stopped", f"at {t:.1f} s the controller's process "
                             f"stopped", t, events=events, trail=trail)
    kind = getattr(exc, "kind", type(exc).__name__)
    return EpisodeResult(False, "raised", f"at {t:.1f} s the controller raised {kind}: "
                         f"{str(exc)[:200]}{_where(exc)}", t, events=events, trail=trail)


def _outcome(node: scenarios.NavigationNode, nav: Navigator, sim: Simulation, contact: Any,
             cruise: float, extra: float, limit: float,
             commands: list[tuple[float, float]]) -> EpisodeResult:
    events = _events(nav)
    trail = np.array(node.trail) if node.trail else np.zeros((0, 3))
    if contact is not None:
        x, y = sim.ground_truth(0).pose[:2]
        what = "a person" if contact.other == "person" else "a wall"
        return EpisodeResult(False, f"touched {what}", f"touched {what} at {contact.time:.1f} s "
                             f"at ({x:.1f}, {y:.1f}) m", contact.time,
                             {"reached": False, "no collision": False, "in time": False},
                             events, trail)
    if not node.results:
        return EpisodeResult(False, "out of time", "the episode ended without a result",
                             sim.time, events=events, trail=trail)
    row = node.results[0]
    v = verdict(row, cruise, extra)
    if all(v.values()):
        return EpisodeResult(True, "reached", f"reached the goal in {row.seconds:.1f} s "
                             f"(allowed {limit:.0f} s), {row.path_length:.1f} m driven",
                             row.seconds, v, events, trail)
    goal = np.asarray(scenarios.ROUTES[("office", "glass")].goals[0][:2])
    left = float(np.hypot(*(trail[-1, :2] - goal))) if len(trail) else math.nan
    if row.reached:
        return EpisodeResult(False, "out of time", f"reached the goal after {row.seconds:.1f} s, "
                             f"over the {limit:.0f} s allowed", row.seconds, v, events, trail)
    gave_up = "recoveries" in row.reason or (nav.status != RUNNING and \
        "time limit" not in row.reason)
    ending = (f"the navigator gave up at {row.seconds:.1f} s: {row.reason}" if gave_up else
              f"out of time at {limit:.0f} s")
    pattern = _pattern(commands)
    if pattern:
        kind, detail = pattern
        return EpisodeResult(False, kind, f"{ending}; {kind}: {detail}; {left:.1f} m from the "
                             f"goal", row.seconds, v, events, trail)
    if gave_up:
        return EpisodeResult(False, "gave up", f"{ending}; {left:.1f} m from the goal",
                             row.seconds, v, events, trail)
    return EpisodeResult(False, "out of time", f"{ending} with {left:.1f} m still to go",
                         row.seconds, v, events, trail)


STEPS = 200
"""the controller's last commands looked at for a pattern (10 s at 20 Hz)."""


def _pattern(commands: list[tuple[float, float]]) -> tuple[str, str] | None:
    """("stuck", …) when the controller's last commands asked for no motion, ("oscillating",
    …) when they turned back and forth without driving on; else ``None``."""
    if len(commands) < STEPS // 2:
        return None
    recent = np.asarray(commands[-STEPS:], dtype=float)
    v, w = recent[:, 0], recent[:, 1]
    still = (np.abs(v) < 0.01) & (np.abs(w) < 0.05)
    if still.mean() > 0.9:
        return "stuck", (f"the controller asked for no motion in {still.sum()} of its last "
                         f"{len(recent)} commands")
    turning = w[np.abs(w) > 0.2]
    flips = int(np.sum(np.diff(np.sign(turning)) != 0)) if len(turning) > 1 else 0
    if flips >= 6 and abs(float(np.sum(v))) / 20.0 < 0.3:
        return "oscillating", (f"its turn changed direction {flips} times in its last "
                               f"{len(recent)} commands while it drove "
                               f"{abs(float(np.sum(v))) / 20.0:.2f} m")
    return None

"""Closed-loop runs: a simulation, a list of nodes, a controller and recorded signals.

A :class:`Runner` steps a :class:`~sim.simulation.Simulation` and passes messages between
nodes the way ROS topics do. Each physics step

1. applies the latest command published on ``/cmd_vel`` (a ``Twist``, or ``(right, left)``
   wheel speeds in rad/s) to the robot;
2. hands each sensor message the step produced (``/scan``, ``/imu``, ``/joint_states``) to the
   nodes subscribed to its topic, and every message those nodes publish in turn to theirs,
   in order (an odometry node's ``/odom`` reaches the fusion node in the same step);
3. ticks every node whose own rate is due (a controller at 20 Hz, a planner at 1 Hz), the
   first time at the run's start, and dispatches what they publish the same way (a node
   ticks at most once per physics step: rates above ``1 / physics.dt`` are capped);
4. records each named signal at ``record_rate``.

A node is any :class:`Node`: it names the topics it subscribes to and its rate, and returns
the ``(topic, message)`` pairs it publishes. :class:`WheelOdometryNode`,
:class:`FusionNode` and :class:`ScriptedCommands` are the nodes of Labs 04–05; the think half
adds localisation, SLAM and planners as further nodes. A run can be repeated as an episode
with :meth:`Runner.reset`.

>>> from sim import Simulation
>>> from kit import msgs
>>> sim = Simulation(world="square", robot="uiabot", seed=1, sensors=False)
>>> plan = ScriptedCommands([(1.0, msgs.Twist(msgs.Vector3(0.3, 0.0, 0.0)))])
>>> run = Runner(sim, [WheelOdometryNode()], controller=plan,
...              signals={"truth": truth_pose(), "odometry": pose_of("/odom")})
>>> recording = run.run(plan.duration)
>>> recording["truth"].shape, round(float(recording["odometry"][-1, 0] - 2.0), 2)
((51, 3), 0.29)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs
from kit.estimation import FusionFilter
from kit.odometry import Method, WheelOdometry
from kit.progress import progress
from sim.simulation import Simulation

__all__ = ["FusionNode", "Node", "ProgressNode", "Recording", "Runner", "ScriptedCommands",
           "WheelOdometryNode", "odometry_pose", "pose_of", "truth_pose"]

FloatArray = NDArray[np.float64]
Published = Iterable[tuple[str, Any]]
Signal = Callable[["Runner"], ArrayLike]

_TICK_TOLERANCE = 1e-9


class Node:
    """A participant of a run: subscriptions, an optional rate, and what it publishes.

    Subclasses override :meth:`start` (called at the start of every run and episode with the
    simulation and the robot's index), :meth:`on_message` (for each message on a subscribed
    topic) and :meth:`on_tick` (at ``rate`` Hz, on the sim clock's multiples of ``1/rate``
    from the run's start). Each returns the ``(topic, message)`` pairs it publishes.
    """

    subscriptions: tuple[str, ...] = ()
    rate: float | None = None
    """Hz of :meth:`on_tick`; ``None``: never ticked."""

    def start(self, sim: Simulation, robot: int) -> Published:
        return ()

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        return ()

    def on_tick(self, time: float) -> Published:
        return ()


class ProgressNode(Node):
    """Moves a progress bar on with the sim clock: twice a simulated second, by the simulated
    seconds since the run started. ``bar`` is anything with ``update(n)`` (a tqdm bar whose
    total is the run's length in seconds)."""

    rate = 2.0

    def __init__(self, bar: Any) -> None:
        self.bar = bar
        self._start, self._shown = 0.0, 0.0

    def start(self, sim: Simulation, robot: int) -> Published:
        self._start, self._shown = sim.time, 0.0
        return ()

    def on_tick(self, time: float) -> Published:
        done = time - self._start
        self.bar.update(done - self._shown)
        self._shown = done
        return ()


class WheelOdometryNode(Node):
    """The odometry node: on each ``/joint_states`` it reads the motor controller's encoder
    counters (:meth:`Simulation.encoder_ticks`) and publishes ``/odom`` (``nav_msgs/Odometry``
    in ``odom``) and ``/tf`` (``odom → base_link``).

    Parameters
    ----------
    initial_pose : (x, y, yaw), optional
        Where odometry starts [m, m, rad]; by default the robot's true start pose, so that
        ``odom`` coincides with the world frame there.
    method : {"exact", "midpoint", "euler"}
        The integration of :func:`kit.odometry.odometry_step`.
    """

    subscriptions = ("/joint_states",)

    def __init__(self, initial_pose: ArrayLike | None = None, method: Method = "exact") -> None:
        self.initial_pose = None if initial_pose is None else \
            geometry.check_pose(initial_pose, "initial_pose")
        self.method: Method = method
        self.odometry: WheelOdometry | None = None
        self._sim: Simulation | None = None
        self._robot = 0

    @property
    def pose(self) -> FloatArray:
        """(x, y, yaw) of the odometry now [m, m, rad] (after :meth:`start`)."""
        if self.odometry is None:
            raise RuntimeError("the odometry node has not started: run it in a Runner first")
        return self.odometry.pose.copy()

    def start(self, sim: Simulation, robot: int) -> Published:
        """Latch the counters; the first ``/odom`` follows the first joint state."""
        self._sim, self._robot = sim, robot
        pose = self.initial_pose if self.initial_pose is not None else \
            sim.ground_truth(robot).pose
        self.odometry = WheelOdometry.for_robot(sim.description(robot), self.method,
                                                initial_pose=pose)
        self.odometry.update(*sim.encoder_ticks(robot), sim.time)
        return ()

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        assert self._sim is not None and self.odometry is not None, "start() comes first"
        odom = self.odometry.update(*self._sim.encoder_ticks(self._robot), time)
        return [("/odom", odom), ("/tf", msgs.TFMessage((self.odometry.transform(time),)))]


class FusionNode(Node):
    """robot_localization's ``ekf_node``: fuses the messages of its input topics with a
    :class:`kit.estimation.FusionFilter` as they come and publishes the estimate at the
    filter's ``frequency`` (as of its last fused input; :attr:`pose` is always current).

    Parameters
    ----------
    fusion : FusionFilter
        Configured with its sensors (and its initial pose).
    inputs : mapping of topic → sensor name
        e.g. ``{"/odom": "odom0", "/imu": "imu0"}``; ``Odometry`` and ``Imu`` messages.
    output : str
        The topic of the estimate (``nav_msgs/Odometry`` in ``odom``).
    """

    def __init__(self, fusion: FusionFilter, inputs: Mapping[str, str],
                 output: str = "/odometry/filtered") -> None:
        self.fusion = fusion
        self.inputs = dict(inputs)
        self.subscriptions = tuple(self.inputs)
        self.output = output
        self.rate = fusion.frequency

    @property
    def pose(self) -> FloatArray:
        """(x, y, yaw) of the estimate now [m, m, rad]."""
        return self.fusion.x[:3].copy()

    def start(self, sim: Simulation, robot: int) -> Published:
        """Every run starts the filter afresh from its initial pose."""
        self.fusion.reset()
        return ()

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        name = self.inputs[topic]
        if isinstance(message, msgs.Odometry):
            self.fusion.add_odometry(name, message)
        elif isinstance(message, msgs.Imu):
            self.fusion.add_imu(name, message)
        else:
            raise TypeError(f"the fusion node takes Odometry and Imu on {topic}, not "
                            f"{type(message).__name__}")
        return ()

    def on_tick(self, time: float) -> Published:
        if self.fusion.time is None:  # nothing fused yet
            return ()
        return [(self.output, self.fusion.odometry())]


class ScriptedCommands(Node):
    """A controller that plays a fixed plan: ``(seconds, command)`` pairs in order, each
    command published on ``/cmd_vel`` when its time comes (a ``Twist`` or ``(right, left)``
    wheel speeds [rad/s]); after the plan it publishes a stop."""

    def __init__(self, plan: Sequence[tuple[float, Any]], rate: float = 100.0) -> None:
        if not plan:
            raise ValueError("a plan needs at least one (seconds, command) pair")
        for seconds, _ in plan:
            if not seconds > 0:
                raise ValueError(f"each step of a plan lasts a positive number of seconds; "
                                 f"got {seconds!r}")
        self.plan = list(plan)
        self.rate = float(rate)
        self.ends = np.cumsum([s for s, _ in self.plan])
        self._t0 = 0.0
        self._current: int | None = None

    @property
    def duration(self) -> float:
        """Seconds the plan lasts."""
        return float(self.ends[-1])

    def start(self, sim: Simulation, robot: int) -> Published:
        self._t0, self._current = sim.time, None
        return ()

    def on_tick(self, time: float) -> Published:
        index = int(np.searchsorted(self.ends, time - self._t0 + _TICK_TOLERANCE, "right"))
        if index == self._current:
            return ()
        self._current = index
        command = self.plan[index][1] if index < len(self.plan) else msgs.Twist()
        return [("/cmd_vel", command)]


@dataclass
class Recording:
    """Signals sampled on the sim clock: ``recording["name"]`` is an array of shape (N, ...)
    over ``recording.time`` (N,) [s]."""

    time: FloatArray
    signals: dict[str, np.ndarray] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self.signals[name]
        except KeyError:
            raise KeyError(f"no signal {name!r}; recorded: {sorted(self.signals)}") from None


def truth_pose(robot: int = 0) -> Signal:
    """Signal: the robot's true (x, y, yaw) [m, m, rad] in the world."""
    return lambda run: run.sim.ground_truth(robot).pose


def odometry_pose(message: msgs.Odometry | None) -> FloatArray:
    """(x, y, yaw) of an ``Odometry`` message's pose; NaN for none."""
    if message is None:
        return np.full(3, np.nan)
    p = message.pose.pose
    q = p.orientation
    return np.array([p.position.x, p.position.y,
                     float(geometry.quaternion_to_yaw([q.x, q.y, q.z, q.w]))])


def pose_of(topic: str) -> Signal:
    """Signal: the pose of the latest ``Odometry`` on ``topic`` (NaN before the first)."""
    return lambda run: odometry_pose(run.latest.get(topic))


class Runner:
    """Steps ``sim`` with ``nodes`` and a ``controller``, recording ``signals``.

    Parameters
    ----------
    sim : Simulation
    nodes : sequence of Node
        In the order messages reach them.
    controller : Node, optional
        A node that publishes ``/cmd_vel`` (at its own rate, or on messages); it gets every
        message after the other nodes.
    signals : mapping of name → callable(runner) → array_like
        Sampled at ``record_rate`` [Hz] from the run's start; see :func:`truth_pose`,
        :func:`pose_of`.
    robot : int
        The index of the robot in ``sim`` that the nodes serve.
    """

    def __init__(self, sim: Simulation, nodes: Sequence[Node] = (), controller: Node | None = None,
                 signals: Mapping[str, Signal] | None = None, record_rate: float = 50.0,
                 robot: int = 0) -> None:
        if not record_rate > 0:
            raise ValueError(f"record_rate must be positive Hz; got {record_rate!r}")
        self.sim = sim
        self.nodes = [*nodes, *([controller] if controller is not None else [])]
        for node in self.nodes:
            if not isinstance(node, Node):
                raise TypeError(f"a runner's nodes are sim.runner.Node objects; got "
                                f"{type(node).__name__}")
        self.signals = dict(signals or {})
        self.record_rate = float(record_rate)
        self.robot = int(robot)
        self.latest: dict[str, Any] = {}
        """the last message on each topic."""
        self._command: Any = None
        self._started = False

    def reset(self, seed: int | None = None) -> None:
        """A new episode: the simulation from its start poses (re-seeded when ``seed`` is
        given); every node starts afresh at the next :meth:`run`."""
        self.sim.reset(seed)
        self._started = False

    # ------------------------------------------------------------------ dispatch
    def dispatch(self, published: Published) -> None:
        """Hand messages to their subscribers, and what those publish to theirs, in order."""
        queue = list(published)
        while queue:
            topic, message = queue.pop(0)
            self.latest[topic] = message
            if topic == "/cmd_vel":
                self._command = message
            time = self.sim.time
            for node in self.nodes:
                if topic in node.subscriptions:
                    queue.extend(node.on_message(topic, message, time))

    def _start(self) -> None:
        self.latest.clear()
        self._command = None
        for node in self.nodes:
            self.dispatch(node.start(self.sim, self.robot))
        self._started = True

    def _record(self, times: list[float], values: dict[str, list[np.ndarray]]) -> None:
        times.append(self.sim.time)
        for name, signal in self.signals.items():
            values[name].append(np.array(signal(self), dtype=float))

    # ------------------------------------------------------------------ running
    def run(self, seconds: float, until: Callable[[Runner], bool] | None = None,
            progress_bar: str | None = None) -> Recording:
        """Run for ``seconds`` of sim time (or until ``until(runner)`` is true after a step).

        ``progress_bar`` names a progress bar (:func:`kit.progress.progress`) for long runs.
        """
        if not (math.isfinite(seconds) and seconds >= 0):
            raise ValueError(f"seconds must be a finite non-negative number; got {seconds!r}")
        if not self._started:
            self._start()
        sim = self.sim
        dt = sim.physics.dt
        t0 = sim.time
        ticks = {id(n): 0 for n in self.nodes if n.rate}
        times: list[float] = []
        values: dict[str, list[np.ndarray]] = {name: [] for name in self.signals}
        recorded = 0
        self._tick(t0, ticks)
        self._record(times, values)
        steps = range(round(seconds / dt))
        for _ in progress(steps, desc=progress_bar) if progress_bar else steps:
            command, self._command = self._command, None
            self.dispatch(sim.step(command))
            self._tick(t0, ticks)
            if sim.time - t0 + _TICK_TOLERANCE >= (recorded + 1) / self.record_rate:
                recorded += 1
                self._record(times, values)
            if until is not None and until(self):
                break
        return Recording(np.array(times), {k: np.array(v) for k, v in values.items()})

    def _tick(self, t0: float, ticks: dict[int, int]) -> None:
        elapsed = self.sim.time - t0
        for node in self.nodes:
            if node.rate and ticks[id(node)] / node.rate <= elapsed + _TICK_TOLERANCE:
                ticks[id(node)] += 1
                self.dispatch(node.on_tick(self.sim.time))

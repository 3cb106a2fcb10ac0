"""The simulator seen live in Foxglove, and what a navigation episode writes beside its rows.

* :class:`LiveNode` sends every message of its topics to a :class:`kit.liveview.LiveView`
  (stamped with the simulation's time) and paces the simulation at ``speed`` times real
  time, so that the robot moves on screen as it would in the building.
* :class:`EpisodeOutputs` is what ``python -m sim navigate --bag/--live`` adds to each episode:
  :class:`sim.navtopics.NavigationTopics`, a bag per episode (``episode_000/`` …, with
  ``/clock``) and the live view.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

from kit import msgs
from kit.bag import BagWriter
from kit.liveview import LiveView
from sim import navtopics
from sim.runner import Node, Published
from sim.simulation import Simulation

__all__ = ["LIVE_TOPICS", "EpisodeOutputs", "LiveNode"]

LIVE_TOPICS = ("/scan", "/odom", "/tf", "/cmd_vel", "/plan", *navtopics.TOPICS)
"""What a navigating robot's live view and bags carry (with ``/tf_static`` and ``/map``)."""


class LiveNode(Node):
    """Publishes its topics to ``view``; with ``speed``, holds the simulation back to that
    many times real time (checked 50 times per simulated second).

    Parameters
    ----------
    view
        The live view (a Foxglove WebSocket server).
    topics
        The topics to send.
    speed
        Simulated seconds per wall-clock second; ``None``: as fast as it runs.
    """

    rate = 50.0

    def __init__(self, view: LiveView, topics: tuple[str, ...] = LIVE_TOPICS,
                 speed: float | None = 1.0) -> None:
        if speed is not None and not speed > 0:
            raise ValueError(f"speed is a positive factor of real time; got {speed!r}")
        self.view = view
        self.subscriptions = topics
        self.speed = speed

    def start(self, sim: Simulation, robot: int) -> Published:
        self._wall0, self._sim0 = time.monotonic(), sim.time
        return ()

    def on_message(self, topic: str, message: Any, time: float) -> Published:
        self.view.publish(topic, message, round(time * 1e9))
        return ()

    def on_tick(self, now: float) -> Published:
        if self.speed is not None:
            ahead = (now - self._sim0) / self.speed - (time.monotonic() - self._wall0)
            if ahead > 0:
                time.sleep(ahead)
        return ()


class EpisodeOutputs:
    """Per episode of :func:`sim.scenarios.navigate`: the navigation topics, a bag in
    ``bag_dir`` (``episode_000/`` …) and the live view, as asked.

    Call :meth:`close` after the last episode (it closes the last bag).
    """

    def __init__(self, bag_dir: Path | None, view: LiveView | None = None,
                 speed: float | None = 1.0, urdf: str | None = None) -> None:
        self.bag_dir, self.view, self.speed, self.urdf = bag_dir, view, speed, urdf
        self._bag: BagWriter | None = None
        self.bags: list[Path] = []

    def __call__(self, index: int, node: Any, sim: Simulation, grid: msgs.OccupancyGrid
                 ) -> list[Node]:
        from sim.demo import BagRecorder

        self.close()
        nodes: list[Node] = [navtopics.NavigationTopics(node, self.urdf)]
        sinks: list[Any] = []
        if self.bag_dir is not None:
            path = self.bag_dir / f"episode_{index:03d}"
            self._bag = BagWriter(path, clock_period=0.01).__enter__()
            self.bags.append(path)
            sinks.append(BagRecorder(LIVE_TOPICS, self._bag))
        if self.view is not None:
            sinks.append(LiveNode(self.view, LIVE_TOPICS, self.speed))
        for sink in sinks:
            sink.on_message("/tf_static", sim.static_transforms(), sim.time)
            sink.on_message("/map", grid, sim.time)
        return nodes + sinks

    def close(self) -> None:
        if self._bag is not None:
            self._bag.__exit__(None, None, None)
            self._bag = None

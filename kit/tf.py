"""A transform tree in the manner of ROS tf2: static and time-stamped transforms, lookups.

Each frame has at most one parent. An edge ``parent → child`` is either static (valid at all
times) or dynamic, with a time-ordered buffer of samples; a lookup at a time between two
samples interpolates (translation linearly, rotation by slerp), and a time outside the
buffer raises :class:`ExtrapolationError` rather than guessing.

``lookup_transform(target, source, time)`` returns ``T_target_source``: it maps coordinates
given in ``source`` into ``target``, and is also the pose of ``source`` in ``target`` — the
same meaning as tf2's ``lookupTransform(target_frame, source_frame, time)``.

Times are float seconds (the sim clock) or :class:`kit.msgs.Time`.
"""

from __future__ import annotations

import bisect
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from kit import geometry, msgs

__all__ = [
    "ConnectivityError",
    "ExtrapolationError",
    "RigidTransform",
    "TransformError",
    "TransformTree",
    "UnknownFrameError",
]


class TransformError(LookupError):
    """Base class of the errors a lookup can raise."""


class UnknownFrameError(TransformError):
    """A frame that no transform mentions."""


class ConnectivityError(TransformError):
    """Two frames that are not in the same tree."""


class ExtrapolationError(TransformError):
    """A time outside the samples buffered for an edge."""


@dataclass(frozen=True, eq=False)
class RigidTransform:
    """A 3-D rigid transform: ``p_parent = R(rotation) p_child + translation``.

    ``rotation`` is a unit quaternion in ROS order (x, y, z, w).
    """

    translation: NDArray[np.float64]
    rotation: NDArray[np.float64]

    @classmethod
    def identity(cls) -> RigidTransform:
        return cls(np.zeros(3), np.array([0.0, 0.0, 0.0, 1.0]))

    @classmethod
    def from_pose2d(cls, pose: ArrayLike) -> RigidTransform:
        p = geometry.check_pose(pose)
        return cls(np.array([p[0], p[1], 0.0]), geometry.yaw_to_quaternion(p[2]))

    @classmethod
    def from_msg(cls, transform: msgs.Transform) -> RigidTransform:
        t, r = transform.translation, transform.rotation
        q = np.array([r.x, r.y, r.z, r.w], dtype=np.float64)
        norm = np.linalg.norm(q)
        if not np.isfinite(norm) or abs(norm - 1.0) > 1e-6:
            raise ValueError(f"transform rotation must be a unit quaternion; got {q} (norm {norm})")
        return cls(np.array([t.x, t.y, t.z], dtype=np.float64), q / norm)

    def to_msg(self) -> msgs.Transform:
        t, q = self.translation, self.rotation
        return msgs.Transform(msgs.Vector3(*map(float, t)), msgs.Quaternion(*map(float, q)))

    def to_pose2d(self) -> NDArray[np.float64]:
        """(x, y, yaw) of this transform, dropping z, roll and pitch."""
        return np.array([self.translation[0], self.translation[1],
                         float(geometry.quaternion_to_yaw(self.rotation))])

    def __matmul__(self, other: RigidTransform) -> RigidTransform:
        """``T_a_b @ T_b_c = T_a_c``."""
        return RigidTransform(
            self.translation + geometry.quaternion_rotate(self.rotation, other.translation),
            geometry.quaternion_multiply(self.rotation, other.rotation))

    def inverse(self) -> RigidTransform:
        conj = self.rotation * np.array([-1.0, -1.0, -1.0, 1.0])
        return RigidTransform(-geometry.quaternion_rotate(conj, self.translation), conj)

    def apply(self, points: ArrayLike) -> NDArray[np.float64]:
        """Map points of shape (..., 3) from the child frame into the parent frame."""
        return geometry.quaternion_rotate(self.rotation, np.asarray(points, float)) + \
            self.translation


def _seconds(time: float | msgs.Time) -> float:
    return time.to_sec() if isinstance(time, msgs.Time) else float(time)


class _Edge:
    """The buffer of one parent → child edge."""

    def __init__(self, parent: str, child: str, static: bool) -> None:
        self.parent, self.child, self.static = parent, child, static
        self.times: list[float] = []
        self.samples: list[RigidTransform] = []

    def insert(self, time: float, transform: RigidTransform, cache_time: float) -> None:
        i = bisect.bisect_left(self.times, time)
        if i < len(self.times) and self.times[i] == time:
            self.samples[i] = transform
        else:
            self.times.insert(i, time)
            self.samples.insert(i, transform)
        cutoff = self.times[-1] - cache_time
        drop = bisect.bisect_left(self.times, cutoff)
        if drop:
            del self.times[:drop], self.samples[:drop]

    def at(self, time: float | None) -> RigidTransform:
        if self.static:
            return self.samples[-1]
        if time is None:
            return self.samples[-1]
        times = self.times
        if time < times[0] or time > times[-1]:
            raise ExtrapolationError(
                f"lookup of {self.parent} -> {self.child} at t={time:.9f} s is outside the "
                f"buffered interval [{times[0]:.9f}, {times[-1]:.9f}] s")
        i = bisect.bisect_left(times, time)
        if times[i] == time:
            return self.samples[i]
        t0, t1 = times[i - 1], times[i]
        a, b = self.samples[i - 1], self.samples[i]
        f = (time - t0) / (t1 - t0)
        return RigidTransform(a.translation + f * (b.translation - a.translation),
                              geometry.quaternion_slerp(a.rotation, b.rotation, f))


class TransformTree:
    """Frames joined by static and time-stamped transforms; one parent per frame.

    Parameters
    ----------
    cache_time : float
        How many seconds of samples each dynamic edge keeps behind its newest one (tf2: 10 s).

    Examples
    --------
    >>> tree = TransformTree()
    >>> tree.set_static("base_link", "laser_link", RigidTransform(np.array([0.1, 0, 0.13]),
    ...                                                          np.array([0, 0, 0, 1.0])))
    >>> tree.set_transform("odom", "base_link", 0.0, RigidTransform.from_pose2d([1, 0, 0]))
    >>> tree.lookup_transform("odom", "laser_link", 0.0).translation.round(3).tolist()
    [1.1, 0.0, 0.13]
    """

    def __init__(self, cache_time: float = 10.0) -> None:
        if cache_time <= 0:
            raise ValueError(f"cache_time must be positive seconds; got {cache_time}")
        self.cache_time = float(cache_time)
        self._edges: dict[str, _Edge] = {}  # keyed by child frame

    # ------------------------------------------------------------------ building
    def _edge(self, parent: str, child: str, static: bool) -> _Edge:
        for name in (parent, child):
            if not isinstance(name, str) or not name or name.startswith("/"):
                raise ValueError(f"frame ids are non-empty names without a leading '/'; "
                                 f"got {name!r}")
        if parent == child:
            raise ValueError(f"a frame cannot be its own parent: {parent!r}")
        edge = self._edges.get(child)
        if edge is None:
            if self._is_ancestor(child, parent):
                raise ValueError(f"{parent!r} -> {child!r} would close a loop in the tree")
            edge = self._edges[child] = _Edge(parent, child, static)
        elif edge.parent != parent:
            raise ValueError(
                f"frame {child!r} already has the parent {edge.parent!r}; a transform from "
                f"{parent!r} would give it two parents")
        elif edge.static != static:
            kind = "static" if edge.static else "dynamic"
            raise ValueError(f"{parent!r} -> {child!r} is already {kind}")
        return edge

    def _is_ancestor(self, frame: str, of: str) -> bool:
        node: str | None = of
        while node is not None:
            if node == frame:
                return True
            edge = self._edges.get(node)
            node = edge.parent if edge else None
        return False

    def set_static(self, parent: str, child: str, transform: RigidTransform) -> None:
        """Add or replace the static transform ``T_parent_child``."""
        self._edge(parent, child, static=True).insert(0.0, transform, float("inf"))

    def set_transform(self, parent: str, child: str, time: float | msgs.Time,
                      transform: RigidTransform) -> None:
        """Add a sample of ``T_parent_child`` at ``time``."""
        t = _seconds(time)
        if not np.isfinite(t):
            raise ValueError(f"transform time must be finite; got {t}")
        self._edge(parent, child, static=False).insert(t, transform, self.cache_time)

    def add_message(self, msg: msgs.TransformStamped | msgs.TFMessage,
                    static: bool = False) -> None:
        """Add a ``TransformStamped`` or every transform in a ``TFMessage`` (``/tf_static``
        when ``static``)."""
        items: Iterable[msgs.TransformStamped] = (
            msg.transforms if isinstance(msg, msgs.TFMessage) else (msg,))
        for ts in items:
            tr = RigidTransform.from_msg(ts.transform)
            if static:
                self.set_static(ts.header.frame_id, ts.child_frame_id, tr)
            else:
                self.set_transform(ts.header.frame_id, ts.child_frame_id, ts.header.stamp, tr)

    # ------------------------------------------------------------------ queries
    @property
    def frames(self) -> set[str]:
        """Every frame named by a transform."""
        return set(self._edges) | {e.parent for e in self._edges.values()}

    def parent(self, frame: str) -> str | None:
        """The parent of ``frame`` (``None`` for a root)."""
        self._require(frame)
        edge = self._edges.get(frame)
        return edge.parent if edge else None

    def _require(self, frame: str) -> None:
        if frame not in self.frames:
            known = ", ".join(sorted(self.frames)) or "none"
            raise UnknownFrameError(f"unknown frame {frame!r}; known frames: {known}")

    def _chain(self, frame: str) -> list[_Edge]:
        chain: list[_Edge] = []
        node = frame
        while node in self._edges:
            edge = self._edges[node]
            chain.append(edge)
            node = edge.parent
        return chain

    def lookup_transform(self, target: str, source: str,
                         time: float | msgs.Time | None = None) -> RigidTransform:
        """``T_target_source`` at ``time`` (``None``: the newest time all edges involved share).
        """
        self._require(target)
        self._require(source)
        up_source, up_target = self._chain(source), self._chain(target)
        roots = [(c[-1].parent if c else f) for c, f in ((up_source, source), (up_target, target))]
        if roots[0] != roots[1]:
            raise ConnectivityError(
                f"{target!r} and {source!r} are not connected: their roots are {roots[1]!r} "
                f"and {roots[0]!r}")
        # drop the shared part above the lowest common ancestor
        while up_source and up_target and up_source[-1] is up_target[-1]:
            up_source.pop()
            up_target.pop()
        edges = up_source + up_target
        t = None if time is None else _seconds(time)
        if t is None:
            dynamic = [e.times[-1] for e in edges if not e.static]
            t = min(dynamic) if dynamic else None
        root_source = RigidTransform.identity()
        for edge in up_source:
            root_source = edge.at(t) @ root_source
        root_target = RigidTransform.identity()
        for edge in up_target:
            root_target = edge.at(t) @ root_target
        return root_target.inverse() @ root_source

    def lookup_message(self, target: str, source: str,
                       time: float | msgs.Time) -> msgs.TransformStamped:
        """:meth:`lookup_transform` as a ``TransformStamped`` (parent ``target``)."""
        tr = self.lookup_transform(target, source, time)
        stamp = time if isinstance(time, msgs.Time) else msgs.Time.from_sec(time)
        return msgs.TransformStamped(msgs.Header(stamp, target), source, tr.to_msg())

    def lookup_pose2d(self, target: str, source: str,
                      time: float | msgs.Time | None = None) -> NDArray[np.float64]:
        """Planar pose (x, y, yaw) of ``source`` in ``target``."""
        return self.lookup_transform(target, source, time).to_pose2d()

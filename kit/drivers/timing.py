"""When was it measured? Stamps for devices that sample at their own steady rate.

A lidar's head takes one sample every ``period`` seconds by its own clock, and the samples
reach the host in chunks, late by the link and the host's scheduling: sometimes by a
fraction of a millisecond, sometimes (a start-up backlog, a busy host) by a whole turn.
Stamping a sample with the arrival of its chunk puts every turn of a backlog at the same
instant. Instead, sample ``i`` was taken at ``T0 + i · period``, and each chunk bounds
``T0``: its last sample cannot have been taken later than the chunk's arrival less the
sample's own transmission time, so

.. math::  T_0 \\le t_{arrival} - t_{tx} - (n - 1) \\cdot period

for a chunk that brings the sample count to ``n``. :class:`SampleClock` keeps the tightest
bound over the last ``window`` seconds (so that a sample lost on the line, which shifts the
count, or a drift between the device's clock and the host's, is forgotten within a window):
the least delayed chunk dates them all.

Only chunks that bring samples bound ``T0`` (an empty read says nothing of when the next
sample will be taken: the device may have stopped). When nothing comes for longer than the
window (a host that reads nothing — a stalled process, a machine busy elsewhere —, or a
device that sends nothing), no bound is left to keep: the clock starts over from the first
chunk after, and the samples of a backlog are dated late until a chunk comes on time again.
:attr:`SampleClock.restarts` counts those times, so that a recording can say its stamps
may be late there (``kit record`` prints it).
"""

from __future__ import annotations

from collections import deque

__all__ = ["SampleClock"]


class SampleClock:
    """The times of samples taken every ``period`` seconds, from their arrival times.

    Parameters
    ----------
    period : float
        Seconds between two samples, by the device's clock.
    transmission : float
        Seconds a sample takes on the link (its bytes × 10 bits / baud rate).
    window : float
        Seconds of arrivals the bound is kept over.

    >>> c = SampleClock(0.5e-3, transmission=0.0)
    >>> c.observe(1000, arrival=10.0)   # a backlog: 1000 samples in one chunk
    >>> c.observe(1010, arrival=10.005)
    >>> round(c.time_of(0), 6), round(c.time_of(999), 6)
    (9.5005, 10.0)
    """

    def __init__(self, period: float, transmission: float = 0.0, window: float = 2.0) -> None:
        if not period > 0 or transmission < 0 or not window > 0:
            raise ValueError(f"period > 0, transmission >= 0 and window > 0 s; got {period}, "
                             f"{transmission}, {window}")
        self.period = period
        self.transmission = transmission
        self.window = window
        self._bounds: deque[tuple[float, float]] = deque()  # (arrival, bound), bounds rising
        self.restarts = 0
        """arrivals after a silence longer than ``window``: every bound before was forgotten,
        and the samples of the backlog are dated late (by up to the silence)."""

    def observe(self, count: int, arrival: float) -> None:
        """``count`` samples have arrived in all (sample ``count − 1`` the latest), the last
        of them by ``arrival`` [s, the stamping clock]."""
        if count <= 0:
            return
        bound = arrival - self.transmission - (count - 1) * self.period
        bounds = self._bounds
        if bounds and bounds[-1][0] < arrival - self.window:
            self.restarts += 1
        while bounds and bounds[-1][1] >= bound:
            bounds.pop()
        bounds.append((arrival, bound))
        while bounds[0][0] < arrival - self.window:
            bounds.popleft()

    @property
    def ready(self) -> bool:
        return bool(self._bounds)

    def time_of(self, index: int) -> float:
        """When sample ``index`` (counted from 0 like ``count``) was taken [s]."""
        if not self._bounds:
            raise ValueError("no sample has arrived yet")
        return self._bounds[0][1] + index * self.period

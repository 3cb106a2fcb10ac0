"""Each driver in its own thread: timestamped messages delivered to a queue or a callback.

The drivers block while they wait for their device, so one loop that reads a lidar and an
IMU in turn reads the IMU only between turns (6 times a second at 5.5 Hz). A
:class:`Reader` runs one device's read in a thread of its own and hands every message on as
``(topic, time_ns, message)`` — the order :func:`kit.bag.read_bag` yields and
:func:`kit.bag.write_bag` takes — stamped by the driver: the wall clock on a real port, the
logical clock on an emulator's logical port.

A device that does not answer in time, or sends a corrupted frame, costs one read and is
counted (``timeouts``, ``errors``); the thread goes on. A port that fails (the device
unplugged: :class:`~kit.drivers.errors.PortError`) is reported once (``on_error``); given
a ``reopen``, the reader then tries it every ``backoff`` seconds, doubling up to
``max_backoff``, and goes on reading on the same driver once the device is back, keeping
the outage in ``gaps``; without one, the port failure ends the thread and is kept in
``error``.

>>> import queue
>>> from kit import msgs
>>> q = queue.Queue()
>>> r = Reader("demo", lambda: [("/imu", msgs.Imu())], q, period=0.01, limit=3).start()
>>> r.join(1.0)
>>> [q.get(timeout=1.0)[0] for _ in range(3)], r.messages, r.error
(['/imu', '/imu', '/imu'], 3, None)
"""

from __future__ import annotations

import queue
import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

from kit import msgs
from kit.drivers.errors import DeviceTimeout, DriverError, PortError

__all__ = ["Gap", "Reader", "Stamped", "message_time_ns"]

Stamped = tuple[str, int, msgs.Message]
"""``(topic, time_ns, message)``."""


@dataclass(frozen=True)
class Gap:
    """An outage of a device: from its last message before the port failed to its first
    after (stamps [ns]; ``end`` ``None`` while it lasts), and why."""

    device: str
    start: int
    end: int | None
    reason: str
    retries: int = 0

    @property
    def seconds(self) -> float | None:
        return None if self.end is None else (self.end - self.start) * 1e-9

    def describe(self) -> str:
        lasted = "not back" if self.seconds is None else f"{self.seconds:.2f} s without data"
        return f"{self.device}: {lasted} ({self.reason}; {self.retries} tries to reopen)"


def message_time_ns(message: msgs.Message) -> int:
    """A message's stamp [ns]: its header's, or its first transform's for ``TFMessage``.

    Raises
    ------
    ValueError
        A message with neither (it cannot be placed in time).
    """
    header = getattr(message, "header", None)
    if header is None and isinstance(message, msgs.TFMessage) and message.transforms:
        header = message.transforms[0].header
    if header is None:
        raise ValueError(f"{type(message).__name__} has no header to take its time from")
    return int(header.stamp.to_nsec())


class Reader:
    """Call ``read`` over and over in a thread; deliver what it returns.

    Parameters
    ----------
    name : str
        The device's name (for the thread and messages).
    read : callable
        One reading: an iterable of ``(topic, message)`` pairs (a driver's ``read_scan``,
        ``read_imu`` … wrapped).
    deliver : queue.Queue or callable
        Where each ``(topic, time_ns, message)`` goes: ``put`` on a queue, or called.
    period : float
        Seconds between the starts of two reads on average (0: read again at once, for
        devices that stream and make ``read`` wait). Polled devices need one (an IMU at
        100 Hz: 0.01); a reading that comes late is made up for by reading the next ones
        sooner (up to a second behind).
    on_error : callable, optional
        Called with the error that ended the thread.
    limit : int, optional
        Stop after this many readings (tests, one-shot captures).
    reopen : callable, optional
        Bring the device back after its port failed (the driver's ``reopen``); it raises
        :class:`~kit.drivers.errors.PortError` (or another driver error) while the device
        is not back.
    backoff, max_backoff : float
        Seconds before the first try to reopen, and the most between two (doubling).
    stamp : callable, optional
        The clock gaps are dated with when no message dates them [s] (the wall clock).
    """

    def __init__(self, name: str, read: Callable[[], Iterable[tuple[str, msgs.Message]]],
                 deliver: queue.Queue[Any] | Callable[[str, int, msgs.Message], None],
                 period: float = 0.0, on_error: Callable[[BaseException], None] | None = None,
                 limit: int | None = None, reopen: Callable[[], Any] | None = None,
                 backoff: float = 0.1, max_backoff: float = 2.0,
                 stamp: Callable[[], float] = time.time) -> None:
        if period < 0:
            raise ValueError(f"period must be >= 0 s; got {period}")
        if not 0 < backoff <= max_backoff:
            raise ValueError(f"need 0 < backoff <= max_backoff; got {backoff}, {max_backoff}")
        if isinstance(deliver, queue.Queue):
            target = deliver

            def put(topic: str, time_ns: int, message: msgs.Message) -> None:
                target.put((topic, time_ns, message))

            self._deliver: Callable[[str, int, msgs.Message], None] = put
        elif callable(deliver):
            self._deliver = deliver
        else:
            raise TypeError(f"deliver must be a queue.Queue or a callable; got "
                            f"{type(deliver).__name__}")
        self.name = name
        self.read = read
        self.period = period
        self.on_error = on_error
        self.limit = limit
        self.reopen = reopen
        self.backoff, self.max_backoff = backoff, max_backoff
        self.stamp = stamp
        self.readings = self.messages = self.timeouts = self.errors = 0
        self.error: BaseException | None = None
        self.counts: dict[str, int] = {}
        self.gaps: list[Gap] = []
        self.last_ns: int | None = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"reader-{name}", daemon=True)

    def start(self) -> Reader:
        self._thread.start()
        return self

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def stop(self, timeout: float = 2.0) -> None:
        """Ask the thread to end after its current read, and wait up to ``timeout`` s."""
        self._stop.set()
        self.join(timeout)

    def join(self, timeout: float | None = None) -> None:
        if self._thread.is_alive() or self._thread.ident is not None:
            self._thread.join(timeout)

    def _once(self) -> None:
        try:
            out = list(self.read())
        except DeviceTimeout:
            self.timeouts += 1
            return
        except PortError:
            raise
        except DriverError:
            self.errors += 1  # a corrupted frame, a reply that did not fit: next reading
            return
        self.readings += 1
        for topic, message in out:
            t = message_time_ns(message)
            if self.gaps and self.gaps[-1].end is None:
                gap = self.gaps[-1]
                self.gaps[-1] = Gap(gap.device, gap.start, t, gap.reason, gap.retries)
            self._deliver(topic, t, message)
            self.last_ns = t
            self.messages += 1
            self.counts[topic] = self.counts.get(topic, 0) + 1

    def _recover(self, failure: PortError) -> bool:
        """After a port failure: report it once, then reopen with a back-off until the
        device is back (True) or the reader is stopped (False)."""
        if self.on_error is not None:
            self.on_error(failure)
        start = self.last_ns if self.last_ns is not None else round(self.stamp() * 1e9)
        reason = str(failure)
        self.gaps.append(Gap(self.name, start, None, reason))
        wait, tries = self.backoff, 0
        while not self._stop.wait(wait):
            tries += 1
            try:
                assert self.reopen is not None
                self.reopen()
            except DriverError:
                wait = min(2 * wait, self.max_backoff)
                gap = self.gaps[-1]
                self.gaps[-1] = Gap(gap.device, gap.start, None, reason, tries)
                continue
            gap = self.gaps[-1]
            self.gaps[-1] = Gap(gap.device, gap.start, None, reason, tries)
            return True
        return False

    def _run(self) -> None:
        next_start = time.monotonic()
        try:
            while not self._stop.is_set():
                if self.limit is not None and self.readings >= self.limit:
                    return
                try:
                    self._once()
                except PortError as failure:
                    if self.reopen is None or not self._recover(failure):
                        raise
                    next_start = time.monotonic()
                    continue
                if self.period:
                    # keep the average rate: a late reading is made up for by the next
                    # ones, up to a second's worth; further behind, start afresh
                    next_start += self.period
                    wait = next_start - time.monotonic()
                    if wait < -1.0:
                        next_start, wait = time.monotonic(), 0.0
                    if wait > 0:
                        self._stop.wait(wait)
        except BaseException as exc:  # the thread's end: kept for whoever owns the reader
            self.error = exc
            if self.on_error is not None and (self.reopen is None or
                                              not isinstance(exc, PortError)):
                self.on_error(exc)

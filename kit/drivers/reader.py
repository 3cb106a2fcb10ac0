"""Each driver in its own thread: timestamped messages delivered to a queue or a callback.

The drivers block while they wait for their device, so one loop that reads a lidar and an
IMU in turn reads the IMU only between turns (6 times a second at 5.5 Hz). A
:class:`Reader` runs one device's read in a thread of its own and hands every message on as
``(topic, time_ns, message)`` — the order :func:`kit.bag.read_bag` yields and
:func:`kit.bag.write_bag` takes — stamped by the driver: the wall clock on a real port, the
logical clock on an emulator's logical port.

A device that does not answer in time, or sends a corrupted frame, costs one read and is
counted (``timeouts``, ``errors``); the thread goes on. A port that fails (the device
unplugged: :class:`~kit.drivers.errors.PortError`) ends the thread, and the error is kept
in ``error`` (and passed to ``on_error``).

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
from typing import Any

from kit import msgs
from kit.drivers.errors import DeviceTimeout, DriverError, PortError

__all__ = ["Reader", "Stamped", "message_time_ns"]

Stamped = tuple[str, int, msgs.Message]
"""``(topic, time_ns, message)``."""


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
    """

    def __init__(self, name: str, read: Callable[[], Iterable[tuple[str, msgs.Message]]],
                 deliver: queue.Queue[Any] | Callable[[str, int, msgs.Message], None],
                 period: float = 0.0, on_error: Callable[[BaseException], None] | None = None,
                 limit: int | None = None) -> None:
        if period < 0:
            raise ValueError(f"period must be >= 0 s; got {period}")
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
        self.readings = self.messages = self.timeouts = self.errors = 0
        self.error: BaseException | None = None
        self.counts: dict[str, int] = {}
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
            self._deliver(topic, message_time_ns(message), message)
            self.messages += 1
            self.counts[topic] = self.counts.get(topic, 0) + 1

    def _run(self) -> None:
        next_start = time.monotonic()
        try:
            while not self._stop.is_set():
                if self.limit is not None and self.readings >= self.limit:
                    return
                self._once()
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
            if self.on_error is not None:
                self.on_error(exc)

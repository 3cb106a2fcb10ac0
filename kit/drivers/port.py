"""The one place the drivers touch a serial port: opening a URL (exclusively), reading what
has come, writing, reopening after a replug, and every failure of the port turned into the
driver's own error.

A port is anything with pyserial's ``read``/``write``/``in_waiting``/
``reset_input_buffer``: a ``serial.Serial`` (``/dev/ttyUSB0``, a pseudo-terminal,
``loop://``, ``socket://``) or an emulator's logical port.

Whatever the port does — ``termios.error`` from an unplugged USB adapter, ``OSError``,
pyserial's ``SerialException``, a read that finds the port closed — the driver raises a
:class:`~kit.drivers.errors.PortError` naming the device and the command, and a port that
stops taking bytes raises :class:`~kit.drivers.errors.DeviceTimeout`. A port handed in by
the caller is read in slices of at most ``timeout`` seconds whatever its own time-out was
(pyserial's default ``timeout=None`` would block for ever on a silent device), so every
driver deadline holds.

**Ours alone.** A port opened from a path is opened with pyserial's ``exclusive=True``: on
Linux and macOS an advisory ``flock`` on the device (the lock pyserial and picocom take; a
program that takes none, such as ``screen``, is not kept out), on Windows the system's own
exclusive access. A second opener gets ``PortError: … busy (held by PID …)``, the holder's
process id read from ``/proc/locks`` where the system has it, and the first holder is not
disturbed (pyserial takes the lock before it touches the port's settings or buffers).

**Failures are reported once.** After the port fails, the link does not touch it again:
every later call raises the same :class:`PortError` until :meth:`Link.reopen` opens the
same path again (the device replugged) — so a driver whose cable came loose reports it
once and resumes on the same object.

**Stamps.** :func:`wall_clock` is the epoch time (as ROS header stamps are) carried by the
monotonic clock, so a step of the system clock during a run cannot disorder stamps.
"""

from __future__ import annotations

import errno as _errno
import os
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from kit.drivers.errors import DeviceTimeout, PortError

__all__ = ["Link", "open_port", "port_errors", "port_holders", "wall_clock", "wall_clock_for"]

_EPOCH_OFFSET = time.time() - time.monotonic()
_BUSY = {_errno.EAGAIN, _errno.EWOULDBLOCK, _errno.EBUSY}

_HINTS = {
    _errno.ENOENT: "no such port: is the device plugged in? (ls /dev/ttyUSB* /dev/ttyACM*)",
    _errno.EACCES: "permission denied: add yourself to the 'dialout' group "
                   "(sudo usermod -aG dialout $USER) and log in again",
    _errno.EBUSY: "the port is busy: another program has it open in exclusive mode",
    _errno.EIO: "input/output error: the device was unplugged or lost power",
    _errno.ENXIO: "no such device: the adapter is gone (unplugged?)",
    _errno.ENODEV: "no such device: the adapter is gone (unplugged?)",
}


def port_errors() -> tuple[type[BaseException], ...]:
    """Every exception a serial port raises when it fails: ``OSError``, pyserial's
    ``SerialException``, ``termios.error`` (not an ``OSError``; raised by flushing an
    unplugged adapter) and the ``TypeError`` some pyserial versions raise from a closed
    pseudo-terminal."""
    import serial

    errors: list[type[BaseException]] = [OSError, serial.SerialException, TypeError]
    try:
        import termios

        errors.append(termios.error)
    except ImportError:  # Windows
        pass
    return tuple(errors)


def _errno_of(exc: BaseException) -> int | None:
    """The operating system's error number behind ``exc``: its own, or that of the error it
    was raised from or while handling (pyserial's ``read`` turns an ``OSError`` into a
    ``SerialException("read failed: [Errno 5] ...")`` that carries no number itself)."""
    seen: set[int] = set()
    at: BaseException | None = exc
    while at is not None and id(at) not in seen:
        seen.add(id(at))
        number = getattr(at, "errno", None)
        if isinstance(number, int):
            return number
        args = getattr(at, "args", ())
        if args and isinstance(args[0], int):  # termios.error carries (errno, text)
            return int(args[0])
        at = at.__cause__ or at.__context__
    return None


def _port_failure(device: str, what: str, exc: BaseException) -> PortError:
    number = _errno_of(exc)
    hint = _HINTS.get(number, "") if number is not None else ""
    if "returned no data" in str(exc):
        # pyserial's words for a hung-up port (the other side gone); the port being ours
        # alone, the "multiple access" it also suggests is not the cause
        return PortError(device, f"{what}: the port failed (disconnected: it reports data "
                                 f"but has none): the device was unplugged or lost power")
    text = f"{what}: the port failed ({exc})" + (f": {hint}" if hint else "")
    return PortError(device, text, number)


def port_holders(path: str) -> list[int]:
    """Process ids holding a ``flock`` on the device at ``path`` (Linux: ``/proc/locks``;
    an empty list where the system cannot tell)."""
    try:
        st = os.stat(path)
        with open("/proc/locks", encoding="ascii") as f:
            lines = f.readlines()
    except OSError:
        return []
    pids = []
    for line in lines:
        parts = line.split()
        if len(parts) < 6 or parts[1] != "FLOCK":  # "->" lines are waiters
            continue
        try:
            major, minor, inode = parts[5].split(":")
            if (int(major, 16), int(minor, 16), int(inode)) == \
                    (os.major(st.st_dev), os.minor(st.st_dev), st.st_ino):
                pids.append(int(parts[4]))
        except ValueError:
            continue
    return sorted(set(pids))


def _process_name(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/comm", encoding="utf-8") as f:
            return f.read().strip()
    except OSError:
        return ""


def _busy_text(url: str) -> str:
    holders = port_holders(url)
    if not holders:
        return "the port is busy: another program has it open"
    named = ", ".join(f"PID {pid}" + (" (this program)" if pid == os.getpid() else
                                      f" ({_process_name(pid)})" if _process_name(pid) else "")
                      for pid in holders)
    return f"the port is busy (held by {named}): close it there first"


def open_port(device: str, url: str, baudrate: int, timeout: float = 0.01,
              write_timeout: float = 1.0, exclusive: bool = True) -> Any:
    """Open ``url`` (``/dev/ttyUSB0``, ``socket://host:port``, ``loop://``) at ``baudrate``
    8N1, exclusively unless ``exclusive=False``; a port that cannot be opened raises
    :class:`PortError` saying what to do (a busy port: which process holds it)."""
    import serial

    try:
        return serial.serial_for_url(url, baudrate=baudrate, timeout=timeout,
                                     write_timeout=write_timeout,
                                     exclusive=True if exclusive else None)
    except (serial.SerialException, OSError, ValueError) as exc:
        number = _errno_of(exc)
        if number in _BUSY:
            raise PortError(device, f"cannot open {url!r} at {baudrate} baud: "
                                    f"{_busy_text(url)}", number) from None
        hint = _HINTS.get(number, "") if number is not None else ""
        raise PortError(device, f"cannot open {url!r} at {baudrate} baud: {exc}" +
                        (f" ({hint})" if hint else ""), number) from None


def wall_clock() -> float:
    """Seconds since the epoch, advancing with the monotonic clock: what stamps messages on
    a real port (strictly increasing between two calls that see the clock move, whatever
    the system clock does meanwhile)."""
    return time.monotonic() + _EPOCH_OFFSET


def wall_clock_for(clock: Callable[[], float]) -> Callable[[], float]:
    """The clock that stamps messages: :func:`wall_clock` (seconds since the epoch, as ROS
    header stamps are) when the driver waits on ``time.monotonic``; otherwise the driver's
    own clock (an emulator's logical clock)."""
    return wall_clock if clock is time.monotonic else clock


class Link:
    """A port plus the clock and sleep its driver waits with, and the clock it stamps with.

    ``clock`` and ``sleep`` default to wall time; an emulator's logical clock passes its own
    (``clock=c, sleep=c.sleep``) so that time-outs and waits run on it. ``stamp`` (seconds)
    defaults to :func:`wall_clock_for` ``(clock)``.

    A port given as a path is opened here, exclusively (``exclusive=False`` shares it: only
    ``kit stop`` does, to stop a robot whose program still holds its port). A port given as
    an object keeps its settings except two: a read time-out that is ``None``, 0 or longer
    than ``timeout`` becomes ``timeout`` (reads are slices; the driver keeps its own
    deadlines), and a missing write time-out becomes ``write_timeout``.

    ``lock`` (re-entrant) is held by a driver for a whole transaction, so a background
    keep-alive and the program never interleave requests and replies. ``failure`` is the
    :class:`PortError` the port failed with, until :meth:`reopen`.
    """

    def __init__(self, device: str, port: Any, baudrate: int, timeout: float = 0.01,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 stamp: Callable[[], float] | None = None, write_timeout: float = 1.0,
                 exclusive: bool = True) -> None:
        if not isinstance(baudrate, int) or baudrate <= 0:
            raise ValueError(f"baudrate must be a positive integer; got {baudrate!r}")
        self.device = device
        self.errors = port_errors()
        self.url: str | None = port if isinstance(port, str) else None
        self.baudrate = baudrate
        self.timeout = timeout
        self.write_timeout = write_timeout
        self.exclusive = exclusive
        self.lock = threading.RLock()
        self.failure: PortError | None = None
        self.reopened = 0
        if isinstance(port, str):
            port = open_port(device, port, baudrate, timeout, write_timeout, exclusive)
        else:
            with self.guard("configure the port"):
                self._slice(port)
        self.port = port
        self.clock = clock
        self.sleep = sleep
        self.stamp = stamp if stamp is not None else wall_clock_for(clock)

    def _slice(self, port: Any) -> None:
        current = getattr(port, "timeout", self.timeout)
        if current is None or not 0 < current <= self.timeout:
            port.timeout = self.timeout
        if getattr(port, "write_timeout", 0.0) is None:
            port.write_timeout = self.write_timeout

    @contextmanager
    def guard(self, what: str) -> Iterator[None]:
        """Turn any failure of the port inside the block into :class:`PortError` (a write
        the port cannot get rid of into :class:`DeviceTimeout`); a port that already failed
        is not touched again: the same error is raised at once."""
        import serial

        if self.failure is not None:
            raise PortError(self.device, f"{what}: {self._failed_text()}",
                            self.failure.errno)
        try:
            yield
        except serial.SerialTimeoutException:
            raise DeviceTimeout(self.device, f"{what}: the port takes no more bytes "
                                             f"(write time-out)") from None
        except self.errors as exc:
            self.failure = _port_failure(self.device, what, exc)
            raise self.failure from None

    def _failed_text(self) -> str:
        assert self.failure is not None
        reason = str(self.failure).split(": ", 1)[-1]
        return f"the port failed earlier ({reason}); reopen() once the device is back"

    def fail(self, error: PortError) -> PortError:
        """Remember ``error`` as the port's failure (a driver that found the port dead)."""
        self.failure = error
        return error

    def write(self, data: bytes, what: str) -> None:
        with self.lock, self.guard(what):
            self.port.write(data)

    def read_some(self, what: str) -> bytes:
        """What has arrived, or waits up to the port's read slice for at least a byte."""
        with self.guard(what):
            data = bytes(self.port.read(self.port.in_waiting or 1))
        if not data and getattr(self.port, "is_open", True) is False:
            raise self.fail(PortError(self.device, f"{what}: the port is closed"))
        return data

    def read_exact(self, n: int, timeout: float, what: str) -> bytes:
        """``n`` bytes, or :class:`DeviceTimeout` after ``timeout`` seconds on the clock."""
        deadline = self.clock() + timeout
        data = bytearray()
        while len(data) < n:
            if self.clock() >= deadline:
                raise DeviceTimeout(self.device, f"{what}: {len(data)} of {n} bytes within "
                                                 f"{timeout:g} s")
            with self.guard(what):
                data += self.port.read(n - len(data))
        return bytes(data)

    def drain(self, quiet: float, timeout: float, what: str) -> bytes:
        """Read what comes until the line has been quiet for ``quiet`` seconds (at most
        ``timeout`` seconds in all): the answers to whatever an earlier program left."""
        start = last = self.clock()
        out = bytearray()
        while self.clock() - last < quiet and self.clock() - start < timeout:
            data = self.read_some(what)
            if data:
                out += data
                last = self.clock()
        return bytes(out)

    def clear(self, what: str) -> None:
        """Drop what has arrived and not been read (stale replies, a stream's tail)."""
        with self.guard(what):
            self.port.reset_input_buffer()

    def set_baudrate(self, baudrate: int, what: str) -> None:
        with self.guard(what):
            try:
                self.port.baudrate = baudrate
            except ValueError as exc:
                raise PortError(self.device, f"{what}: {exc}") from None
        self.baudrate = baudrate

    def reopen(self) -> None:
        """Open the port again after it failed (the device unplugged and plugged back in):
        the same path, rate and exclusivity; a port the caller opened is opened again
        through its own ``open()``. Raises :class:`PortError` while the device is not
        back (no such port, busy)."""
        with self.lock:
            self.close()
            if self.url is not None:
                port = open_port(self.device, self.url, self.baudrate, self.timeout,
                                 self.write_timeout, self.exclusive)
            else:
                port = self.port
                try:
                    port.open()
                    self._slice(port)
                except AttributeError:
                    raise PortError(self.device, "reopen: this port object cannot be opened "
                                                 "again; pass the port's path instead") from None
                except self.errors as exc:
                    raise _port_failure(self.device, "reopen", exc) from None
            self.port = port
            self.failure = None
            self.reopened += 1

    def close(self) -> None:
        """Close the port; a port that already failed closes quietly."""
        try:
            self.port.close()
        except self.errors:
            pass

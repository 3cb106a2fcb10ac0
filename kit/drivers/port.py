"""The one place the drivers touch a serial port: opening a URL, reading what has come,
writing, and every failure of the port turned into the driver's own error.

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
"""

from __future__ import annotations

import errno as _errno
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from kit.drivers.errors import DeviceTimeout, PortError

__all__ = ["Link", "open_port", "port_errors", "wall_clock_for"]

_HINTS = {
    _errno.ENOENT: "no such port: is the device plugged in? (ls /dev/ttyUSB* /dev/ttyACM*)",
    _errno.EACCES: "permission denied: add yourself to the 'dialout' group "
                   "(sudo usermod -aG dialout $USER) and log in again",
    _errno.EBUSY: "the port is busy: another program has it open",
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
    number = getattr(exc, "errno", None)
    if isinstance(number, int):
        return number
    args = getattr(exc, "args", ())
    if args and isinstance(args[0], int):  # termios.error carries (errno, text)
        return int(args[0])
    return None


def _port_failure(device: str, what: str, exc: BaseException) -> PortError:
    number = _errno_of(exc)
    hint = _HINTS.get(number, "") if number is not None else ""
    text = f"{what}: the port failed ({exc})" + (f": {hint}" if hint else "")
    return PortError(device, text, number)


def open_port(device: str, url: str, baudrate: int, timeout: float = 0.01,
              write_timeout: float = 1.0) -> Any:
    """Open ``url`` (``/dev/ttyUSB0``, ``socket://host:port``, ``loop://``) at ``baudrate``
    8N1; a port that cannot be opened raises :class:`PortError` saying what to do."""
    import serial

    try:
        return serial.serial_for_url(url, baudrate=baudrate, timeout=timeout,
                                     write_timeout=write_timeout)
    except (serial.SerialException, OSError, ValueError) as exc:
        number = _errno_of(exc)
        hint = _HINTS.get(number, "") if number is not None else ""
        raise PortError(device, f"cannot open {url!r} at {baudrate} baud: {exc}" +
                        (f" ({hint})" if hint else ""), number) from None


def wall_clock_for(clock: Callable[[], float]) -> Callable[[], float]:
    """The clock that stamps messages: the wall clock (``time.time``, seconds since the
    epoch, as ROS header stamps are) when the driver waits on ``time.monotonic``; otherwise
    the driver's own clock (an emulator's logical clock)."""
    return time.time if clock is time.monotonic else clock


class Link:
    """A port plus the clock and sleep its driver waits with, and the clock it stamps with.

    ``clock`` and ``sleep`` default to wall time; an emulator's logical clock passes its own
    (``clock=c, sleep=c.sleep``) so that time-outs and waits run on it. ``stamp`` (seconds)
    defaults to :func:`wall_clock_for` ``(clock)``.

    A port given as an object keeps its settings except two: a read time-out that is
    ``None``, 0 or longer than ``timeout`` becomes ``timeout`` (reads are slices; the
    driver keeps its own deadlines), and a missing write time-out becomes
    ``write_timeout``.
    """

    def __init__(self, device: str, port: Any, baudrate: int, timeout: float = 0.01,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 stamp: Callable[[], float] | None = None, write_timeout: float = 1.0) -> None:
        if not isinstance(baudrate, int) or baudrate <= 0:
            raise ValueError(f"baudrate must be a positive integer; got {baudrate!r}")
        self.device = device
        self.errors = port_errors()
        if isinstance(port, str):
            port = open_port(device, port, baudrate, timeout, write_timeout)
        else:
            with self.guard("configure the port"):
                current = getattr(port, "timeout", timeout)
                if current is None or not 0 < current <= timeout:
                    port.timeout = timeout
                if getattr(port, "write_timeout", 0.0) is None:
                    port.write_timeout = write_timeout
        self.port = port
        self.clock = clock
        self.sleep = sleep
        self.stamp = stamp if stamp is not None else wall_clock_for(clock)

    @contextmanager
    def guard(self, what: str) -> Iterator[None]:
        """Turn any failure of the port inside the block into :class:`PortError` (a write
        the port cannot get rid of into :class:`DeviceTimeout`)."""
        import serial

        try:
            yield
        except serial.SerialTimeoutException:
            raise DeviceTimeout(self.device, f"{what}: the port takes no more bytes "
                                             f"(write time-out)") from None
        except self.errors as exc:
            raise _port_failure(self.device, what, exc) from None

    def write(self, data: bytes, what: str) -> None:
        with self.guard(what):
            self.port.write(data)

    def read_some(self, what: str) -> bytes:
        """What has arrived, or waits up to the port's read slice for at least a byte."""
        with self.guard(what):
            data = bytes(self.port.read(self.port.in_waiting or 1))
        if not data and getattr(self.port, "is_open", True) is False:
            raise PortError(self.device, f"{what}: the port is closed")
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

    def close(self) -> None:
        """Close the port; a port that already failed closes quietly."""
        try:
            self.port.close()
        except self.errors:
            pass

"""The one place the drivers touch a serial port: opening a URL, reading what has come,
writing, each failure turned into a :class:`~kit.drivers.errors.ProtocolError` that names
the device.

A port is anything with pyserial's ``read``/``write``/``in_waiting``/
``reset_input_buffer``: a ``serial.Serial`` (``/dev/ttyUSB0``, a pseudo-terminal,
``loop://``, ``socket://``) or an emulator's logical port.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from kit.drivers.errors import DeviceTimeout, ProtocolError

__all__ = ["Link"]


class Link:
    """A port plus the clock and sleep its driver waits with.

    ``clock`` and ``sleep`` default to wall time; an emulator's logical clock passes its own
    (``clock=c, sleep=c.sleep``) so that time-outs and waits run on it.
    """

    def __init__(self, device: str, port: Any, baudrate: int, timeout: float = 0.01,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep) -> None:
        if isinstance(port, str):
            import serial

            try:
                port = serial.serial_for_url(port, baudrate=baudrate, timeout=timeout)
            except (serial.SerialException, ValueError) as exc:
                raise ProtocolError(device, f"cannot open {port!r}: {exc}") from None
        self.device = device
        self.port = port
        self.clock = clock
        self.sleep = sleep

    def _failed(self, what: str, exc: Exception) -> ProtocolError:
        return ProtocolError(self.device, f"{what}: the port failed ({exc})")

    def write(self, data: bytes, what: str) -> None:
        import serial

        try:
            self.port.write(data)
        except (OSError, serial.SerialException) as exc:
            raise self._failed(what, exc) from None

    def read_some(self, what: str) -> bytes:
        """What has arrived, or waits up to the port's time-out for at least a byte."""
        import serial

        try:
            return bytes(self.port.read(self.port.in_waiting or 1))
        except (OSError, serial.SerialException, TypeError) as exc:
            # pyserial raises TypeError from a closed pty's read on some versions
            raise self._failed(what, exc) from None

    def read_exact(self, n: int, timeout: float, what: str) -> bytes:
        """``n`` bytes, or :class:`DeviceTimeout` after ``timeout`` seconds on the clock."""
        deadline = self.clock() + timeout
        data = bytearray()
        while len(data) < n:
            if self.clock() >= deadline:
                raise DeviceTimeout(self.device, f"{what}: {len(data)} of {n} bytes within "
                                                 f"{timeout:g} s")
            import serial

            try:
                data += self.port.read(n - len(data))
            except (OSError, serial.SerialException, TypeError) as exc:
                raise self._failed(what, exc) from None
        return bytes(data)

    def clear(self, what: str) -> None:
        import serial

        try:
            self.port.reset_input_buffer()
        except (OSError, serial.SerialException) as exc:
            raise self._failed(what, exc) from None

    def set_baudrate(self, baudrate: int, what: str) -> None:
        import serial

        try:
            self.port.baudrate = baudrate
        except (OSError, serial.SerialException, ValueError) as exc:
            raise self._failed(what, exc) from None

    def close(self) -> None:
        self.port.close()

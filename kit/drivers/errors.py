"""The drivers' errors: one small hierarchy, each naming the device (and the command).

====================  =====================================================================
``DeviceTimeout``     the device did not answer in time (off, frozen, wrong baud rate, wrong
                      port)
``ChecksumError``     a frame whose check code does not match (line noise, a loose cable)
``ProtocolError``     bytes that do not follow the protocol (another device on the port, a
                      reply that does not fit the request)
``PortError``         the port itself failed: no such port, no permission, unplugged or
                      closed while in use (a kind of ``ProtocolError``)
``DeviceError``       the device answered with an error of its own (``code``)
====================  =====================================================================
"""

from __future__ import annotations

__all__ = ["ChecksumError", "DeviceError", "DeviceTimeout", "DriverError", "PortError",
           "ProtocolError", "failed_twice"]


class DriverError(Exception):
    """Base of every driver error."""

    def __init__(self, device: str, message: str) -> None:
        super().__init__(f"{device}: {message}")
        self.device = device


class DeviceTimeout(DriverError, TimeoutError):
    """The device did not answer (or went silent) within the configured time-out."""


class ChecksumError(DriverError):
    """A frame whose checksum or CRC does not match its contents."""


class ProtocolError(DriverError):
    """Bytes that do not follow the protocol (bad length, unexpected reply, closed port)."""


class PortError(ProtocolError):
    """The serial port failed: it cannot be opened (missing, no permission, busy) or it
    failed while in use (the device was unplugged, the port closed). ``errno`` is the
    operating system's error number when there is one."""

    def __init__(self, device: str, message: str, errno: int | None = None) -> None:
        super().__init__(device, message)
        self.errno = errno


class DeviceError(DriverError):
    """The device answered with an error of its own; ``code`` is the device's code."""

    def __init__(self, device: str, message: str, code: int) -> None:
        super().__init__(device, message)
        self.code = code


def failed_twice(second: DriverError, first: DriverError) -> DriverError:
    """``second`` again (same class, device and code), its message also saying how the first
    try failed: what a driver raises when a retried first exchange fails again."""
    prefix = f"{second.device}: "
    text = str(second)[len(prefix):] if str(second).startswith(prefix) else str(second)
    before = str(first).split(": ", 1)[-1]
    message = f"{text} (twice; the first time: {before})"
    if isinstance(second, DeviceError):
        return DeviceError(second.device, message, second.code)
    if isinstance(second, PortError):
        return PortError(second.device, message, second.errno)
    return type(second)(second.device, message)

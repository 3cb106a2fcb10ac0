"""The drivers' errors: one small hierarchy, each naming the device (and the command)."""

from __future__ import annotations

__all__ = ["ChecksumError", "DeviceError", "DeviceTimeout", "DriverError", "ProtocolError"]


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


class DeviceError(DriverError):
    """The device answered with an error of its own; ``code`` is the device's code."""

    def __init__(self, device: str, message: str, code: int) -> None:
        super().__init__(device, message)
        self.code = code

"""Which device is on this port? Try each protocol at the rates its device runs at, with
requests that change nothing, and report the first that answers.

Order: at 115200 baud the ODrive (``r vbus_voltage`` with a checksum, after a bare line end
that flushes whatever the firmware holds), the RPLidar (``GET_HEALTH``), the BNO055 (read
``CHIP_ID``), the DPRALTE drives at the IGV's addresses 0x3F and 0x3E (read ``02.00``);
then the OS5000 listened to (it streams by itself) at 19200 and 9600; the SICK LMS2xx's
status request at 9600, 38400, 19200 and 500000; the OS5000 at its other rates; the
DPRALTE at 38400 and 9600. Every answer must pass its protocol's check code (or, for the
BNO055 and the RPLidar, carry the exact identifying bytes), so noise from a device at
another rate is not taken for an answer.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

from kit.drivers.errors import DriverError, PortError
from kit.drivers.port import Link

__all__ = ["Answer", "attempts", "probe"]


@dataclass(frozen=True)
class Answer:
    """A device that answered: its name, the rate, and what it said about itself."""

    device: str
    baudrate: int
    detail: str


def _odrive(link: Link, timeout: float) -> str | None:
    from kit.drivers.odrive import ODrive

    link.write(b"\n", "flush the line")
    voltage = ODrive(link.port, timeout=timeout, clock=link.clock, sleep=link.sleep).read(
        "vbus_voltage")
    return f"bus voltage {voltage:.1f} V"


def _rplidar(link: Link, timeout: float) -> str | None:
    from kit.drivers.rplidar import RPLidar

    status, code = RPLidar(link.port, timeout=timeout, clock=link.clock,
                           sleep=link.sleep).health()
    return f"health {('good', 'warning', 'error')[status] if status < 3 else status}" + \
        (f", error 0x{code:04X}" if code else "")


def _bno055(link: Link, timeout: float) -> str | None:
    from kit.drivers.bno055 import BNO055, CHIP_ID

    chip = BNO055(link.port, timeout=timeout, retries=1, clock=link.clock,
                  sleep=link.sleep).read_registers(CHIP_ID, 1, "read chip id")[0]
    return "chip id 0xA0" if chip == 0xA0 else None


def _dpralte(link: Link, timeout: float) -> str | None:
    from kit.drivers.dpralte import DpralteDrive

    found = []
    for address in (0x3F, 0x3E):
        drive = DpralteDrive(link, address, timeout=timeout)
        try:
            drive.read((0x02, 0x00), 1, "read bridge status")
        except DriverError:
            continue
        found.append(f"0x{address:02X}")
    return f"drive(s) at {', '.join(found)}" if found else None


def _os5000(link: Link, timeout: float) -> str | None:
    from kit.drivers.os5000 import Os5000

    reading = Os5000(link.port, timeout=max(timeout, 0.3), clock=link.clock).read()
    return f"heading {reading.heading_deg:.1f}°"


def _lms2xx(link: Link, timeout: float) -> str | None:
    from kit.drivers.lms2xx import LMS2xx

    scanner = LMS2xx(link.port, timeout=timeout, tries=1, clock=link.clock, sleep=link.sleep,
                     baudrate=9600)
    scanner.status()
    try:
        return scanner.device_type()
    except DriverError:
        return "status answered"


Check = Callable[[Link, float], "str | None"]


def attempts() -> Iterator[tuple[str, int, Check]]:
    """(device, baud rate, check) in the order they are tried."""
    yield from (("odrive", 115200, _odrive), ("rplidar", 115200, _rplidar),
                ("bno055", 115200, _bno055), ("dpralte", 115200, _dpralte))
    yield from (("os5000", b, _os5000) for b in (19200, 9600))
    yield from (("lms2xx", b, _lms2xx) for b in (9600, 38400, 19200, 500000))
    yield from (("os5000", b, _os5000) for b in (4800, 38400, 57600, 115200))
    yield from (("dpralte", b, _dpralte) for b in (38400, 9600))


def probe(port: Any, timeout: float = 0.2, clock: Callable[[], float] = time.monotonic,
          sleep: Callable[[float], None] = time.sleep,
          log: Callable[[str], None] | None = None,
          devices: tuple[str, ...] | None = None, exclusive: bool = True) -> Answer | None:
    """The first device that answers on ``port`` (a path or an open port), or ``None``;
    ``devices`` limits the devices tried (``kit stop``: the motor controllers);
    ``exclusive=False`` shares a port another program holds.

    Raises
    ------
    PortError
        The port cannot be opened (missing, busy), or fails while probing (unplugged).
    """
    link = Link("probe", port, 115200, 0.01, clock, sleep, exclusive=exclusive)
    try:
        for device, baud, check in attempts():
            if devices is not None and device not in devices:
                continue
            if log is not None:
                log(f"{device} at {baud} baud …")
            link.set_baudrate(baud, f"{device} at {baud} baud")
            link.clear(f"{device} at {baud} baud")
            try:
                detail = check(link, timeout)
            except PortError:
                raise
            except DriverError:
                continue
            if detail is not None:
                return Answer(device, baud, detail)
        return None
    finally:
        link.close()

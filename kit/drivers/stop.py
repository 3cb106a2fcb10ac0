"""Stop a robot's motors from anywhere: what ``kit stop PORT…`` runs in another terminal
when the program that drove the robot hangs, or died leaving a motor controller without a
watchdog running.

For each port: the motor controller on it (named, or probed among the ODrive and the
DPRALTE drives), its line cleared, then zero speed and the motors off — the ODrive's axes
to IDLE, the drives' bridges inhibited — and the state read back. A port another program
still holds (the hung program itself) is shared for the stop rather than refused: the stop
gets through, though that program may read the answers; the report says so.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

from kit.drivers.errors import DriverError, PortError
from kit.drivers.port import open_port, port_holders

__all__ = ["MOTOR_CONTROLLERS", "Stopped", "stop_motors"]

MOTOR_CONTROLLERS = ("odrive", "dpralte")


@dataclass(frozen=True)
class Stopped:
    """What ``kit stop`` did on one port."""

    device: str
    port: str
    detail: str
    confirmed: bool
    """the motors were read back stopped (False: the stop was sent, not confirmed)."""

    def __str__(self) -> str:
        return f"{self.device} on {self.port}: {self.detail}"


def _open(device: str, path: str, baudrate: int) -> tuple[object, str]:
    try:
        return open_port(device, path, baudrate), ""
    except PortError as exc:
        if "busy" not in str(exc):
            raise
    holders = port_holders(path)
    held = "held by " + ", ".join(f"PID {p}" for p in holders) if holders else "held"
    return open_port(device, path, baudrate, exclusive=False), held


def _stop_odrive(path: str, baudrate: int, timeout: float) -> Stopped:
    from kit.drivers.odrive import IDLE, ODrive

    port, held = _open("ODrive", path, baudrate)
    od = ODrive(port, timeout=timeout)
    try:
        od.clear_line()
        for axis in (0, 1):
            od.set_velocity(axis, 0.0)
        for axis in (0, 1):
            od.request_state(axis, IDLE)
        try:
            od.link.sleep(0.05)
            states = [od.axis_state(axis) for axis in (0, 1)]
        except DriverError as exc:
            note = f" (the port is {held})" if held else ""
            return Stopped("odrive", path, f"zero speed and IDLE sent, not read back: "
                                           f"{exc}{note}", False)
        if states == [IDLE, IDLE]:
            return Stopped("odrive", path, "both axes IDLE" + (f" (the port was {held})"
                                                              if held else ""), True)
        return Stopped("odrive", path, f"zero speed and IDLE sent, axes read back in states "
                                       f"{states}", False)
    finally:
        od.close()


def _stop_dpralte(path: str, baudrate: int, timeout: float) -> Stopped:
    from kit.drivers.dpralte import DEVICE, DpralteDrive
    from kit.drivers.port import Link

    port, held = _open(DEVICE, path, baudrate)
    link = Link(DEVICE, port, baudrate)
    try:
        done: list[str] = []
        failures: list[str] = []
        for address in (0x3F, 0x3E):
            drive = DpralteDrive(link, address, timeout=timeout)
            try:
                drive.connect(clear=address == 0x3F)
                drive.get_write_access()
                drive.set_velocity_rpm(0.0)
                drive.disable()
                bridge = drive.read((0x02, 0x00), 1, "read bridge status").uint16()
            except DriverError as exc:
                failures.append(f"0x{address:02X}: {exc}")
                continue
            (done if not bridge & 1 else failures).append(
                f"0x{address:02X}" + ("" if not bridge & 1 else ": bridge still enabled"))
        note = f" (the port was {held})" if held else ""
        if done and not failures:
            return Stopped("dpralte", path, f"bridges off at {', '.join(done)}{note}", True)
        return Stopped("dpralte", path, f"stopped {', '.join(done) or 'none'}; "
                                        f"{'; '.join(failures)}{note}", False)
    finally:
        link.close()


def stop_motors(path: str, device: str | None = None, baudrate: int | None = None,
                timeout: float = 0.3,
                log: Callable[[str], None] | None = None) -> Stopped:
    """Stop the motor controller on ``path`` (``device`` ``"odrive"`` or ``"dpralte"``, or
    ``None`` to probe which); ``baudrate`` overrides its default rate.

    Raises
    ------
    PortError
        The port cannot be opened (missing, no permission).
    DriverError
        No motor controller answers on it.
    ValueError
        An unknown device name.
    """
    from kit.drivers.probe import probe

    if device is not None and device not in MOTOR_CONTROLLERS:
        raise ValueError(f"kit stop stops motor controllers ({', '.join(MOTOR_CONTROLLERS)}); "
                         f"got {device!r}")
    if device is None:
        shared = False
        try:
            answer = probe(path, timeout=timeout, devices=MOTOR_CONTROLLERS, log=log)
        except PortError as exc:
            if "busy" not in str(exc):
                raise
            shared = True
            answer = probe(path, timeout=timeout, devices=MOTOR_CONTROLLERS, log=log,
                           exclusive=False)
        if answer is None:
            raise DriverError("kit stop", f"{path}: no motor controller answered (tried the "
                                          f"ODrive and the DPRALTE drives" +
                                          (", on a port another program holds)" if shared
                                           else ")"))
        device, baudrate = answer.device, baudrate or answer.baudrate
        time.sleep(0.01)
    if device == "odrive":
        return _stop_odrive(path, baudrate or 115200, timeout)
    return _stop_dpralte(path, baudrate or 115200, timeout)

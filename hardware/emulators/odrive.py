"""ODrive v3.x, firmware 0.5.x, ASCII protocol (``protocols.md`` §4): the device side.

Two axes, each with the state machine a driver meets: IDLE at power-up, a full calibration
(requested state 3) that takes ``calibration_time`` seconds before the axis is calibrated
and back in IDLE, closed loop (8) refused with ``AXIS_ERROR_INVALID_STATE`` until then,
velocity commands that move the wheel only in closed loop, and the watchdog. The encoder is
the backend's wheel through the gearbox, quantised at the encoder's CPR. Replies follow the
firmware: no echo, ``\\r\\n`` line ends, checksums only when asked, ``r`` values cut to 9
characters, a bad checksum dropped silently.

The watchdog runs as in firmware 0.5.x (``Axis::watchdog_feed``/``watchdog_check``): a feed
(``v``, ``p``, ``q``, ``c``, ``t``, ``u``, entering closed loop) reloads the counter with
the time-out in force then; while ``config.enable_watchdog`` is set the counter runs down in
every state, and when it runs out the axis gets ``WATCHDOG_TIMER_EXPIRED`` (0x800), its
motor is disarmed and it falls to IDLE — at that instant, whoever moves the world on
(``backend.at``) — and the error comes back at once after ``sc`` until the watchdog is fed.
Enabling it without a feed after power-up (the counter holds 0) stops the axis at once, as
the firmware does. ``watchdog_expired_at`` keeps when each axis was stopped.
"""

from __future__ import annotations

import math
from functools import partial
from typing import Any

from hardware.emulators.backends import IdealWheels
from hardware.emulators.core import Device, Faults
from kit.drivers.checksums import odrive_checksum

__all__ = ["ODriveEmulator"]

IDLE, FULL_CALIBRATION, CLOSED_LOOP = 1, 3, 8
ERROR_INVALID_STATE = 0x01
ERROR_WATCHDOG = 0x800
# 0.5.1 numbers states as 0.4.x did (5 = SENSORLESS_CONTROL); 0.5.2-0.5.6 drop 5 and add
# 11-13 (protocols.md §4.6)
VALID_STATES = {"0.5.1": set(range(0, 11)), "0.5.6": set(range(0, 14)) - {5}}


class _Axis:
    def __init__(self, index: int) -> None:
        self.index = index
        self.current_state = IDLE
        self.error = 0
        self.control_mode = 3  # POSITION_CONTROL, the firmware default
        self.input_mode = 1
        self.input_vel = 0.0
        self.calibrated = False
        self.calibration_done_at: float | None = None
        self.watchdog_timeout = 0.0
        self.watchdog_enabled = False
        self.watchdog_deadline = 0.0  # when the counter, last reloaded by a feed, runs out
        self.watchdog_expired_at: float | None = None
        self.last_feed = 0.0


class ODriveEmulator(Device):
    """An ODrive on the host's port.

    Parameters
    ----------
    backend : wheels (:class:`~hardware.emulators.backends.IdealWheels` by default, or a
        :class:`~hardware.emulators.backends.SimBackend`); axis 0 drives wheel 0 (right),
        axis 1 wheel 1 (left), as the Uiabot is wired.
    gear_ratio, cpr : motor turns per wheel turn and encoder counts per motor turn.
    axis_signs : +1/−1 per axis: the Uiabot's left motor is mounted mirrored.
    firmware : ``"0.5.6"`` (states 0–13 without 5) or ``"0.5.1"`` (0–10).
    calibration_time : seconds a full calibration takes.
    transport : ``"usb"`` (the Uiabot's: a CDC-ACM port, whose baud setting the device
        ignores, protocols.md §4.1) or ``"uart"`` (115200 8N1 only; another rate is noise).
    """

    name = "odrive"
    baudrate = 115200

    def __init__(self, backend: Any = None, gear_ratio: float = 20.0, cpr: int = 20480,
                 axis_signs: tuple[int, int] = (1, -1), firmware: str = "0.5.6",
                 calibration_time: float = 12.0, vbus_voltage: float = 12.1,
                 faults: Faults | None = None, transport: str = "usb") -> None:
        super().__init__(faults)
        if firmware not in VALID_STATES:
            raise ValueError(f"firmware must be one of {sorted(VALID_STATES)}; got {firmware!r}")
        if transport not in ("usb", "uart"):
            raise ValueError(f"transport is 'usb' or 'uart'; got {transport!r}")
        self.transport = transport
        self.backend = backend or IdealWheels()
        self.gear_ratio = float(gear_ratio)
        self.cpr = int(cpr)
        self.axis_signs = axis_signs
        self.firmware = firmware
        self.calibration_time = float(calibration_time)
        self.vbus_voltage = float(vbus_voltage)
        self.axes = [_Axis(0), _Axis(1)]
        self._line = bytearray()
        self._dropping = False
        self.serial_number = "2061377C3548"

    @classmethod
    def for_robot(cls, backend: Any, **options: Any) -> ODriveEmulator:
        """Gearing, encoder and motor signs from the backend's robot description."""
        d = backend.description
        return cls(backend, gear_ratio=d.gear_ratio, cpr=d.encoder_resolution,
                   axis_signs=(d.parameters["drive"].get("right_motor_sign", 1),
                               d.parameters["drive"].get("left_motor_sign", 1)), **options)

    def hears(self, host_baud: int, device_baud: int) -> bool:
        return self.transport == "usb" or host_baud == device_baud

    # ------------------------------------------------------------------ the motors
    def _update(self, now: float) -> None:
        self.backend.advance(now)  # runs any watchdog that ran out before now, at its time
        for axis in self.axes:
            if axis.current_state == FULL_CALIBRATION and axis.calibration_done_at is not None \
                    and now >= axis.calibration_done_at:
                axis.calibrated = True
                axis.current_state = IDLE
                axis.calibration_done_at = None
            self._check_watchdog(axis, now)

    def stream(self, now: float) -> None:
        self._update(now)  # the firmware's control loop runs whether or not a host talks

    def _feed(self, axis: _Axis, now: float) -> None:
        axis.last_feed = now
        axis.watchdog_deadline = now + axis.watchdog_timeout
        self._arm(axis)

    def _arm(self, axis: _Axis) -> None:
        """Have the backend stop the axis at the instant its watchdog runs out."""
        if axis.watchdog_enabled and hasattr(self.backend, "at"):
            self.backend.at(axis.watchdog_deadline, partial(self._check_watchdog, axis))

    def _check_watchdog(self, axis: _Axis, now: float) -> None:
        if not axis.watchdog_enabled or now < axis.watchdog_deadline or \
                axis not in self.axes:  # (an axis from before a reboot)
            return
        first = not axis.error & ERROR_WATCHDOG
        axis.error |= ERROR_WATCHDOG
        if axis.current_state != IDLE or axis.calibration_done_at is not None:
            axis.calibration_done_at = None
            axis.current_state = IDLE  # motor disarmed: the state machine falls to IDLE
            self._wheel_command(axis)
        if first:
            axis.watchdog_expired_at = axis.watchdog_deadline

    def _wheel_command(self, axis: _Axis) -> None:
        turns = axis.input_vel if (axis.current_state == CLOSED_LOOP and
                                   axis.control_mode == 2) else 0.0
        rad_s = turns * 2 * math.pi / self.gear_ratio
        self.backend.set_wheel_speed(axis.index, self.axis_signs[axis.index] * rad_s)

    def _enter(self, axis: _Axis, state: int, now: float) -> None:
        if state not in VALID_STATES[self.firmware]:
            axis.error |= ERROR_INVALID_STATE
            axis.current_state = IDLE
        elif state == FULL_CALIBRATION:
            axis.current_state = FULL_CALIBRATION
            axis.calibration_done_at = now + self.calibration_time
        elif state == CLOSED_LOOP:
            if axis.calibrated and not axis.error:
                axis.current_state = CLOSED_LOOP
                self._feed(axis, now)  # the firmware feeds on entering closed loop
            else:
                axis.error |= ERROR_INVALID_STATE
                axis.current_state = IDLE
        elif state in (0, IDLE):
            axis.current_state = IDLE
        else:
            axis.current_state = state  # other states are accepted and held
        self._wheel_command(axis)

    def position(self, axis: _Axis) -> float:
        """Encoder ``pos_estimate`` [motor turns], quantised at the CPR."""
        turns = self.axis_signs[axis.index] * self.backend.wheel_angle(axis.index) * \
            self.gear_ratio / (2 * math.pi)
        return math.floor(turns * self.cpr) / self.cpr

    def velocity(self, axis: _Axis) -> float:
        return self.axis_signs[axis.index] * self.backend.wheel_speed(axis.index) * \
            self.gear_ratio / (2 * math.pi)

    # ------------------------------------------------------------------ properties
    def _property(self, path: str) -> tuple[Any, Any] | None:
        """(getter, setter) of a property path, or None if there is no such property."""
        if path == "vbus_voltage":
            return (lambda: self.vbus_voltage), None
        if path in ("serial_number",):
            return (lambda: int(self.serial_number, 16)), None
        if not (path.startswith("axis0.") or path.startswith("axis1.")):
            return None
        axis = self.axes[int(path[4])]
        rest = path[6:]

        def setter(attr: str, kind: type) -> Any:
            def write(value: str) -> None:
                setattr(axis, attr, kind(float(value)) if kind is not bool
                        else bool(int(float(value))))
            return write

        table: dict[str, tuple[Any, Any]] = {
            "current_state": ((lambda: axis.current_state), None),
            "requested_state": ((lambda: 0), "state"),
            "error": ((lambda: axis.error), setter("error", int)),
            "motor.error": ((lambda: 0), None),
            "encoder.error": ((lambda: 0), None),
            "controller.error": ((lambda: 0), None),
            "motor.is_calibrated": ((lambda: int(axis.calibrated)), None),
            "encoder.is_ready": ((lambda: int(axis.calibrated)), None),
            "encoder.config.cpr": ((lambda: self.cpr), None),
            "encoder.pos_estimate": ((lambda: self.position(axis)), None),
            "encoder.vel_estimate": ((lambda: self.velocity(axis)), None),
            "encoder.shadow_count": ((lambda: round(self.position(axis) * self.cpr)), None),
            "controller.config.control_mode": ((lambda: axis.control_mode),
                                               setter("control_mode", int)),
            "controller.config.input_mode": ((lambda: axis.input_mode),
                                             setter("input_mode", int)),
            "controller.input_vel": ((lambda: axis.input_vel), "input_vel"),
            "config.watchdog_timeout": ((lambda: axis.watchdog_timeout),
                                        setter("watchdog_timeout", float)),
            "config.enable_watchdog": ((lambda: axis.watchdog_enabled),
                                       setter("watchdog_enabled", bool)),
        }
        return table.get(rest)

    @staticmethod
    def _format(value: Any) -> str:
        if isinstance(value, bool):
            return "1" if value else "0"
        if isinstance(value, int):
            return str(value)
        return f"{value:f}"

    # ------------------------------------------------------------------ the line protocol
    def receive(self, data: bytes, now: float) -> None:
        for b in data:
            if b in (0x0A, 0x0D, 0x21):  # \n \r !
                if not self._dropping and self._line:
                    self._handle(self._line.decode("ascii", "replace"), now)
                self._line.clear()
                self._dropping = False
            elif not self._dropping:
                self._line.append(b)
                if len(self._line) > 255:  # the firmware drops lines over 256 bytes
                    self._line.clear()
                    self._dropping = True

    def _handle(self, line: str, now: float) -> None:
        line = line.split(";", 1)[0]
        checksummed = False
        if "*" in line:
            text, _, given = line.partition("*")
            try:
                expected = int(given.strip())
            except ValueError:
                return
            if odrive_checksum(text) != expected:
                return  # the firmware ignores a line whose checksum does not match
            line, checksummed = text, True
        line = line.strip()
        if not line:
            return
        self._update(now)
        for reply in self._execute(line, now):
            if checksummed:
                reply = f"{reply}*{odrive_checksum(reply)}"
            self.send((reply + "\r\n").encode("ascii"), now)

    def error_reply(self, reply: bytes) -> bytes | None:
        return b"unknown command\r\n"

    def _axis(self, token: str) -> _Axis | str:
        try:
            n = int(token)
        except ValueError:
            return "invalid command format"
        if not 0 <= n < 2:
            return f"invalid motor {n}"
        return self.axes[n]

    def _execute(self, line: str, now: float) -> list[str]:
        parts = line.split()
        cmd, args = parts[0], parts[1:]
        if cmd in ("v", "p", "q", "c", "t", "u", "f"):
            if not args:
                return ["invalid command format"]
            axis = self._axis(args[0])
            if isinstance(axis, str):
                return [axis]
            if cmd == "f":
                self.event(f"feedback{axis.index}", now)
                return [f"{self.position(axis):f} {self.velocity(axis):f}"]
            self._feed(axis, now)
            if cmd == "u":
                return []
            if len(args) < 2:
                return ["invalid command format"]
            try:
                value = float(args[1])
            except ValueError:
                return ["invalid command format"]
            if cmd == "v":
                axis.control_mode = 2
                axis.input_vel = value
                self._wheel_command(axis)
            return []  # position/torque commands are accepted; the emulator moves on v only
        if cmd == "r":
            if len(args) != 1:
                return ["invalid command format"]
            prop = self._property(args[0])
            if prop is None:
                return ["invalid property"]
            return [self._format(prop[0]())[:9]]
        if cmd == "w":
            if len(args) != 2:
                return ["invalid command format"]
            prop = self._property(args[0])
            if prop is None or prop[1] is None:
                return ["invalid property"]
            try:
                value = float(args[1])
            except ValueError:
                return ["not implemented"]
            axis = self.axes[int(args[0][4])]
            if prop[1] == "state":
                self._enter(axis, int(value), now)
            elif prop[1] == "input_vel":
                axis.input_vel = value
                self._wheel_command(axis)
            else:
                prop[1](args[1])
                if args[0].endswith("config.enable_watchdog"):
                    self._arm(axis)
                    self._check_watchdog(axis, now)  # enabled with a spent counter
                self._wheel_command(axis)
            return []
        if cmd == "sc":
            for axis in self.axes:
                axis.error = 0
                self._check_watchdog(axis, now)  # a spent watchdog sets it again at once
            return []
        if cmd in ("ss", "se"):
            return []
        if cmd == "sr":
            self.axes = [_Axis(0), _Axis(1)]
            for axis in self.axes:
                self._wheel_command(axis)
            return []
        if cmd == "i":
            return ["Hardware version: 3.6-24V", f"Firmware version: {self.firmware}",
                    f"Serial number: {self.serial_number}"]
        if cmd.startswith("es") and cmd[2:] == "l":
            return ["encoder set to " + " ".join(args[1:2])] if len(args) >= 2 else \
                ["invalid command format"]
        if cmd == "h":
            return ["Please see documentation for more details", "",
                    "Available commands syntax reference:"]
        return ["unknown command"]

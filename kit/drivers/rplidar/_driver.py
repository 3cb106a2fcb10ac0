"""The RPLidar A1 driver: health, info, the standard and express scans, whole turns, each
stamped with when its first sample was measured.

**Stamps.** The head takes a sample every ``sample time`` (``GET_SAMPLERATE``, asked at
:meth:`RPLidar.start`; 500 µs, the A1's 2000 samples/s, if the device does not answer),
so node ``i`` of a scan was measured at ``T0 + i · sample time``; the arrival of each
chunk of nodes bounds ``T0`` (:class:`~kit.drivers.timing.SampleClock`). A turn's
``LaserScan`` is stamped with its first node's time and carries ``scan_time`` and
``time_increment`` from the same clock, so the turns of a start-up backlog get their own
times, one turn apart, and stamps increase strictly.

**The first command gets through.** :meth:`RPLidar.start` first sends 130 × ``A5 25``
(STOP): they complete whatever request an earlier program left unfinished in the lidar's
receiver (the longest carries 255 payload bytes) and stop a scan left running; then it asks
for the health, once more if the first exchange fails.
"""

from __future__ import annotations

import time
from collections import Counter
from collections.abc import Callable
from typing import Any

from kit import msgs
from kit.drivers.errors import DeviceError, DeviceTimeout, ProtocolError, failed_twice
from kit.drivers.port import Link
from kit.drivers.rplidar._protocol import (
    BAUDRATE,
    CAPSULE,
    DEVICE,
    EXPRESS_SCAN,
    GET_HEALTH,
    GET_INFO,
    GET_SAMPLERATE,
    RESET,
    SCAN,
    STOP,
    CapsuleParser,
    Node,
    NodeParser,
    _Resynchronising,
    encode_request,
    parse_descriptor,
)
from kit.drivers.rplidar._turns import Turn, TurnAssembler, revolution_to_scan
from kit.drivers.timing import SampleClock

FILL = bytes.fromhex("A525") * 130
"""STOP 130 times: completes any request left half sent (≤ 259 bytes) and ends aligned."""
A1_SAMPLE_TIME = 500e-6
"""the A1's standard scan: 2000 samples/s (its datasheet), when GET_SAMPLERATE is not
answered."""


class RPLidar:
    """An RPLidar A1 on a serial port: health, info, the standard scan, and full turns as
    counter-clockwise ``LaserScan`` messages (:meth:`read_scan`).

    Parameters
    ----------
    port : str or serial port
        ``"/dev/ttyUSB0"``, a pseudo-terminal, any pyserial URL, or an open port.
    timeout : float
        Seconds to wait for a reply, and for a complete turn, before
        :class:`DeviceTimeout`.
    clock, sleep : callables
        What the driver waits with (wall time, or an emulator's logical clock).
    frame_id, beams : str, int
        The scans' frame and number of beams.
    baudrate : int
        115200, the A1's only rate (other models: 256000).
    stamp : callable, optional
        Seconds for header stamps; the wall clock by default on a real port (the logical
        clock when ``clock`` is one).
    min_nodes, min_span_deg : int, float
        The plausibility limits of a turn (:class:`TurnAssembler`).

    The A1's motor runs while DTR is low; a pseudo-terminal cannot set DTR (the ``OSError``
    is caught), and its emulator keeps the motor running.
    """

    def __init__(self, port: Any, timeout: float = 1.0,
                 clock: Callable[[], float] = time.monotonic,
                 sleep: Callable[[float], None] = time.sleep,
                 frame_id: str = "laser_link", beams: int = 360, *, baudrate: int = BAUDRATE,
                 stamp: Callable[[], float] | None = None, min_nodes: int = 100,
                 min_span_deg: float = 330.0) -> None:
        self.link = Link(DEVICE, port, baudrate, 0.01, clock, sleep, stamp)
        self.timeout = timeout
        self.frame_id = frame_id
        self.beams = beams
        self.parser: _Resynchronising = NodeParser(strict=True)
        self.turns = TurnAssembler(min_nodes=min_nodes, min_span_deg=min_span_deg)
        self.scanning = False
        self.express = False
        self.last_turn: Turn | None = None
        self.skipped_before_reply = 0
        """bytes skipped while looking for a reply's descriptor."""
        self.sample_times = (A1_SAMPLE_TIME, A1_SAMPLE_TIME / 2)
        """seconds per sample (standard scan, express scan), from the device if it says."""
        self.clock_of_samples: SampleClock | None = None
        self.samples = 0
        """nodes decoded since the scan started (the sample clock's count)."""
        self.reordered = 0
        """turns whose stamp had to be moved past the one before (never, if all is well)."""
        self._stalls_before = 0
        self._last_stamp = -float("inf")
        self._ready: list[Turn] = []
        self._pending = bytearray()
        self._resume = (False, False)

    def _motor(self, run: bool) -> None:
        try:
            self.link.port.dtr = not run
        except (OSError, AttributeError):
            pass  # a pseudo-terminal cannot set DTR (protocols.md §0)
        except self.link.errors as exc:  # the port itself failed
            with self.link.guard("motor"):
                raise exc

    def _clear(self, what: str) -> None:
        self.link.clear(what)
        self._pending.clear()

    def _await_descriptor(self, kind: int, what: str) -> tuple[int, int]:
        """Skip bytes until a response descriptor of type ``kind``; (length, mode)."""
        link, buf = self.link, self._pending
        deadline = link.clock() + self.timeout
        while True:
            i = buf.find(b"\xa5\x5a")
            while i >= 0 and len(buf) - i >= 7:
                length, mode, reply = parse_descriptor(bytes(buf[i:i + 7]))
                if reply == kind:
                    self.skipped_before_reply += i
                    del buf[:i + 7]
                    return length, mode
                i = buf.find(b"\xa5\x5a", i + 1)
            keep = i if i >= 0 else max(len(buf) - 1, 0)  # an A5 may start the next read
            self.skipped_before_reply += keep
            del buf[:keep]
            if link.clock() >= deadline:
                raise DeviceTimeout(DEVICE, f"{what}: no reply within {self.timeout:g} s "
                                            f"(no descriptor of type 0x{kind:02X})")
            buf += link.read_some(what)

    def _take(self, n: int, what: str) -> bytes:
        buf = self._pending
        if len(buf) < n:
            buf += self.link.read_exact(n - len(buf), self.timeout, what)
        data = bytes(buf[:n])
        del buf[:n]
        return data

    def _command(self, command: int, what: str, expect_type: int | None,
                 payload: bytes | None = None, length: int | None = None) -> bytes:
        self._clear(what)
        self.link.write(encode_request(command, payload), what)
        if expect_type is None:
            return b""
        size, mode = self._await_descriptor(expect_type, what)
        if mode == 1:
            return b""  # a stream follows
        if length is not None and size != length:
            raise ProtocolError(DEVICE, f"{what}: a {size}-byte reply, expected {length}")
        return self._take(size, what)

    def health(self) -> tuple[int, int]:
        """(status 0 good / 1 warning / 2 error, error code)."""
        data = self._command(GET_HEALTH, "get health", 0x06, length=3)
        return data[0], int.from_bytes(data[1:3], "little")

    def info(self) -> dict[str, Any]:
        data = self._command(GET_INFO, "get info", 0x04, length=20)
        return {"model": data[0], "firmware": (data[2], data[1]), "hardware": data[3],
                "serial": data[4:20].hex().upper()}

    def sample_time_us(self) -> tuple[int, int]:
        """Microseconds per sample: (standard scan, express scan)."""
        data = self._command(GET_SAMPLERATE, "get sample rate", 0x15, length=4)
        return int.from_bytes(data[0:2], "little"), int.from_bytes(data[2:4], "little")

    def clear_line(self) -> None:
        """Complete whatever request an earlier program left unfinished in the lidar and stop
        any scan (:data:`FILL`); drop what came meanwhile."""
        self.link.write(FILL, "clear the line")
        self.link.sleep(0.002 + 10 * len(FILL) / self.link.baudrate)
        self._clear("clear the line")

    def reset(self, wait: float = 2.0) -> None:
        self._command(RESET, "reset", None)
        self.link.sleep(wait)
        self._clear("reset")

    def _begin(self, request: bytes, kind: int, record: int, what: str,
               parser: _Resynchronising) -> None:
        self._motor(True)
        self._command(STOP, "stop", None)
        self.link.sleep(0.002)
        self._clear("stop")
        self.link.write(request, what)
        size, mode = self._await_descriptor(kind, what)
        if (size, mode) != (record, 1):
            raise ProtocolError(DEVICE, f"{what}: the descriptor announces {size}-byte "
                                        f"records in mode {mode}, not a stream of {record}-byte "
                                        f"records")
        self.parser = parser
        self.turns.reset()
        self._ready = []
        self.express = kind == 0x82
        period = self.sample_times[1 if self.express else 0]
        per_node = CAPSULE / 32 if self.express else 5
        self._stalls_before = self.stalls
        self.clock_of_samples = SampleClock(period, 10 * per_node / self.link.baudrate)
        self.samples = 0
        self.scanning = True

    @property
    def stalls(self) -> int:
        """Times nothing came for longer than the sample clock's window while scanning
        (:attr:`~kit.drivers.timing.SampleClock.restarts`): a host that read nothing (its
        backlog's turns then stamped late, by up to the stall, until the stream caught up;
        bytes beyond the port's buffer lost, as with any UART) or a head that sent nothing.
        0 when all is well."""
        clock = self.clock_of_samples
        return self._stalls_before + (clock.restarts if clock is not None else 0)

    def start(self) -> None:
        """Line cleared (:meth:`clear_line`), motor on, health checked (asked once more if
        the first exchange fails; a device in error is reset once), sample time asked,
        standard scan on."""
        self._motor(True)
        self.clear_line()
        try:
            status, code = self.health()
        except (DeviceTimeout, ProtocolError) as exc:
            if self.link.failure is not None:
                raise
            self.clear_line()
            try:
                status, code = self.health()
            except (DeviceTimeout, ProtocolError) as again:
                raise failed_twice(again, exc) from None
        if status == 2:
            self.reset()
            status, code = self.health()
            if status == 2:
                raise DeviceError(DEVICE, f"health: error 0x{code:04X} after a reset", code)
        try:
            timeout, self.timeout = self.timeout, min(self.timeout, 0.25)
            standard, express = self.sample_time_us()
            if standard and express:
                self.sample_times = (standard * 1e-6, express * 1e-6)
        except (DeviceTimeout, ProtocolError):
            pass  # older firmware: the A1's datasheet rate
        finally:
            self.timeout = timeout
        self._begin(encode_request(SCAN), 0x81, 5, "scan", NodeParser(strict=True))

    def start_express(self) -> None:
        """Like :meth:`start`, in express mode (legacy capsules, ``A5 82 05 00 00 00 00 00``):
        more samples per second; the kit's A1 normally uses the standard scan."""
        self._begin(encode_request(EXPRESS_SCAN, bytes(5)), 0x82, CAPSULE, "express scan",
                    CapsuleParser())

    def stop(self) -> None:
        self._command(STOP, "stop", None)
        self.link.sleep(0.002)
        self._clear("stop")
        self.scanning = False
        self._motor(False)

    def reopen(self) -> None:
        """Open the port again after it failed (the lidar unplugged and back, so stopped)
        and scan again as before (standard or express)."""
        if self.scanning:  # (kept across tries while the lidar is not back)
            self._resume = (True, self.express)
        self.scanning = False
        self.link.reopen()
        scanning, express = self._resume
        if scanning:
            self.start()
            if express:
                self.start_express()
        self._resume = (False, False)

    def read_turn(self) -> Turn:
        """The next complete, plausible turn (:class:`Turn`, its times those its nodes were
        measured at), or :class:`DeviceTimeout` after ``timeout`` seconds saying what came
        instead."""
        if not self.scanning:
            raise ProtocolError(DEVICE, "read: call start() first")
        link = self.link
        deadline = link.clock() + self.timeout
        clock = self.clock_of_samples
        assert clock is not None
        while not self._ready:
            if link.clock() >= deadline:
                refused = sum(getattr(self.parser, "refused", Counter()).values())
                raise DeviceTimeout(DEVICE, f"read scan: no complete turn within "
                                            f"{self.timeout:g} s (since the scan started: "
                                            f"{self.turns.summary()}; {self.parser.skipped} "
                                            f"bytes skipped, {refused} impossible nodes)")
            data = link.read_some("read scan")
            arrived = link.stamp()
            if self._pending:
                data, self._pending = bytes(self._pending) + data, bytearray()
            nodes = self.parser.feed(data)
            first = self.samples
            self.samples += len(nodes)
            if nodes:  # (an empty read bounds nothing: the head may have stopped sending)
                clock.observe(self.samples, arrived)
                times = [clock.time_of(first + k) for k in range(len(nodes))]
                self._ready.extend(self.turns.push(nodes, times))
        turn = self._ready.pop(0)
        if turn.started <= self._last_stamp:
            self.reordered += 1
            shift = self._last_stamp + 1e-6 - turn.started
            turn = Turn(turn.nodes, turn.started + shift, turn.ended + shift)
        self._last_stamp = turn.started
        self.last_turn = turn
        return turn

    def read_revolution(self) -> list[Node]:
        """The nodes of the next complete turn (from one start flag to the next)."""
        return list(self.read_turn().nodes)

    def read_scan(self) -> msgs.LaserScan:
        """The next complete turn as a counter-clockwise ``LaserScan``, stamped when its
        first node was measured; ``scan_time`` is the turn's duration by the same clock."""
        turn = self.read_turn()
        scan_time = max(turn.ended - turn.started, 1e-3)
        return revolution_to_scan(turn.nodes, msgs.Time.from_sec(turn.started), self.frame_id,
                                  self.beams, scan_time)

    def close(self) -> None:
        self.link.close()

"""What every emulator shares: a logical clock, seeded fault injection, the device base
class, an in-process serial port on the logical clock, and a pseudo-terminal server.

A device is a state machine fed with the host's bytes at a time ``now`` and asked for the
bytes it has sent by a time ``now``; it never reads a clock itself. That is what lets the
same device run on a pseudo-terminal in real time (:class:`PtyServer`) or in lock-step with
a driver on a logical clock (:class:`LogicalPort`), where a 40 s bring-up takes
milliseconds.
"""

from __future__ import annotations

import array
import fcntl
import math
import os
import pty
import random
import re
import select
import termios
import threading
import time
import tty
from dataclasses import dataclass, fields
from typing import Any

__all__ = ["BAUD_CONSTANTS", "Clock", "Device", "Faults", "LogicalPort", "PtyServer",
           "port_baudrate"]

BAUD_CONSTANTS = {getattr(termios, name): int(name[1:]) for name in dir(termios)
                  if re.fullmatch(r"B\d+", name) and int(name[1:]) > 0}
"""termios speed constant → baud rate, for every standard rate of this system."""
BOTHER = 0o010000  # Linux: the rate is in termios2's c_ospeed (how pyserial sets 256000)
TCGETS2 = 0x802C542A  # ioctl reading struct termios2 (x86, arm; pyserial uses the same)


def port_baudrate(fd: int) -> int | None:
    """The baud rate a terminal (a pseudo-terminal's master or slave) is set to: a standard
    rate from its speed constant, a custom one (``BOTHER``) from ``termios2``; 0 for a rate
    that cannot be read, ``None`` when the terminal cannot be asked at all (closed)."""
    try:
        speed = termios.tcgetattr(fd)[4]
    except termios.error:
        return None
    if speed in BAUD_CONSTANTS:
        return BAUD_CONSTANTS[speed]
    if speed == BOTHER:
        buf = array.array("i", [0] * 64)
        try:
            fcntl.ioctl(fd, TCGETS2, buf)
        except OSError:
            return 0
        return int(buf[10])  # c_iflag, c_oflag, c_cflag, c_lflag, c_line + c_cc[19], c_ispeed
    return 0


class Clock:
    """A logical clock: ``clock()`` is the time now [s]; ``clock.sleep(dt)`` moves it on.

    Pass ``clock`` and ``clock.sleep`` to a driver and the driver's time-outs and waits run
    on it, so nothing ever waits in wall time.
    """

    def __init__(self, start: float = 0.0) -> None:
        self.now = float(start)

    def __call__(self) -> float:
        return self.now

    def sleep(self, seconds: float) -> None:
        if seconds > 0:
            self.now += seconds

    def __repr__(self) -> str:
        return f"Clock(now={self.now:.6f})"


@dataclass(frozen=True)
class Faults:
    """Seeded fault injection on what a device sends.

    ``flip``, ``drop`` and ``duplicate`` are per-byte probabilities (a flipped byte has one
    random bit inverted); ``delay`` is the probability that a reply (or streamed chunk) comes
    ``delay_s`` late; ``silence`` the probability that the device stops answering for
    ``silence_s``; ``error`` the probability that a request gets the device's error reply
    instead of its answer. The same seed injects the same faults.
    """

    seed: int = 0
    flip: float = 0.0
    drop: float = 0.0
    duplicate: float = 0.0
    delay: float = 0.0
    delay_s: float = 0.05
    silence: float = 0.0
    silence_s: float = 1.0
    error: float = 0.0

    def __post_init__(self) -> None:
        for name in ("flip", "drop", "duplicate", "delay", "silence", "error"):
            p = getattr(self, name)
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"fault probability {name} must be in [0, 1]; got {p}")
        for name in ("delay_s", "silence_s"):
            if not getattr(self, name) >= 0:
                raise ValueError(f"{name} must be >= 0; got {getattr(self, name)}")

    @property
    def any(self) -> bool:
        return any((self.flip, self.drop, self.duplicate, self.delay, self.silence, self.error))

    @classmethod
    def parse(cls, text: str) -> Faults:
        """``"seed=3,flip=0.001,drop=0.01"`` (the command line's ``--faults``)."""
        known = {f.name: f.type for f in fields(cls)}
        values: dict[str, Any] = {}
        for item in filter(None, (part.strip() for part in text.split(","))):
            key, sep, value = item.partition("=")
            if not sep or key not in known:
                raise ValueError(f"unknown fault {item!r}; known: {', '.join(known)}")
            values[key] = int(value) if key == "seed" else float(value)
        return cls(**values)


class Device:
    """The device side of a protocol. Subclasses implement :meth:`receive` (the host's
    bytes) and may implement :meth:`stream` (output that flows without a request); both
    answer through :meth:`send`, which applies the transmission time at the device's baud
    rate and the fault injection.

    ``host_baud`` is the rate the host's port is set to (a pseudo-terminal's or a
    :class:`LogicalPort`'s); a device whose ``baudrate`` differs hears garbage and sends
    garbage, as a real serial link does — at any rate the device does not run at, standard
    or not. A device on USB (CDC-ACM), where the rate is a setting nobody uses, overrides
    :meth:`hears`.
    """

    name = "device"
    baudrate = 115200
    latency = 0.0005
    """seconds from the end of a request to the first byte of the reply."""

    def __init__(self, faults: Faults | None = None) -> None:
        self.faults = faults or Faults()
        self.rng = random.Random(self.faults.seed)
        self._out: list[tuple[float, bytes, int]] = []
        self._silent_until = -math.inf
        self._line_free = 0.0  # when the device's transmitter is free again
        self.received = 0
        self.sent = 0
        self.lost = 0
        """bytes the host's side did not take (its buffer full: a host that stopped reading)."""
        self.events: dict[str, list[float]] = {}
        """what the device did that a host records, by kind (``"turn"``, ``"imu"``,
        ``"feedback"`` …), each with the time it did it [s, the device's clock]."""

    def event(self, kind: str, at: float) -> None:
        """Note that the device did ``kind`` at ``at`` (its own clock)."""
        self.events.setdefault(kind, []).append(at)

    def stats(self) -> dict[str, Any]:
        """What the device sent and did: bytes each way, those the host's full buffer did
        not take (:attr:`lost`), and its :attr:`events`."""
        return {"device": self.name, "sent": self.sent, "received": self.received,
                "lost": self.lost,
                "events": {kind: list(times) for kind, times in self.events.items()}}

    # ------------------------------------------------------------------ to implement
    def receive(self, data: bytes, now: float) -> None:
        raise NotImplementedError

    def stream(self, now: float) -> None:
        """Schedule whatever the device sends by itself up to ``now`` (default: nothing)."""

    def error_reply(self, reply: bytes) -> bytes | None:
        """The error reply the fault injector may put in place of ``reply`` (default: none)."""
        return None

    # ------------------------------------------------------------------ plumbing
    def hears(self, host_baud: int, device_baud: int) -> bool:
        """Whether a host at ``host_baud`` and the device at ``device_baud`` understand each
        other (a UART: only at the same rate)."""
        return host_baud == device_baud

    def byte_time(self, n: int) -> float:
        return 10.0 * n / self.baudrate

    def send(self, data: bytes, now: float, *, reply: bool = True) -> None:
        """Queue ``data`` to go out at ``now`` (after the link is free), faults applied."""
        if not data:
            return
        f = self.faults
        if f.any:
            rng = self.rng
            if now < self._silent_until:
                return
            if f.silence and rng.random() < f.silence:
                self._silent_until = now + f.silence_s
                return
            if reply and f.error and rng.random() < f.error:
                data = self.error_reply(data) or data
            if f.delay and rng.random() < f.delay:
                now += f.delay_s
            if f.flip or f.drop or f.duplicate:
                out = bytearray()
                for b in data:
                    if f.drop and rng.random() < f.drop:
                        continue
                    if f.flip and rng.random() < f.flip:
                        b ^= 1 << rng.randrange(8)
                    out.append(b)
                    if f.duplicate and rng.random() < f.duplicate:
                        out.append(b)
                data = bytes(out)
        start = max(now + (self.latency if reply else 0.0), self._line_free)
        self._line_free = start + self.byte_time(len(data))
        self._out.append((self._line_free, data, self.baudrate))

    def feed(self, data: bytes, now: float, host_baud: int | None = None) -> None:
        """Bytes from the host; at a mismatched baud rate the device hears noise."""
        self.received += len(data)
        if host_baud is not None and not self.hears(host_baud, self.baudrate):
            return
        self.receive(data, now)

    def read(self, now: float, host_baud: int | None = None) -> bytes:
        """Everything the device has finished sending by ``now``."""
        self.stream(now)
        if not self._out:
            return b""
        due = [item for item in self._out if item[0] <= now]
        if not due:
            return b""
        self._out = [item for item in self._out if item[0] > now]
        out = bytearray()
        for _, chunk, baud in due:
            self.sent += len(chunk)
            if host_baud is not None and not self.hears(host_baud, baud):
                # sent at another speed: the host's UART samples noise
                out += bytes(self.rng.randrange(256) for _ in chunk)
            else:
                out += chunk
        return bytes(out)

    def next_due(self) -> float | None:
        """When the next queued byte lands (``None`` if nothing is queued)."""
        return min((item[0] for item in self._out), default=None)

    def flush_output(self) -> None:
        self._out.clear()


class LogicalPort:
    """A pyserial-like port connected in-process to a device, on a logical :class:`Clock`.

    Writing takes the bytes' transmission time; reading returns what the device has sent by
    now and, when nothing has come, lets the clock run on to the next byte or the read's
    time-out (so a silent device times out in logical time). Several ports may share one
    clock (a robot's devices), which also drives a simulator behind them.
    """

    def __init__(self, device: Device, clock: Clock | None = None,
                 baudrate: int | None = None, timeout: float | None = 0.01) -> None:
        self.device = device
        self.clock = clock or Clock()
        self.baudrate = int(baudrate or device.baudrate)
        self.timeout = timeout
        self.is_open = True
        self._buffer = bytearray()
        self.name = f"logical://{device.name}"

    def _check(self) -> None:
        if not self.is_open:
            import serial

            raise serial.PortNotOpenError()

    def _pull(self) -> None:
        self._buffer += self.device.read(self.clock.now, self.baudrate)

    def write(self, data: bytes) -> int:
        self._check()
        data = bytes(data)
        self.clock.now += 10.0 * len(data) / self.baudrate
        self.device.feed(data, self.clock.now, self.baudrate)
        return len(data)

    @property
    def in_waiting(self) -> int:
        self._check()
        self._pull()
        return len(self._buffer)

    def read(self, size: int = 1) -> bytes:
        self._check()
        self._pull()
        if len(self._buffer) < size:
            deadline = self.clock.now + (self.timeout if self.timeout is not None else 1.0)
            while len(self._buffer) < size and self.clock.now < deadline:
                nxt = self.device.next_due()
                target = deadline if nxt is None else min(max(nxt, self.clock.now), deadline)
                # streaming devices schedule as time passes: never jump more than 1 ms blind
                self.clock.now = min(target, self.clock.now + 0.001) if nxt is None else target
                self._pull()
        out = bytes(self._buffer[:size])
        del self._buffer[:size]
        return out

    def reset_input_buffer(self) -> None:
        self._check()
        self._pull()
        self._buffer.clear()

    def reset_output_buffer(self) -> None:
        self._check()

    def flush(self) -> None:
        self._check()

    def close(self) -> None:
        self.is_open = False

    # a pseudo-terminal cannot change DTR/RTS either (protocols.md §0)
    @property
    def dtr(self) -> bool:
        return False

    @dtr.setter
    def dtr(self, value: bool) -> None:
        raise OSError(25, "Inappropriate ioctl for device")

    @property
    def rts(self) -> bool:
        return False

    @rts.setter
    def rts(self, value: bool) -> None:
        raise OSError(25, "Inappropriate ioctl for device")

    def __enter__(self) -> LogicalPort:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class PtyServer:
    """Serves one or more devices, each on its own pseudo-terminal, in real time.

    ``path`` (or ``paths[i]``) is what a serial driver opens: the slave's name
    (``/dev/pts/N``), or, given ``links``, a symbolic link to it at a path of your choosing
    — as udev's ``/dev/serial/by-id/…`` links are — which stays the same when the device is
    unplugged (:meth:`unplug`: its pseudo-terminal closed, the link removed) and plugged
    back in (:meth:`replug`: a new pseudo-terminal behind the same link, and, for a device
    that lost power, a new device). Each slave is put in raw mode at once (protocols.md §0)
    and kept open by the server so the master never sees a hang-up between a driver's
    sessions. All devices are served by one thread, so devices that share a simulated robot
    never race. ``epoch`` is the wall-clock time [s since the epoch] of the devices' time 0.
    """

    def __init__(self, device: Device | list[Device], clock: Any = time.monotonic,
                 start: float = 0.0, links: list[str | None] | None = None) -> None:
        self.devices = list(device) if isinstance(device, (list, tuple)) else [device]
        self.clock = clock
        self.links = list(links) if links is not None else [None] * len(self.devices)
        if len(self.links) != len(self.devices):
            raise ValueError(f"{len(self.devices)} devices but {len(self.links)} links")
        self.masters: list[int] = []
        self.slaves: list[int] = []
        self.paths: list[str] = []
        self.plugged: list[bool] = []
        self._lock = threading.Lock()
        for i in range(len(self.devices)):
            self.masters.append(-1)
            self.slaves.append(-1)
            self.paths.append("")
            self.plugged.append(False)
            self._plug(i)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.t0 = clock() - start  # the devices' time: ``start`` seconds now
        self.epoch = time.time() - start if clock is time.monotonic else 0.0

    def _plug(self, i: int) -> None:
        master, slave = pty.openpty()
        tty.setraw(slave)
        os.set_blocking(master, False)
        self.masters[i], self.slaves[i] = master, slave
        link = self.links[i]
        if link is None:
            self.paths[i] = os.ttyname(slave)
        else:
            if os.path.islink(link):
                os.unlink(link)
            os.symlink(os.ttyname(slave), link)
            self.paths[i] = link
        self.plugged[i] = True

    def unplug(self, i: int = 0) -> None:
        """Device ``i`` is unplugged: its pseudo-terminal closes (a driver reading it gets
        an input/output error) and its link disappears."""
        with self._lock:
            if not self.plugged[i]:
                return
            self.plugged[i] = False
            for fd in (self.masters[i], self.slaves[i]):
                try:
                    os.close(fd)
                except OSError:
                    pass
            link = self.links[i]
            if link is not None and os.path.islink(link):
                os.unlink(link)

    def replug(self, i: int = 0, device: Device | None = None) -> str:
        """Device ``i`` is plugged back in, at the same link (it needs ``links``); with
        ``device``, that device stands in for it (one that lost power starts afresh).
        Returns the path."""
        if self.links[i] is None:
            raise ValueError("replugging at the same path needs a link (PtyServer(links=...))")
        with self._lock:
            if device is not None:
                self.devices[i] = device
            if not self.plugged[i]:
                self._plug(i)
            return self.paths[i]

    @property
    def overrun(self) -> int:
        """Bytes the host's side did not take, over the devices served now (each its
        :attr:`Device.lost`)."""
        return sum(d.lost for d in self.devices)

    @property
    def device(self) -> Device:
        return self.devices[0]

    @property
    def path(self) -> str:
        return self.paths[0]

    @staticmethod
    def host_baud(master: int) -> int | None:
        return port_baudrate(master)

    def now(self) -> float:
        return self.clock() - self.t0

    def serve(self) -> None:
        """Run until :meth:`stop` (the command line runs this in the foreground)."""
        while not self._stop.is_set():
            with self._lock:
                channels = [(d, m) for d, m, up in zip(self.devices, self.masters,
                                                        self.plugged, strict=True) if up]
                unplugged = [d for d, up in zip(self.devices, self.plugged, strict=True)
                             if not up]
            by_fd = {master: device for device, master in channels}
            now = self.now()
            for device in unplugged:
                device.read(now)  # a device without its cable still runs (and is not heard)
            dues = [d.next_due() for d, _ in channels]
            wait = min([0.002] + [max(t - now, 0.0) for t in dues if t is not None])
            try:
                readable, _, _ = select.select(list(by_fd), [], [], wait)
                now = self.now()
                for master in readable:
                    data = os.read(master, 4096)
                    if data:
                        by_fd[master].feed(data, now, self.host_baud(master))
                for device, master in channels:
                    out = device.read(now, self.host_baud(master))
                    if out:
                        device.lost += self._write(master, out)
            except OSError:
                if self._stop.is_set():
                    return
                time.sleep(0.01)  # nobody on the other side right now, or just unplugged

    def _write(self, master: int, data: bytes) -> int:
        """Hand bytes to the host's side; what its full buffer cannot take is lost, as with
        a real UART whose host stops reading: how many bytes, returned."""
        try:
            written = os.write(master, data)
        except BlockingIOError:
            written = 0
        return len(data) - written

    def start(self) -> PtyServer:
        self._thread = threading.Thread(target=self.serve, daemon=True,
                                        name=f"emulator-{self.devices[0].name}")
        self._thread.start()
        return self

    def freeze(self) -> None:
        """The devices stop dead (a hung microcontroller): nothing is read or sent any more,
        the ports stay open."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)

    def stop(self) -> None:
        """Stop serving and close the ports: to a driver, the devices are unplugged."""
        self.freeze()
        for i in range(len(self.devices)):
            self.unplug(i)

    def __enter__(self) -> PtyServer:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()

"""Byte-level device emulators: the device side of each protocol in ``kit.drivers``.

Each emulator is a :class:`~hardware.emulators.core.Device` — a state machine fed with the
host's bytes at a time ``now`` — served either on a pseudo-terminal in real time
(:class:`~hardware.emulators.core.PtyServer`; ``python -m hardware.emulators DEVICE``
prints the port's path and serves until stopped) or in-process on a logical clock
(:class:`~hardware.emulators.core.LogicalPort`). Behind the motors, lidars and IMUs is a
backend: ideal wheels, or a ``sim`` robot (:class:`~hardware.emulators.backends.SimBackend`).
A device runs at its own baud rate only (a host at another rate hears noise), and a recorded
RPLidar stream can be played back as the device (:mod:`~hardware.emulators.replay`;
``python -m hardware.emulators rplidar --replay CAPTURE``).
"""

from hardware.emulators.core import Clock, Device, Faults, LogicalPort, PtyServer

__all__ = ["Clock", "Device", "Faults", "LogicalPort", "PtyServer"]

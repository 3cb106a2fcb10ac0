"""Device drivers over pyserial (any port URL): the byte protocols of the kit's devices.

One module per device: :mod:`~kit.drivers.dpralte` (the IGV's AMC servo drives),
:mod:`~kit.drivers.os5000` (its compass), :mod:`~kit.drivers.lms2xx` (its SICK scanner),
:mod:`~kit.drivers.odrive` (the Uiabot's motor controller), :mod:`~kit.drivers.bno055` (its
IMU), :mod:`~kit.drivers.rplidar` (its lidar); :mod:`~kit.drivers.bases` puts a robot's
motors, kinematics and odometry together (``UiabotBase``, ``IgvBase``). Check codes:
:mod:`~kit.drivers.checksums`; the port helper: :mod:`~kit.drivers.port`; errors:
:mod:`~kit.drivers.errors`. Every driver takes a port URL or an open port, ``baudrate=``
(the device's default rate), and ``clock`` and ``sleep`` callables so that it can run on an
emulator's logical clock; messages are stamped with the wall clock on a real port.

Live use: :mod:`~kit.drivers.reader` runs a driver in its own thread (reopening its device
after an unplug), :mod:`~kit.drivers.live` opens each device as a message source,
:mod:`~kit.drivers.probe` finds which device answers on a port (``kit probe``, ``kit
record``), :mod:`~kit.drivers.timing` dates samples by a device's own pace. Safety: the bases
arm the motor controllers' watchdogs, :mod:`~kit.drivers.safety` stops every base on the
program's way out, :mod:`~kit.drivers.stop` is ``kit stop``.
"""

from kit.drivers.errors import (
    ChecksumError,
    DeviceError,
    DeviceTimeout,
    DriverError,
    PortError,
    ProtocolError,
)

__all__ = ["ChecksumError", "DeviceError", "DeviceTimeout", "DriverError", "PortError",
           "ProtocolError"]

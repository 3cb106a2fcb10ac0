"""Device drivers over pyserial (any port URL): the byte protocols of the kit's devices.

One module per device: :mod:`~kit.drivers.dpralte` (the IGV's AMC servo drives),
:mod:`~kit.drivers.os5000` (its compass), :mod:`~kit.drivers.lms2xx` (its SICK scanner),
:mod:`~kit.drivers.odrive` (the Uiabot's motor controller), :mod:`~kit.drivers.bno055` (its
IMU), :mod:`~kit.drivers.rplidar` (its lidar); :mod:`~kit.drivers.bases` puts a robot's
motors, kinematics and odometry together (``UiabotBase``, ``IgvBase``). Check codes:
:mod:`~kit.drivers.checksums`; the port helper: :mod:`~kit.drivers.port`; errors:
:mod:`~kit.drivers.errors`. Every driver takes a port URL or an open port, and ``clock``
and ``sleep`` callables so that it can run on an emulator's logical clock.
"""

from kit.drivers.errors import ChecksumError, DeviceError, DeviceTimeout, DriverError, ProtocolError

__all__ = ["ChecksumError", "DeviceError", "DeviceTimeout", "DriverError", "ProtocolError"]

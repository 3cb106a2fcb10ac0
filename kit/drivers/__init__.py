"""Device drivers over pyserial (any port URL): the byte protocols of the kit's devices.

So far: :mod:`kit.drivers.dpralte` (the IGV's AMC servo drives) and
:mod:`kit.drivers.os5000` (its compass); the check codes of all six devices are in
:mod:`kit.drivers.checksums`. Errors: :mod:`kit.drivers.errors`.
"""

from kit.drivers.errors import ChecksumError, DeviceError, DeviceTimeout, DriverError, ProtocolError

__all__ = ["ChecksumError", "DeviceError", "DeviceTimeout", "DriverError", "ProtocolError"]

"""Robot hardware: robot descriptions (``hardware/robots``: URDF + parameter files, read by
:func:`kit.robots.load`) and byte-level device emulators (:mod:`hardware.emulators`)."""

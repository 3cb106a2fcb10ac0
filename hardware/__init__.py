"""Robot hardware: robot descriptions (``hardware/robots``: URDF + parameter files, read by
:func:`kit.robots.load`) and, later, byte-level device emulators."""

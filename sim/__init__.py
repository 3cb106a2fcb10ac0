"""The kit's simulator. For now a kinematic differential-drive model with imperfect wheels
and encoders (:mod:`sim.kinematic`); the pymunk world with traction, IMU and lidar follows.

``python -m sim demo`` drives each robot around a square and compares odometry with the truth.
"""

from sim.kinematic import DiffDriveModel, WheelErrors, drive_square

__all__ = ["DiffDriveModel", "WheelErrors", "drive_square"]

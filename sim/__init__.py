"""The kit's simulator: robots with real traction in a pymunk world, encoders, IMU, lidar,
walking people; rendering (:mod:`sim.render`) and ROS 2 bags (:mod:`sim.bag`).

    >>> from sim import Simulation
    >>> sim = Simulation(world="square", robot="uiabot", seed=1)
    >>> messages = sim.run(1.0, (10.0, 10.0))   # 1 s at 10 rad/s on both wheels
    >>> round(float(sim.ground_truth().pose[0]), 1)
    2.5

:mod:`sim.runner` runs closed loops: a simulation, nodes (odometry, fusion, …), a controller
and recorded signals. :mod:`sim.kinematic` keeps the lighter kinematic model with imperfect
wheels.
``python -m sim demo`` runs the headless see–think–act demo; ``python -m sim bench`` measures.
"""

from sim.kinematic import DiffDriveModel, WheelErrors, drive_square
from sim.simulation import Collision, GroundTruth, Physics, Simulation
from sim.world import BUILTIN_WORLDS, World, WorldError, load_world

__all__ = ["BUILTIN_WORLDS", "Collision", "DiffDriveModel", "GroundTruth", "Physics",
           "Simulation", "WheelErrors", "World", "WorldError", "drive_square", "load_world"]

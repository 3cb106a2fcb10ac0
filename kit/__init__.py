"""The kit's reference implementation: pure algorithms, ROS-shaped messages, robot models.

Modules (import the one you need; ``import kit`` itself pulls in neither matplotlib nor
pymunk):

* :mod:`kit.geometry`   SE(2) poses, ``wrap_angle``, quaternions
* :mod:`kit.msgs`       ROS 2 messages as frozen dataclasses
* :mod:`kit.rosconv`    conversion to and from ROS 2 types (rosbags), CDR bytes
* :mod:`kit.tf`         the transform tree
* :mod:`kit.robots`     robot descriptions (URDF + parameters)
* :mod:`kit.kinematics` differential-drive kinematics, the IGV's RPM equations
* :mod:`kit.odometry`   encoder ticks → pose, covariance, ``Odometry`` messages
* :mod:`kit.maps`       occupancy grids in the ROS map_server format (YAML + PGM)
* :mod:`kit.bag`        ROS 2 bags (MCAP) written and read (rosbags, imported lazily)
* :mod:`kit.drivers`    the devices' serial drivers, reader threads, ``kit record``/``probe``
* :mod:`kit.control`    DC motor model, discrete PID, cascade, step figures, tuning
* :mod:`kit.estimation` the EKF and a robot_localization-style fusion filter
* :mod:`kit.planning`   Nav2-style costmaps, Dijkstra/A*/Theta*, smoothing, Moving AI maps
* :mod:`kit.viz`        plotting (matplotlib, imported lazily)
"""

__version__ = "0.1.0"
__all__ = ["__version__"]

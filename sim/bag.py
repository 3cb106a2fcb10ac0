"""ROS 2 bags for simulated runs: the writer and reader live in :mod:`kit.bag` (the drivers'
``kit record`` writes bags too, and ``kit`` may not import ``sim``); this module keeps the
simulator's import path.
"""

from __future__ import annotations

from kit.bag import BagWriter, read_bag, write_bag

__all__ = ["BagWriter", "read_bag", "write_bag"]

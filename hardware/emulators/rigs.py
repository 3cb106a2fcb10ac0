"""A simulated robot wired to its emulated devices: the rig the real drivers drive.

``uiabot_rig()`` puts a Uiabot in a ``sim`` world and gives it an ODrive, an RPLidar A1 and
a BNO055, each on its own logical port, all on one clock that also steps the simulation;
``igv_rig()`` does the same for the IGV (two DPRALTE drives on one bus, the OS5000, the
LMS291). Hand the ports to the drivers with ``clock=rig.clock, sleep=rig.clock.sleep``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from hardware.emulators.backends import SimBackend
from hardware.emulators.bno055 import BNO055Emulator
from hardware.emulators.core import Clock, Device, Faults, LogicalPort
from hardware.emulators.dpralte import DpralteBusEmulator
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.odrive import ODriveEmulator
from hardware.emulators.os5000 import Os5000Emulator
from hardware.emulators.rplidar import RPLidarEmulator

__all__ = ["Rig", "igv_rig", "uiabot_rig"]


@dataclass
class Rig:
    clock: Clock
    backend: SimBackend
    devices: dict[str, Device]
    ports: dict[str, LogicalPort] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name, device in self.devices.items():
            self.ports[name] = LogicalPort(device, self.clock)

    @property
    def sim(self) -> Any:
        return self.backend.sim

    def driver_options(self) -> dict[str, Any]:
        return {"clock": self.clock, "sleep": self.clock.sleep}


def uiabot_rig(world: str = "square", seed: int = 0, start: Any = None, people: int = 0,
               faults: Faults | None = None, calibration_time: float = 12.0,
               firmware: str = "0.5.6", **sim_options: Any) -> Rig:
    """A simulated Uiabot with its ODrive (axis 0 right, axis 1 left, mirrored), RPLidar A1
    and BNO055; ``faults`` go to every device (each with its own seed offset)."""
    from sim import Simulation

    sim = Simulation(world=world, robot="uiabot", seed=seed, start=start, people=people,
                     **sim_options)
    backend = SimBackend(sim)

    def f(k: int) -> Faults | None:
        if faults is None:
            return None
        return Faults(**{**faults.__dict__, "seed": faults.seed + k})

    devices: dict[str, Device] = {
        "odrive": ODriveEmulator.for_robot(backend, firmware=firmware,
                                           calibration_time=calibration_time, faults=f(0)),
        "rplidar": RPLidarEmulator(backend, faults=f(1)),
        "bno055": BNO055Emulator(backend, faults=f(2)),
    }
    return Rig(Clock(), backend, devices)


def igv_rig(world: str = "aisle", seed: int = 0, start: Any = None, people: int = 0,
            faults: Faults | None = None, **sim_options: Any) -> Rig:
    """A simulated IGV with its two DPRALTE drives on one bus, OS5000 and LMS291."""
    from sim import Simulation

    sim = Simulation(world=world, robot="igv", seed=seed, start=start, people=people,
                     **sim_options)
    backend = SimBackend(sim)
    d = sim.descriptions[0]
    devices: dict[str, Device] = {
        "dpralte": DpralteBusEmulator(backend, counts_per_rev=d.encoder_resolution,
                                      faults=faults),
        "os5000": Os5000Emulator(backend, faults=faults),
        "lms2xx": LMS2xxEmulator(backend, faults=faults),
    }
    return Rig(Clock(), backend, devices)

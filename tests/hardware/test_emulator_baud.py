"""Emulators as strict as the devices about the baud rate: a host at any rate a device
does not run at — standard or not — hears noise and is not heard; the ODrive on USB, like
the real one, ignores the rate."""

from __future__ import annotations

import pytest
import serial

from hardware.emulators import Clock, LogicalPort, PtyServer
from hardware.emulators.bno055 import BNO055Emulator
from hardware.emulators.core import port_baudrate
from hardware.emulators.odrive import ODriveEmulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit.drivers import DeviceTimeout, bno055, odrive, rplidar


def test_the_emulator_reads_a_custom_rate_off_the_terminal():
    with PtyServer(RPLidarEmulator()) as server:
        port = serial.Serial(server.path, 256000, timeout=0.01)
        assert port_baudrate(server.masters[0]) == 256000
        port.baudrate = 115200
        assert port_baudrate(server.masters[0]) == 115200
        port.close()


def test_an_rplidar_opened_at_256000_baud_does_not_stream():
    with PtyServer(RPLidarEmulator()) as server:
        lidar = rplidar.RPLidar(server.path, timeout=0.3, baudrate=256000)
        with pytest.raises(DeviceTimeout, match="RPLidar: get health: no reply"):
            lidar.start()
        lidar.close()
        # the A1's own 115200 (a turn takes 0.15 s; the time-out is long for a loaded machine,
        # where the emulator's thread can be kept from streaming for a while)
        lidar = rplidar.RPLidar(server.path, timeout=5.0)
        lidar.start()
        assert len(lidar.read_revolution()) > 300


@pytest.mark.parametrize("baud", [9600, 57600, 230400, 250000])
def test_the_bno055_hears_only_115200(baud):
    clock = Clock()
    imu = bno055.BNO055(LogicalPort(BNO055Emulator(), clock, baudrate=baud), clock=clock,
                        sleep=clock.sleep, retries=1, baudrate=baud)
    with pytest.raises(DeviceTimeout, match="BNO055: read chip id: no reply"):
        imu.begin()


def test_the_odrive_on_usb_ignores_the_rate_and_on_its_uart_does_not():
    for transport, answers in (("usb", True), ("uart", False)):
        with PtyServer(ODriveEmulator(transport=transport)) as server:
            # the USB one answers: awaited as long as a loaded machine may take
            drive = odrive.ODrive(server.path, timeout=5.0 if answers else 0.3, baudrate=9600)
            if answers:
                assert drive.vbus_voltage() == pytest.approx(12.1)
            else:
                with pytest.raises(DeviceTimeout, match="ODrive: r vbus_voltage: no reply"):
                    drive.vbus_voltage()
            drive.close()
    with pytest.raises(ValueError, match="transport is 'usb' or 'uart'"):
        ODriveEmulator(transport="can")

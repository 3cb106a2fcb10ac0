"""Motors that stop: a program driving the emulated Uiabot or IGV over pseudo-terminals is
killed, terminated, interrupted, fails or ends; the emulated motor controllers say whether,
when and by whom the wheels were stopped — the host (at once: no watchdog error) or their
own watchdog (on the emulator's clock, within its time-out of the kill). Nothing here
measures how long anything took on this machine: only the emulator's own clock and states.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Callable

import pytest

from hardware.emulators import PtyServer
from hardware.emulators.backends import IdealWheels
from hardware.emulators.dpralte import COMMS_ERROR, DpralteBusEmulator
from hardware.emulators.odrive import ERROR_WATCHDOG, ODriveEmulator
from kit import cli

# A program as a terminal starts it: Ctrl-C raises KeyboardInterrupt. (Python leaves SIGINT
# ignored when it starts ignored, as it does under nohup or a shell's background job.)
# Replies are awaited for up to REPLY s instead of the devices' 0.25-0.5 s: what is tested is
# how the wheels stop, and on a heavily loaded machine the emulator's thread can be kept from
# answering a bring-up query for longer than a real device would take.
REPLY = 10.0
DRIVER = f"""
import signal, sys, time
signal.signal(signal.SIGINT, signal.default_int_handler)
from kit.drivers.bases import IgvBase, UiabotBase
from kit.drivers.odrive import ODrive
robot, path, timeout, how = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4]
if robot == "uiabot":
    base = UiabotBase(ODrive(path, timeout={REPLY}), watchdog_timeout=timeout)
    base.bring_up()
else:
    base = IgvBase(path, timeout={REPLY}, watchdog_timeout=timeout)
    base.start()
base.drive((0.2, 0.0))
print("driving", flush=True)
if how == "exception":
    raise RuntimeError("the program fails")
if how == "exit":
    sys.exit(0)
time.sleep(600)  # the command held, until the program is stopped from outside
"""

KERNEL_CODE = """
from kit.drivers.bases import IgvBase, UiabotBase
from kit.drivers.odrive import ODrive
base = UiabotBase(ODrive({path!r}, timeout={reply}), watchdog_timeout=5.0) if {robot!r} == \\
    "uiabot" else IgvBase({path!r}, timeout={reply}, watchdog_timeout=5.0)
base.bring_up() if {robot!r} == "uiabot" else base.start()
base.drive((0.2, 0.0))
"""


def until(condition: Callable[[], bool], what: str, limit: float = 60.0) -> None:
    """Wait for ``condition`` (``limit`` only gives up on a broken run; it is no bar)."""
    end = time.monotonic() + limit
    while not condition():
        if time.monotonic() > end:
            raise AssertionError(f"{what} never happened")
        time.sleep(0.01)


def serve(robot: str) -> tuple[PtyServer, IdealWheels, object]:
    wheels = IdealWheels()
    device = ODriveEmulator(wheels, calibration_time=0.2) if robot == "uiabot" else \
        DpralteBusEmulator(wheels)
    return PtyServer(device).start(), wheels, device


def drive_in_child(robot: str, path: str, timeout: float, how: str = "hold"
                   ) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-c", DRIVER, robot, path, str(timeout), how],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    line = proc.stdout.readline()
    assert line.strip() == "driving", proc.stderr.read()
    return proc


def stopped_by_the_host(robot: str, device: object) -> bool:
    if robot == "uiabot":
        return all(a.current_state == 1 and a.error == 0 and a.input_vel == 0.0 and
                   not a.watchdog_enabled for a in device.axes)
    return all(not d.enabled and not d.words[(0x02, 0x02)] & COMMS_ERROR and
               d.watchdog_timeout == 0 for d in device.drives.values())


@pytest.mark.parametrize("robot", ["uiabot", "igv"])
def test_sigkill_stops_both_wheels_within_the_watchdog_time(robot):
    """Nothing on the host can act on SIGKILL: the motor controllers' own watchdogs do."""
    timeout = 1.0
    server, wheels, device = serve(robot)
    try:
        proc = drive_in_child(robot, server.path, timeout)
        until(lambda: all(s != 0.0 for s in wheels.speeds), "the wheels turning")
        killed = server.now()
        proc.kill()
        proc.wait(30)
        if robot == "uiabot":
            until(lambda: all(a.current_state == 1 for a in device.axes), "the axes stopping")
            assert all(a.error == ERROR_WATCHDOG for a in device.axes)
            stops = [a.watchdog_expired_at for a in device.axes]
        else:
            until(lambda: not any(d.enabled for d in device.drives.values()), "the bridges off")
            assert all(d.words[(0x02, 0x02)] & COMMS_ERROR for d in device.drives.values())
            stops = [d.watchdog_expired_at for d in device.drives.values()]
        # on the emulator's clock: stopped no later than the time-out after the kill
        assert all(killed < t <= killed + timeout for t in stops), (killed, stops)
        assert wheels.speeds == [0.0, 0.0]
    finally:
        server.stop()


@pytest.mark.parametrize("robot", ["uiabot", "igv"])
@pytest.mark.parametrize("how", ["sigterm", "sigint", "exception", "exit"])
def test_the_host_stops_the_wheels_on_every_way_out(robot, how):
    """SIGTERM, Ctrl-C, an uncaught exception, the end of the program: the host stops the
    motors itself, before any watchdog could (a long time-out, so that only the host can
    have done it)."""
    server, wheels, device = serve(robot)
    try:
        proc = drive_in_child(robot, server.path, 30.0, how)
        if how in ("sigterm", "sigint"):
            until(lambda: all(s != 0.0 for s in wheels.speeds), "the wheels turning")
            proc.send_signal(signal.SIGTERM if how == "sigterm" else signal.SIGINT)
        code = proc.wait(30)
        assert code != 0 if how != "exit" else code == 0
        until(lambda: stopped_by_the_host(robot, device), "the host's stop")
        assert wheels.speeds == [0.0, 0.0]
    finally:
        server.stop()


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["uiabot", "igv"])
def test_a_notebook_kernel_shut_down_stops_the_wheels(robot):
    from jupyter_client.manager import KernelManager

    server, wheels, device = serve(robot)
    km = KernelManager(kernel_name="python3")
    km.start_kernel()
    try:
        kc = km.client()
        kc.start_channels()
        kc.wait_for_ready(timeout=120)
        code = KERNEL_CODE.format(path=server.path, robot=robot, reply=REPLY)
        reply = kc.execute_interactive(code, timeout=120)
        assert reply["content"]["status"] == "ok"
        until(lambda: all(s != 0.0 for s in wheels.speeds), "the wheels turning")
        kc.stop_channels()
        km.shutdown_kernel(now=False)  # what JupyterLab's "Shut Down Kernel" sends
        until(lambda: stopped_by_the_host(robot, device), "the host's stop")
        assert wheels.speeds == [0.0, 0.0]
    finally:
        if km.is_alive():
            km.shutdown_kernel(now=True)
        server.stop()


@pytest.mark.parametrize("robot", ["uiabot", "igv"])
def test_kit_stop_stops_a_robot_whose_program_still_holds_its_port(robot, capsys):
    """The program hangs holding the port: ``kit stop`` from another terminal shares the
    port, stops the motors and reads them back stopped."""
    server, wheels, device = serve(robot)
    try:
        proc = drive_in_child(robot, server.path, 30.0)
        until(lambda: all(s != 0.0 for s in wheels.speeds), "the wheels turning")
        assert cli.main(["stop", server.path]) == 0
        out = capsys.readouterr().out
        assert f"{'odrive' if robot == 'uiabot' else 'dpralte'} on {server.path}:" in out
        assert f"held by PID {proc.pid}" in out
        assert wheels.speeds == [0.0, 0.0]
        if robot == "uiabot":
            assert all(a.current_state == 1 for a in device.axes)
        else:
            assert not any(d.enabled for d in device.drives.values())
        proc.kill()
        proc.wait(30)
    finally:
        server.stop()


def test_kit_stop_stops_a_robot_left_running_without_a_watchdog(capsys):
    """A program killed with the watchdog off (``watchdog_timeout=0``): the wheels turn on
    until ``kit stop`` — named device, the port free again."""
    server, wheels, device = serve("uiabot")
    try:
        proc = drive_in_child("uiabot", server.path, 0.0)
        until(lambda: all(s != 0.0 for s in wheels.speeds), "the wheels turning")
        proc.kill()
        proc.wait(30)
        turned = list(wheels.angles)
        until(lambda: all(abs(a) > abs(b) for a, b in zip(wheels.angles, turned, strict=True)),
              "the wheels turning on after the kill")
        assert cli.main(["stop", f"odrive={server.path}"]) == 0
        assert "both axes IDLE" in capsys.readouterr().out
        assert all(a.current_state == 1 for a in device.axes) and wheels.speeds == [0.0, 0.0]
    finally:
        server.stop()


def test_kit_stop_refuses_what_is_not_a_motor_controller(capsys):
    assert cli.main(["stop", "rplidar=/dev/ttyKIT_NONE"]) == 2
    assert "kit stop stops motor controllers (odrive, dpralte)" in capsys.readouterr().err
    assert cli.main(["stop", "/dev/ttyKIT_NONE"]) == 1
    assert "no such port" in capsys.readouterr().err


def test_bases_refuse_bad_settings_and_commands_before_bring_up():
    from hardware.emulators import Clock, LogicalPort
    from kit.drivers import DriverError
    from kit.drivers.bases import UiabotBase

    clock = Clock()
    port = LogicalPort(ODriveEmulator(), clock)
    with pytest.raises(ValueError, match=r"watchdog_timeout is seconds >= 0"):
        UiabotBase(port, clock=clock, sleep=clock.sleep, watchdog_timeout=-1.0)
    with pytest.raises(ValueError, match=r"hold is seconds > 0"):
        UiabotBase(port, clock=clock, sleep=clock.sleep, hold=0.0)
    base = UiabotBase(port, clock=clock, sleep=clock.sleep)
    with pytest.raises(DriverError, match=r"drive: the motors are not under control — "
                                          r"bring_up\(\) first"):
        base.drive((0.1, 0.0))
    with pytest.raises(ValueError, match="a twist must be finite"):
        base.motor_speeds((float("nan"), 0.0))


def test_a_held_command_is_dropped_after_hold_seconds():
    """``hold=``: the keep-alive commands zero speed once no new command came for that
    long, and keeps the axes under control (the next command drives again)."""
    server, wheels, device = serve("uiabot")
    try:
        from kit.drivers.bases import UiabotBase
        from kit.drivers.odrive import ODrive

        with UiabotBase(ODrive(server.path, timeout=REPLY), watchdog_timeout=5.0,
                        hold=0.3) as base:
            base.bring_up()
            base.drive((0.2, 0.0))
            until(lambda: all(s != 0.0 for s in wheels.speeds), "the wheels turning")
            until(lambda: wheels.speeds == [0.0, 0.0], "the held command dropped")
            assert all(a.current_state == 8 and a.error == 0 for a in device.axes)
            base.drive((0.2, 0.0))
            until(lambda: all(s != 0.0 for s in wheels.speeds), "driving again")
        until(lambda: stopped_by_the_host("uiabot", device), "the stop on leaving the block")
    finally:
        server.stop()


def test_sigterm_leaves_a_programs_own_handler_in_charge():
    """A program with its own SIGTERM handler keeps it: the safety hooks only replace the
    default handlers."""
    code = """
import signal, sys
signal.signal(signal.SIGTERM, lambda *a: print("mine"))
from kit.drivers import safety
class B:
    def halt(self): pass
    def emergency_stop(self): print("stopped")
b = B()
safety.register(b)
import os; os.kill(os.getpid(), signal.SIGTERM)
print("alive")
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=60).stdout.split()
    assert out == ["mine", "alive", "stopped"]  # its handler, then the exit hook

"""``kit record --live``: what is recorded also goes to the live view, message for message."""

from __future__ import annotations

import subprocess
import sys

import pytest

from kit.drivers import _cli as cli


def test_a_bad_live_address_is_refused_before_any_device_is_opened(tmp_path, capsys):
    from kit.cli import main as kit_main

    assert kit_main(["record", "rplidar=/dev/ttyKIT_NONE", "--live", "nowhere:x", "--out",
                     str(tmp_path / "b")]) == 2
    assert "a live view's address is HOST:PORT or PORT" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()


@pytest.mark.slow
def test_every_recorded_message_also_reaches_the_live_callback(tmp_path):
    """The emulated Uiabot (its devices on pseudo-terminals, another process) recorded for
    2 s: the callback a live view hangs on record() sees each message the bag holds."""
    from kit.bag import bag_topics

    proc = subprocess.Popen([sys.executable, "-m", "hardware.emulators", "uiabot"],
                            stdout=subprocess.PIPE, text=True)
    seen: dict[str, int] = {}
    try:
        specs = [(name, path, None) for name, path in
                 (proc.stdout.readline().split() for _ in range(3))]
        counts = cli.record(specs, tmp_path / "bag", duration=2.0, log=lambda *a: None,
                            on_message=lambda t, ns, m: seen.__setitem__(t, seen.get(t, 0) + 1))
    finally:
        proc.terminate()
        proc.wait(10)
    assert seen == counts
    assert {t: n for t, (_, n) in bag_topics(tmp_path / "bag").items()} == counts
    assert {"/scan", "/imu", "/odom", "/tf", "/tf_static"} <= seen.keys()

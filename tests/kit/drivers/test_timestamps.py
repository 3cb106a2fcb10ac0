"""Honest timestamps: each message stamped with when its data was measured, by the device's
own timing, compared with the emulator's record of when it measured it (its event log, on
the logical clock) — including a start-up backlog, where stamping at the arrival of the
chunk would give several turns the same time."""

from __future__ import annotations

import numpy as np
import pytest

from hardware.emulators import Clock, LogicalPort
from hardware.emulators.lms2xx import LMS2xxEmulator
from hardware.emulators.os5000 import Os5000Emulator
from hardware.emulators.rplidar import RPLidarEmulator
from kit.drivers import lms2xx, os5000, rplidar
from kit.drivers.errors import DeviceTimeout
from kit.drivers.timing import SampleClock


def test_rplidar_turns_are_stamped_by_the_heads_own_timing_even_out_of_a_backlog():
    clock = Clock()
    device = RPLidarEmulator()
    port = LogicalPort(device, clock)
    lidar = rplidar.RPLidar(port, clock=clock, sleep=clock.sleep)
    lidar.start()
    assert lidar.sample_times[0] == pytest.approx(500e-6)  # from GET_SAMPLERATE
    clock.sleep(1.0)  # the host busy for a second: 5 turns pile up on the port
    backlog = port.in_waiting // 5
    turns = [lidar.read_turn() for _ in range(12)]
    assert backlog > 4 * 340
    starts = np.array([t.started for t in turns])
    assert np.all(np.diff(starts) > 0)  # strictly increasing
    # each turn's stamp is when the emulated head measured its first sample
    measured = np.array(device.events["turn"])
    matched = measured[np.abs(measured[:, None] - starts).argmin(axis=0)]
    assert np.abs(starts - matched).max() < 1e-3
    assert len(set(matched)) == len(turns)  # one turn each, none skipped or doubled
    # and a scan's duration is the turn's, by the same clock
    assert np.allclose([t.ended - t.started for t in turns[:-1]], np.diff(starts), atol=1e-6)
    assert lidar.reordered == 0


def test_rplidar_scans_of_a_steady_stream_come_at_the_heads_rate():
    clock = Clock()
    device = RPLidarEmulator(turns_per_second=5.5)
    lidar = rplidar.RPLidar(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    lidar.start()
    stamps = [lidar.read_scan().header.stamp.to_sec() for _ in range(30)]
    rate = (len(stamps) - 1) / (stamps[-1] - stamps[0])
    events = device.events["turn"]
    device_rate = (len(events) - 1) / (events[-1] - events[0])
    assert rate == pytest.approx(device_rate, rel=0.01) and device_rate == pytest.approx(
        5.5, rel=0.02)


def test_compass_sentences_are_stamped_by_the_compass_pace_out_of_a_backlog():
    clock = Clock()
    device = Os5000Emulator()
    compass = os5000.Os5000(LogicalPort(device, clock), clock=clock)
    compass.set_rate(20)
    clock.sleep(0.5)  # ten sentences waiting
    stamps = np.array([compass.read_stamped()[1] for _ in range(30)])
    assert np.all(np.diff(stamps) > 0)
    sent = np.array(device.events["sentence"])
    nearest = np.abs(sent[:, None] - stamps).min(axis=0)
    # after the pace is known (the first chunk's lines are dated by their bytes alone)
    assert np.abs(np.diff(stamps[12:]) - 0.05).max() < 1e-3 and nearest[12:].max() < 2e-3


def test_sick_scans_read_together_are_dated_back_to_back():
    clock = Clock()
    device = LMS2xxEmulator()
    scanner = lms2xx.LMS2xx(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    scanner.connect(38400, 180, 1.0)
    scanner.start()
    scanner.read_scan()
    clock.sleep(0.5)  # five telegrams of 372 bytes at 38400 baud wait on the port
    stamps = np.array([scanner.read_scan().header.stamp.to_sec() for _ in range(10)])
    gaps = np.diff(stamps)
    sent = 10 * 372 / 38400  # each telegram takes this long on the link
    assert np.all(gaps > 0) and np.all(gaps[5:] >= sent - 1e-9)  # as they were sent
    # the emulator measures a scan (1/75 s) then sends it: the stamp is the measurement's
    # start — for the telegrams after the backlog (those of the backlog are dated from the
    # read that found them: late by as long as they waited, at most one telegram)
    measured = np.array(device.events["scan"]) - 1 / 75
    nearest = np.abs(measured[:, None] - stamps).min(axis=0)
    assert nearest[6:].max() < 1e-3 and nearest.max() < sent


def test_the_sample_clock_takes_the_least_delayed_chunk_and_forgets_old_bounds():
    c = SampleClock(1e-3, transmission=0.0, window=1.0)  # sample i taken at i ms
    c.observe(100, arrival=0.2)  # sample 99 arrived 101 ms late
    c.observe(200, arrival=0.2)  # sample 199, 1 ms late
    c.observe(300, arrival=0.3005)  # sample 299, 1.5 ms late
    assert c.time_of(0) == pytest.approx(0.001)  # the least delayed chunk dates them all
    c = SampleClock(1e-3, transmission=0.0, window=1.0)
    c.observe(1000, arrival=1.0)  # sample 999 arrived 1 ms late
    c.observe(1999, arrival=2.0)  # a sample was lost on the line: the count is one short
    assert c.time_of(1998) == pytest.approx(1.999)  # (truly taken at 2.000 − 0.001 late)
    c.observe(2999, arrival=3.0)
    assert c.time_of(2998) == pytest.approx(2.999 + 0.001)  # the old bound forgotten
    assert c.restarts == 0  # a chunk every window: never started over
    with pytest.raises(ValueError, match="no sample has arrived yet"):
        SampleClock(1e-3).time_of(0)


def test_the_sample_clock_counts_the_stalls_after_which_it_dated_a_backlog_late():
    """A host that read nothing for longer than the window: the backlog's first chunk is the
    only bound left, so its samples are dated late (by up to the stall) until a prompt chunk
    comes; the clock says so once per stall."""
    c = SampleClock(1e-3, transmission=0.0, window=1.0)  # sample i taken at i ms
    c.observe(500, arrival=0.5)  # on time
    c.observe(3000, arrival=3.0)  # 2.5 s later: 2,500 samples in one chunk, on time
    assert c.restarts == 1 and c.time_of(0) == pytest.approx(0.001)
    c = SampleClock(1e-3, transmission=0.0, window=1.0)
    c.observe(500, arrival=0.5)
    c.observe(2000, arrival=3.0)  # the backlog's first chunk: sample 1999 read 1.0 s late
    assert c.restarts == 1 and c.time_of(1999) == pytest.approx(3.0)  # late, never early
    c.observe(3000, arrival=3.001)  # the rest of it at once: caught up
    assert c.time_of(2999) == pytest.approx(3.001)
    c.observe(3500, arrival=3.5)
    assert c.restarts == 1  # prompt chunks: no new stall
    with pytest.raises(ValueError, match="period > 0"):
        SampleClock(0.0)


def test_a_host_that_stalls_while_the_lidar_streams_is_told_and_its_stamps_stay_in_order():
    """The host reads nothing for 3 s (longer than the sample clock's 2 s window) while the
    head turns on: the driver counts the stall, ``kit record``'s note for the lidar says it,
    and the turns after it are stamped in order, never before the head measured them."""
    from kit.drivers.live import open_source

    clock = Clock()
    device = RPLidarEmulator()
    source = open_source("rplidar", LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    before = [source.read()[0][1].header.stamp.to_sec() for _ in range(5)]
    assert source.health is not None and source.health() is None  # all is well so far
    clock.sleep(3.0)
    after = [source.read()[0][1].header.stamp.to_sec() for _ in range(25)]
    stamps = np.array(before + after)
    assert np.all(np.diff(stamps) > 0)
    measured = np.array(device.events["turn"])
    # never early: by each stamp, at least as many turns measured as scans stamped
    taken = np.searchsorted(measured, stamps + 1e-3, side="right")
    assert np.all(taken >= np.arange(1, len(stamps) + 1))
    note = source.health()
    assert note is not None and note.startswith("1 time nothing came for over 2 s")
    source.close()


class _Frozen(RPLidarEmulator):
    """An emulator that sends nothing from ``a`` to ``b`` seconds (its process stopped),
    then goes on from the present, as the emulator does after any long pause."""

    def __init__(self, a: float, b: float) -> None:
        super().__init__()
        self.a, self.b = a, b

    def stream(self, now: float) -> None:
        if not self.a <= now < self.b:
            super().stream(now)


def test_a_head_that_sends_nothing_for_a_while_is_not_dated_by_the_reads_that_found_nothing():
    """While the driver keeps reading and nothing comes (the head's process stopped for
    2.5 s), an empty read says nothing of when the next sample is taken: the turns after the
    pause are stamped when they were measured, not earlier as if the head had sampled on."""
    clock = Clock()
    device = _Frozen(1.0, 3.5)
    lidar = rplidar.RPLidar(LogicalPort(device, clock), clock=clock, sleep=clock.sleep)
    lidar.start()
    stamps = []
    while clock.now < 6.0:
        try:
            stamps.append(lidar.read_turn().started)
        except DeviceTimeout:
            pass  # the pause: no complete turn within a second
    stamps = np.array(stamps)
    measured = np.array(device.events["turn"])
    assert measured[(measured > 1.2) & (measured < 3.5)].size == 0  # the pause, in its log
    after = stamps[stamps > 1.2]
    assert after.size >= 10
    nearest = np.abs(measured[:, None] - after).min(axis=0)
    assert nearest.max() < 1e-3  # each turn after the pause at its measured time
    assert np.all(np.diff(stamps) > 0) and lidar.stalls == 1

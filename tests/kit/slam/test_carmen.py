"""CARMEN logs and relation files, read back against the counts and numbers in the data
READMEs (kummerle2009-slam-benchmark, flirtlib-carmen-graph-logs, intel-lab)."""

from __future__ import annotations

import gzip

import numpy as np
import pytest

from kit.slam import carmen

FLASER = ("FLASER 3 1.5 2.0 81.91 0.1 0.2 0.3 0.1 0.2 0.3 1134864629.895 pippo 0.5\n")
ROBOTLASER = ("ROBOTLASER1 0 -1.570796 3.150319 0.008727 50.0 0.1 0 3 1.4 1.5 1.6 0 "
              "1.0 2.0 0.5 1.1 2.1 0.6 0 0 0 0 0 1134864630.5 x 0.25\n")


def test_flaser_and_robotlaser_lines_are_parsed_field_by_field(tmp_path):
    path = tmp_path / "a.log"
    path.write_text("# comment\nPARAM robot_x 1\n" + FLASER + ROBOTLASER +
                    "ODOM 1 2 0.5 0.3 0.1 0 99.5 host 0.1\n")
    log = carmen.read_carmen(path)
    f, r = log.lasers
    assert f.kind == "FLASER" and f.timestamp == 1134864629.895 and f.logger_timestamp == 0.5
    assert f.ranges.tolist() == [1.5, 2.0, 81.91]
    assert f.laser_pose.tolist() == [0.1, 0.2, 0.3] == f.robot_pose.tolist()
    assert r.angle_min == -1.570796 and r.angle_increment == 0.008727 and r.range_max == 50.0
    assert r.laser_pose.tolist() == [1.0, 2.0, 0.5] and r.robot_pose.tolist() == [1.1, 2.1, 0.6]
    assert r.timestamp == 1134864630.5
    assert log.odometry[0].pose.tolist() == [1, 2, 0.5] and log.odometry[0].timestamp == 99.5
    assert log.skipped == {"PARAM": 1}


def test_flaser_beams_span_the_front_half_circle_symmetrically():
    for n, step_deg in ((361, 0.5), (181, 1.0), (180, 1.0)):
        a0, inc = carmen.flaser_geometry(n)
        assert inc == pytest.approx(np.radians(step_deg))
        assert a0 + inc * (n - 1) == pytest.approx(-a0)


def test_no_return_beams_become_max_range_beams():
    from kit import perception

    log_line = carmen._flaser(FLASER.split(), "x")
    scan = carmen.laser_to_scan(log_line)
    assert perception.max_range_beams(scan).tolist() == [False, False, True]
    assert perception.valid_returns(scan).tolist() == [True, True, False]


def test_malformed_lines_are_named(tmp_path):
    path = tmp_path / "bad.log"
    path.write_text("FLASER 3 1.5 2.0\n")
    with pytest.raises(carmen.CarmenError, match=r"bad.log:1: FLASER needs"):
        carmen.read_carmen(path)
    path.write_text(FLASER.replace("2.0", "two"))
    with pytest.raises(carmen.CarmenError, match=r"bad.log:1: not a number"):
        carmen.read_carmen(path)
    path.write_text("ODOM 1 2\n")
    with pytest.raises(carmen.CarmenError, match="ODOM needs"):
        carmen.read_carmen(path)
    path.write_text("PARAM a b\n")
    with pytest.raises(carmen.CarmenError, match="no FLASER or ROBOTLASER1"):
        carmen.read_carmen(path)
    (tmp_path / "r.relations").write_text("1 2 3\n")
    with pytest.raises(carmen.CarmenError, match="8 fields"):
        carmen.read_relations(tmp_path / "r.relations")
    with pytest.raises(carmen.CarmenError, match="no such file"):
        carmen.read_carmen(tmp_path / "none.log")
    (tmp_path / "x.log.gz").write_bytes(b"not gzip")
    with pytest.raises(carmen.CarmenError, match="unreadable"):
        carmen.read_carmen(tmp_path / "x.log.gz")


def test_gzipped_logs_read_like_plain_ones(tmp_path):
    with gzip.open(tmp_path / "a.log.gz", "wt") as f:
        f.write(FLASER)
    assert carmen.read_carmen(tmp_path / "a.log.gz").lasers[0].ranges.tolist() == \
        [1.5, 2.0, 81.91]


@pytest.mark.dataset
def test_csail_log_and_relations_have_the_readme_counts(shared_data):
    bench = shared_data / "kummerle2009-slam-benchmark"
    log = carmen.read_carmen(bench / "mit-csail.clf.gz")
    assert len(log.lasers) == 1988 and not log.odometry
    assert all(len(r.ranges) == 361 for r in log.lasers)
    t = log.laser_timestamps
    assert t[0] == pytest.approx(1134864629.895) and t[-1] == pytest.approx(1134865053.892)
    rel = carmen.read_relations(bench / "mit-csail.relations")
    assert len(rel) == 1172
    assert len(carmen.read_relations(bench / "fr-clinic.relations")) == 2820  # '#' header


@pytest.mark.dataset
def test_flirtlib_robotlaser_scans_are_the_csail_flaser_scans(shared_data):
    """The FLIRTLib CSAIL log's ROBOTLASER1 lines carry the geometry FLASER leaves out."""
    log = carmen.read_carmen(shared_data / "kummerle2009-slam-benchmark/mit-csail.clf.gz")
    fl = carmen.read_carmen(shared_data / "flirtlib-carmen-graph-logs/mit-cscail.log.gz")
    assert len(fl.lasers) == 1051 and fl.skipped == {"VERTEX2": 1051, "EDGE2": 1189}
    by_time = {round(r.timestamp, 3): r for r in log.lasers}
    for r in fl.lasers[::50]:
        f = by_time[round(r.timestamp, 3)]
        assert np.array_equal(f.ranges, r.ranges)
        assert f.angle_min == pytest.approx(r.angle_min, abs=1e-6)
        assert f.angle_increment == pytest.approx(r.angle_increment, abs=1e-6)

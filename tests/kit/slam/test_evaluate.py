"""The Kümmerle et al. relation metric, against the numbers the benchmark's README measured
for raw odometry and for the FLIRTLib SLAM-corrected CSAIL trajectory."""

from __future__ import annotations

import numpy as np
import pytest

from kit import geometry
from kit.slam import carmen, evaluate


def test_an_exact_trajectory_has_zero_error_in_any_global_frame():
    rng = np.random.default_rng(0)
    truth = np.column_stack([rng.uniform(-5, 5, (50, 2)), rng.uniform(-3, 3, 50)])
    t = np.arange(50.0)
    i, j = rng.integers(0, 50, 40), rng.integers(0, 50, 40)
    rel = carmen.Relations(t[i], t[j], geometry.relative(truth[i], truth[j]))
    moved = geometry.compose([3.0, -2.0, 1.0], truth)
    e = evaluate.relation_errors(t, moved, rel)
    assert e.evaluated.all()
    assert np.allclose(e.translational, 0, atol=1e-9) and np.allclose(e.rotational, 0,
                                                                      atol=1e-9)


def test_error_is_measured_in_the_frame_of_the_estimate():
    # ε = δ̂⁻¹ ⊕ δ*: a 90° turn then 1 m, estimated as a 90° turn then 1.2 m
    rel = carmen.Relations(np.array([0.0]), np.array([1.0]), np.array([[0.0, 1.0, np.pi / 2]]))
    e = evaluate.relation_errors([0.0, 1.0], [[0, 0, 0], [0, 1.2, np.pi / 2 + 0.05]], rel)
    assert e.translational[0] == pytest.approx(0.2)
    assert e.rotational[0] == pytest.approx(0.05)


def test_unmatched_relations_are_left_out_and_bad_input_rejected():
    rel = carmen.Relations(np.array([0.0, 5.0]), np.array([1.0, 6.0]), np.zeros((2, 3)))
    e = evaluate.relation_errors([0.0, 1.0002], [[0, 0, 0], [0, 0, 0]], rel)
    assert e.evaluated.tolist() == [True, False]
    with pytest.raises(ValueError, match="same non-zero length"):
        evaluate.relation_errors([0.0], np.zeros((2, 3)), rel)
    with pytest.raises(ValueError, match="no relation"):
        evaluate.summarize(evaluate.relation_errors([10.0], np.zeros((1, 3)), rel))


@pytest.mark.dataset
def test_raw_odometry_and_flirtlib_poses_score_the_readme_figures(shared_data):
    bench = shared_data / "kummerle2009-slam-benchmark"
    rel = carmen.read_relations(bench / "mit-csail.relations")
    log = carmen.read_carmen(bench / "mit-csail.clf.gz")
    odom = np.array([r.robot_pose for r in log.lasers])
    s = evaluate.summarize(evaluate.relation_errors(log.laser_timestamps, odom, rel))
    assert s.count == 1172
    assert s.translational_mean == pytest.approx(1.682, abs=6e-4)  # README: 1.682 ± 5.292
    assert s.translational_std == pytest.approx(5.292, abs=6e-4)
    assert (round(s.rotational_mean_deg, 2), round(s.rotational_std_deg, 2)) == (5.07, 8.24)
    local = evaluate.summarize(evaluate.relation_errors(log.laser_timestamps, odom, rel), 1.0)
    assert local.count == 1040 and round(local.translational_mean, 3) == 0.032
    fl = carmen.read_carmen(shared_data / "flirtlib-carmen-graph-logs/mit-cscail.log.gz")
    s = evaluate.summarize(evaluate.relation_errors(
        fl.laser_timestamps, np.array([r.robot_pose for r in fl.lasers]), rel))
    assert (round(s.translational_mean, 4), round(s.translational_std, 4)) == (0.0045, 0.0093)
    assert (round(s.rotational_mean_deg, 3), round(s.rotational_std_deg, 3)) == (0.046, 0.087)

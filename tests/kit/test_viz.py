"""kit.viz: each plot draws the data it is given on the axes it returns."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import pytest

from kit import viz


@pytest.fixture(autouse=True)
def _close():
    yield
    plt.close("all")


def test_plot_signals_draws_each_signal_and_the_levels():
    t = np.linspace(0, 1, 11)
    ax = viz.plot_signals(t, {"a": t**2, "b": -t}, levels=(0.5,), ylabel="v")
    lines = ax.get_lines()
    np.testing.assert_array_equal(lines[0].get_ydata(), t**2)
    np.testing.assert_array_equal(lines[1].get_ydata(), -t)
    assert lines[2].get_ydata()[0] == 0.5  # the dashed level
    assert [x.get_text() for x in ax.get_legend().get_texts()] == ["a", "b"]
    with pytest.raises(ValueError, match="shape"):
        viz.plot_signals(t, {"short": t[:3]})


def test_plot_step_response_shows_the_setpoint_band():
    t = np.linspace(0, 1, 11)
    ax = viz.plot_step_response(t, 5 * (1 - np.exp(-5 * t)), setpoint=5.0)
    np.testing.assert_allclose(ax.get_lines()[0].get_ydata(), 5 * (1 - np.exp(-5 * t)))
    ys = ax.patches[0].get_patch_transform().transform([[0, 0], [1, 1]])[:, 1]
    assert ys.tolist() == pytest.approx([4.9, 5.1])
    _fig, ax2 = plt.subplots()
    assert viz.plot_step_response(t, {"x": t, "y": t}, ax=ax2) is ax2


def test_plot_lidar_turn_puts_clockwise_nodes_on_the_right_and_drops_misses():
    # an RPLidar node at clockwise 90° is on the robot's right: y < 0
    ax = viz.plot_lidar_turn(np.radians(-np.array([90.0, 0.0, 45.0])), [2.0, 1.0, 0.0])
    xy = ax.collections[0].get_offsets()
    np.testing.assert_allclose(xy, [[0.0, -2.0], [1.0, 0.0]], atol=1e-12)
    with pytest.raises(ValueError, match="equal length"):
        viz.plot_lidar_turn([0.0, 1.0], [1.0])


def test_plot_kalman_track_and_headings():
    t = np.arange(5) * 0.1
    ax = viz.plot_kalman_track(t, t, t + 0.1, t, np.full(5, 0.05))
    np.testing.assert_allclose(ax.get_lines()[2].get_ydata(), t)
    yaw = np.array([3.0, 3.1, -3.1, -3.0, -2.9])  # across ±π: unwrapped, not a jump
    ax = viz.plot_headings(t, yaw, {"fused": yaw})
    assert np.all(np.diff(ax.get_lines()[0].get_ydata()) > 0)
    np.testing.assert_allclose(ax.get_lines()[-1].get_ydata(), np.degrees(np.unwrap(yaw)))

"""Particle clouds animated over a map: every frame is drawn into the HTML, with a progress
bar over the frames unless KIT_FAST=1."""

from __future__ import annotations

import matplotlib
import numpy as np

from kit import mapping, msgs, viz

matplotlib.use("Agg")


def _animation(frames: int):
    m = mapping.OccupancyGridMap(0.1)
    m.insert_scan(msgs.LaserScan(angle_min=-1.0, angle_increment=0.5, range_min=0.1,
                                 range_max=5.0, ranges=np.array([1.0, 2.0, 1.5])), [0, 0, 0])
    rng = np.random.default_rng(1)
    clouds = [rng.normal(0, 0.3, (20, 3)) for _ in range(frames)]
    truth = np.zeros((frames, 3))
    return viz.animate_particles(m.to_msg(), clouds, truth, truth)


def test_the_html_holds_every_frame_and_a_bar_counts_them(monkeypatch, capsys):
    monkeypatch.delenv("KIT_FAST", raising=False)
    import kit.progress

    counted = []  # tqdm redraws at most every 0.1 s: which counts it prints depends on the
    # machine's speed, so the frames the bar was advanced by are counted where they pass
    bar = kit.progress.progress

    def counting(iterable, **kwargs):
        for item in bar(iterable, **kwargs):
            counted.append(item)
            yield item

    monkeypatch.setattr(kit.progress, "progress", counting)
    html = viz.animation_html(_animation(4), desc="drawing")
    assert html.count("data:image/png;base64") == 4
    assert counted == [0, 1, 2, 3]
    err = capsys.readouterr().err
    assert "drawing" in err and "/4" in err  # the bar drawn, with the number of frames


def test_no_bar_under_kit_fast(monkeypatch, capsys):
    monkeypatch.setenv("KIT_FAST", "1")
    html = viz.animation_html(_animation(3))
    assert html.count("data:image/png;base64") == 3
    assert capsys.readouterr().err == ""

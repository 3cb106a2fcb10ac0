"""``make demo``: the whole loop — SLAM map, then navigation on it with AMCL among people."""

from __future__ import annotations

import io

import pytest

from kit.bag import read_bag
from kit.maps import read_map
from sim import navdemo


@pytest.mark.slow
def test_the_demo_maps_the_office_then_navigates_it_and_writes_its_files(demo_run):
    status, out, tmp_path = demo_run
    assert status == 0
    grid = read_map(tmp_path / "demo_map.yaml")
    assert 0.04 < grid.info.resolution < 0.06 and grid.info.width > 300
    reached = int(out.split("AMCL among 5 people: ")[1].split(" of ")[0])
    assert reached >= 2, out                 # the seeded run reaches all 3 (see the note)
    assert "0 contacts with walls" in out
    assert (tmp_path / "demo_loop.png").stat().st_size > 30_000
    html = (tmp_path / "demo_loop.html").read_text(encoding="utf-8")
    assert "<script" in html and "http" not in html     # plays offline: nothing fetched
    assert "Plays at" in html                            # its speed stated
    topics = {t for t, _, _ in read_bag(tmp_path / "demo_loop")}
    assert {"/map", "/scan", "/odom", "/tf", "/tf_static", "/plan", "/cmd_vel", "/clock",
            "/amcl_pose", "/particlecloud", "/local_plan", "/global_costmap/costmap",
            "/local_costmap/costmap", "/robot_description"} <= topics


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize(("terminal", "quiet", "shown"),
                         [(True, False, True), (True, True, False), (False, False, False)])
def test_the_demos_bars_show_on_a_terminal_unless_quiet_whatever_kit_fast_says(
        monkeypatch, terminal, quiet, shown):
    """make demo sets KIT_FAST=1 (it shortens notebooks); its own stages still show bars,
    as the kit's commands do: off with --quiet or away from a terminal."""
    monkeypatch.setenv("KIT_FAST", "1")
    stream = Terminal() if terminal else io.StringIO()
    monkeypatch.setattr("sys.stderr", stream)
    with navdemo._bar("2. navigating", 10, "s simulated", quiet) as bar:
        assert bar.disable is not shown
        bar.update(4)
        bar.refresh()
    assert ("2. navigating:  40%" in stream.getvalue()) is shown

"""``kit localize`` on a bag the simulator recorded, scored against the simulator's truth."""

import csv
import math

import numpy as np
import pytest

from kit import maps
from kit.cli import main as kit_main


@pytest.mark.slow
def test_kit_localize_tracks_the_simulated_uiabot_through_the_office(tmp_path):
    from sim import demo
    from sim.world import load_world

    result = demo.run(seconds=30.0, seed=3, people=2, bag_path=tmp_path / "bag")
    maps.write_map(load_world("office").occupancy_grid(0.05, layer="lidar"),
                   tmp_path / "office.yaml")           # what the lidar sees: no glass
    truth = np.asarray(result["truth"])
    x0, y0, yaw0 = truth[0]
    assert kit_main(["localize", str(tmp_path / "bag"), "--map", str(tmp_path / "office.yaml"),
                     "--initial", f"{x0},{y0},{yaw0}", "--seed", "1", "--out",
                     str(tmp_path / "out"), "--quiet"]) == 0
    rows = list(csv.reader((tmp_path / "out" / "poses.csv").open()))
    assert rows[0] == ["stamp", "x", "y", "yaw", "std_x", "std_y", "std_yaw"]
    assert len(rows) - 1 == result["counts"]["/scan"]          # one row per scan
    # the end of the run, in the corridor: its length leaves x the least certain, and the
    # estimate's own spread must cover the truth (two standard deviations per axis)
    x, y, yaw, sx, sy, syaw = (float(v) for v in rows[-1][1:7])
    dx, dy = x - truth[-1, 0], y - truth[-1, 1]
    dyaw = math.remainder(yaw - truth[-1, 2], 2 * math.pi)
    assert math.hypot(dx, dy) < 0.5 and abs(dyaw) < math.radians(5)
    assert abs(dx) <= 2 * sx and abs(dy) <= 2 * sy and abs(dyaw) <= 2 * syaw
    assert (tmp_path / "out" / "localization.png").stat().st_size > 10_000


def test_kit_localize_names_what_is_wrong(tmp_path, capsys):
    office = tmp_path / "office.yaml"
    from sim.world import load_world

    maps.write_map(load_world("square").occupancy_grid(0.1), office)
    assert kit_main(["localize", str(tmp_path / "none"), "--map", str(office), "--out",
                     str(tmp_path / "out")]) == 2
    assert "no such bag" in capsys.readouterr().err
    (tmp_path / "bag").mkdir()
    assert kit_main(["localize", str(tmp_path / "bag"), "--map", str(office), "--initial",
                     "1,2", "--out", str(tmp_path / "out")]) == 2
    assert "--initial takes x,y,yaw" in capsys.readouterr().err

"""kit.clitext: help as plain text, negative numbers in options, trajectories that evo reads."""

from __future__ import annotations

import math

import numpy as np
import pytest

from kit import clitext
from kit.cli import build_parser


def test_negative_lists_reach_their_option():
    argv = ["localize", "bag", "--initial", "-2.5,-0.36,-1.44", "--out", "-", "-v"]
    assert clitext.negative_values(argv) == ["localize", "bag", "--initial=-2.5,-0.36,-1.44",
                                             "--out", "-", "-v"]
    assert clitext.negative_values(["--initial", "1,-2,3"]) == ["--initial", "1,-2,3"]
    assert clitext.negative_values(["--initial", "-1e-3, 2, -3"]) == ["--initial=-1e-3, 2, -3"]


def test_the_kit_parser_takes_a_negative_initial_pose():
    args = build_parser().parse_args(clitext.negative_values(
        ["localize", "bag", "--map", "m.yaml", "--initial", "-2.5,-0.36,-1.44", "--out", "o"]))
    assert args.initial == "-2.5,-0.36,-1.44"
    with pytest.raises(SystemExit):   # argparse alone takes it for an option
        build_parser().parse_args(["localize", "bag", "--map", "m.yaml", "--initial",
                                   "-2.5,-0.36,-1.44", "--out", "o"])


def test_plain_drops_the_markup_of_restructured_text():
    doc = ("``kit slam LOG --out DIR``: see :func:`kit.slam.offline.run_bag` and "
           ":class:`~kit.Amcl`; *emphasis*, **strong**, `title`.\n\n* a bullet stays")
    assert clitext.plain(doc) == ("kit slam LOG --out DIR: see kit.slam.offline.run_bag and "
                                  "kit.Amcl; emphasis, strong, title.\n\n* a bullet stays")


@pytest.mark.parametrize("command", ["slam", "localize", "plan", "record", "robot"])
def test_help_renders_as_plain_text(command, capsys):
    with pytest.raises(SystemExit):
        build_parser().parse_args([command, "--help"])
    text = capsys.readouterr().out
    assert "``" not in text and ":func:" not in text and ":class:" not in text
    assert "--out" in text or command == "robot"


def test_a_tum_trajectory_reads_back_in_evo(tmp_path):
    """evo (the odometry and SLAM evaluation package) reads the file: same stamps, positions
    and headings; rows without an estimate are left out."""
    from evo.tools import file_interface

    stamps = 1663967375.5 + np.arange(5) * 0.25
    poses = np.array([[1.0, -2.0, 0.0], [1.5, -2.0, 0.5], [np.nan] * 3, [2.0, -1.0, 3.1],
                      [2.0, -0.5, -3.1]])
    path = clitext.write_trajectory(tmp_path / "t.tum", stamps, poses, "tum")
    traj = file_interface.read_tum_trajectory_file(str(path))
    keep = [0, 1, 3, 4]
    assert traj.num_poses == 4
    np.testing.assert_allclose(traj.timestamps, stamps[keep], atol=1e-6)
    np.testing.assert_allclose(traj.positions_xyz[:, :2], poses[keep, :2], atol=1e-6)
    assert np.all(traj.positions_xyz[:, 2] == 0)
    w, x, y, z = traj.orientations_quat_wxyz.T
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    np.testing.assert_allclose(np.cos(yaw - poses[keep, 2]), 1.0, atol=1e-12)
    assert math.isclose(float(np.linalg.norm(traj.orientations_quat_wxyz[0])), 1.0)


def test_a_csv_trajectory_keeps_every_row(tmp_path):
    path = clitext.write_trajectory(tmp_path / "t.csv", [0.0, 0.5], [[1, 2, 3], [np.nan] * 3])
    assert path.read_text().splitlines() == ["stamp,x,y,yaw", "0.000000,1.000000,2.000000,"
                                             "3.000000", "0.500000,,,"]
    with pytest.raises(ValueError, match="format is one of csv, tum; got 'kitti'"):
        clitext.write_trajectory(tmp_path / "t", [0.0], [[1, 2, 3]], "kitti")
    with pytest.raises(ValueError, match=r"poses must be \(N, 3\)"):
        clitext.write_trajectory(tmp_path / "t", [0.0], [[1, 2]])


def test_out_is_a_folder_and_a_file_in_its_place_is_refused(tmp_path, capsys):
    from kit.cli import main

    assert clitext.output_dir(tmp_path / "a" / "b") == tmp_path / "a" / "b"
    assert (tmp_path / "a" / "b").is_dir()
    assert clitext.output_file(tmp_path / "c", "plan.csv") == tmp_path / "c" / "plan.csv"
    assert clitext.output_file(tmp_path / "d.csv", "plan.csv") == tmp_path / "d.csv"
    (tmp_path / "taken").write_text("")
    with pytest.raises(ValueError, match="taken is a file; --out takes a folder"):
        clitext.output_dir(tmp_path / "taken")
    (tmp_path / "log.clf").write_text("")
    assert main(["slam", str(tmp_path / "log.clf"), "--out", str(tmp_path / "taken")]) == 2
    assert "taken is a file; --out takes a folder" in capsys.readouterr().err

"""``kit robot FILE``: any robot's description, what was found in it and what was assumed;
bad input in one line, never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from kit import cli


@pytest.mark.dataset
def test_kit_robot_prints_what_it_found_and_what_it_assumed(shared_data, capsys):
    path = shared_data / "urdf" / "turtlebot3-ros2-namespaced-xacro" / "turtlebot3_burger.urdf"
    assert cli.main(["robot", str(path), "--xacro-arg", "namespace:=tb3_0/"]) == 0
    out = capsys.readouterr().out
    assert "  wheel_radius          0.033\n  wheel_separation      0.16\n" in out
    assert "wheel joints          tb3_0/wheel_right_joint (right), tb3_0/wheel_left_joint " \
           "(left)" in out
    found = out.split("found in the description:\n")[1].split("  assumed")[0]
    assert "expanded with xacro (namespace:=tb3_0/)" in found
    assert "lidar tb3_0/base_scan at (-0.032, +0.000) m, yaw +0.0°, by its link's name" in found
    assert "footprint 0.140 x 0.178 m" in found
    assumed = out.split("assumed (give them in a parameter file with --params):\n")[1]
    assert "max_linear_velocity 0.26 (Nav2's stock controller parameters, DWB max_vel_x)" in \
        assumed


@pytest.mark.dataset
def test_kit_robot_reads_a_bags_robot_description(shared_data, capsys):
    bag = shared_data / "ros2-bags" / "turtlebot4-real-olin-mac-first-floor"
    assert cli.main(["robot", str(bag)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("turtlebot4: ")
    assert "URDF from the bag's /robot_description" in out
    assert "lidar model from the bag's /scan: 720 beams" in out


@pytest.mark.parametrize("argv, message", [
    (["robot", "nothere.urdf"], "kit: nothere.urdf: no such file"),
    (["robot", "turtlebot"], "kit: 'turtlebot' is neither a shipped robot"),
    (["robot", "uiabot", "--params", "x.toml"], "kit: --params, --xacro-arg and "
     "--package-path go with a robot file, not the shipped uiabot"),
    (["robot", "x.xacro", "--xacro-arg", "namespace"], "kit: a xacro argument is NAME:=VALUE"),
])
def test_kit_robot_refuses_bad_input_in_one_line(argv, message, capsys):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith(message) and len(err.strip().splitlines()) == 1


def test_kit_robot_names_a_urdf_without_drive_wheels(tmp_path: Path, capsys):
    path = tmp_path / "arm.urdf"
    path.write_text("<robot name='arm'><link name='base_link'/><link name='a'/>"
                    "<joint name='shoulder' type='revolute'><parent link='base_link'/>"
                    "<child link='a'/><axis xyz='0 0 1'/>"
                    "<limit lower='-1' upper='1' effort='1' velocity='1'/></joint></robot>")
    assert cli.main(["robot", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"kit: {path}: no pair of drive wheels: expected two continuous "
                          f"joints")
    assert "joints that turn: none" in err

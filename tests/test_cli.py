import pytest

from grader import cli as grader_cli
from kit import cli as kit_cli
from sim import __main__ as sim_main


@pytest.mark.parametrize("main", [kit_cli.main, grader_cli.main, sim_main.main])
def test_help_exits_cleanly(main, capsys):
    with pytest.raises(SystemExit) as exc:
        main(["--help"])
    assert exc.value.code == 0
    assert "usage" in capsys.readouterr().out


def test_kit_wheels_prints_the_igv_paper_numbers(capsys):
    assert kit_cli.main(["wheels", "igv", "1.0", "0.0"]) == 0
    out = capsys.readouterr().out
    assert "59.701, 59.701" in out and "0x00000A30" in out


def test_kit_robot_and_unknown_robot(capsys):
    assert kit_cli.main(["robot", "eddie"]) == 0
    assert "base_link -> laser_link" in capsys.readouterr().out
    assert kit_cli.main(["robot", "igv"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert "  max_angular_velocity  2" in lines          # every name and value apart
    assert "  cruise_velocity       0.8" in lines and "  max_linear_velocity   1.8" in lines
    assert kit_cli.main(["robot", "r2d2"]) == 2
    assert "neither a shipped robot" in capsys.readouterr().err


def test_grader_check_release_and_grade(tmp_path, capsys):
    assert grader_cli.main(["check-release"]) == 0
    assert grader_cli.main(["grade", str(tmp_path), "--lab", "01",
                            "--out", str(tmp_path / "gb.csv")]) == 2
    assert grader_cli.main(["grade", "labs/01-kinematics.ipynb", "--lab", "99",
                            "--out", str(tmp_path / "gb.csv")]) == 2
    assert "no such lab" in capsys.readouterr().err


def test_grader_grade_then_feedback(tmp_path, capsys, weakest_layer_allowed):
    import shutil

    shutil.copy("solutions/01-kinematics.ipynb", tmp_path / "ada.ipynb")
    out = tmp_path / "gb.csv"
    assert grader_cli.main(["grade", str(tmp_path / "ada.ipynb"), "--lab", "01", "--out",
                            str(out), "--practice", *weakest_layer_allowed]) == 0
    printed = capsys.readouterr().out
    assert "sandbox:" in printed and "ada" in printed and "20 / 20" in printed
    assert grader_cli.main(["feedback", str(tmp_path / "gb.json"), "--out",
                            str(tmp_path / "fb")]) == 0
    assert "20 / 20 points" in (tmp_path / "fb" / "ada.md").read_text()

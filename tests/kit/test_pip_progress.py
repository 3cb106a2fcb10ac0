"""The Makefile's install steps: pip's output counted on one line, errors shown whole."""

from __future__ import annotations

import io

from kit import _pip_progress

# what pip 26 prints installing the kit into a fresh environment (abridged)
TRANSCRIPT = """\
Obtaining file:///home/student/kit
  Installing build dependencies: started
  Installing build dependencies: finished with status 'done'
Collecting numpy<3,>=1.24 (from robotics-kit==0.1.0)
  Downloading numpy-2.4.6-cp311-cp311-manylinux_2_27_x86_64.whl (16.6 MB)
Collecting scipy<2,>=1.10 (from robotics-kit==0.1.0)
  Using cached scipy-1.17.1-cp311-cp311-manylinux_2_27_x86_64.whl (35.1 MB)
Requirement already satisfied: tqdm<5,>=4.66 in ./.venv/lib/python3.11/site-packages
Processing /opt/wheels/pymunk-7.3.1-cp311-abi3-manylinux_2_17_x86_64.whl
Building wheels for collected packages: robotics-kit
Installing collected packages: numpy, scipy, pymunk, robotics-kit
Successfully installed numpy-2.4.6 pymunk-7.3.1 robotics-kit-0.1.0 scipy-1.17.1
"""


def test_pips_output_is_counted_on_one_line_rewritten_in_place():
    out = io.StringIO()
    count = _pip_progress.follow(io.StringIO(TRANSCRIPT), out, live=True)
    assert (count.looked_at, count.installed) == (5, 4)
    assert count.installing == ["numpy", "scipy", "pymunk", "robotics-kit"]
    shown = out.getvalue()
    assert "\n" not in shown                                  # one line, rewritten
    assert "looked at 5 packages" in shown and "installing 4 packages" in shown
    assert len(count.lines) == len(TRANSCRIPT.splitlines())  # every line kept for errors


def test_away_from_a_terminal_nothing_is_printed_while_pip_runs():
    out = io.StringIO()
    _pip_progress.follow(io.StringIO(TRANSCRIPT), out, live=False)
    assert out.getvalue() == ""


def test_a_failing_pip_shows_all_it_printed_and_its_exit_status(capsys):
    status = _pip_progress.main(["make: installing", "--", "--no-index", "--no-deps",
                                 "/nonexistent/robotics-kit-0.0.0-py3-none-any.whl"])
    assert status != 0
    out, err = capsys.readouterr()
    assert out.startswith("make: installing\n")
    assert "nonexistent" in err and f"exit status {status}" in err


def test_a_missing_separator_is_a_usage_error(capsys):
    assert _pip_progress.main(["label only"]) == 2
    assert "usage: python -m kit._pip_progress LABEL --" in capsys.readouterr().err


def test_the_last_line_says_how_many_were_installed_or_that_none_were():
    count = _pip_progress.follow(io.StringIO(TRANSCRIPT), io.StringIO(), live=False)
    assert _pip_progress.summary(count, "1 min 05 s") == \
        "  4 packages installed in 1 min 05 s (1 already there)"
    nothing = "Requirement already satisfied: tqdm in ./x\nRequirement already satisfied: pip\n"
    count = _pip_progress.follow(io.StringIO(nothing), io.StringIO(), live=False)
    assert _pip_progress.summary(count, "3 s") == \
        "  nothing to install (2 packages already there, 3 s)"

"""Stopping the grader ends every sandbox it started within seconds — submissions that ignore
SIGTERM, children they spawned, forked processes — and leaves nothing in /tmp or /dev/shm,
whether the grader gets SIGTERM (and says so) or SIGKILL (and cannot)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import nbformat
import pytest

from grader.sandbox import ISOLATING, UID_RANGE, layer_works

EXERCISE = "def turning_radius(linear, angular):\n    return 0.0\n"
STUBBORN = [  # in the cell that defines the exercise: cells the grader runs whole
    EXERCISE + "import signal, time\nsignal.signal(signal.SIGTERM, signal.SIG_IGN)\n"
    "time.sleep(300)",
    EXERCISE + "import os, subprocess, time\nsubprocess.Popen(['sleep', '300'])\n"
    "if os.fork() == 0:\n    time.sleep(300)\ntime.sleep(300)",
]


def marked(pid: int) -> list[int]:
    """Processes whose environment says the grader ``pid`` started them."""
    tag = f"KIT_GRADER_PID={pid}".encode()
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as fh:
                if tag in fh.read().split(b"\0"):
                    found.append(int(entry))
        except OSError:
            continue
    return found


def sandbox_owned(folder: str) -> list[str]:
    out = []
    for name in os.listdir(folder):
        try:
            if UID_RANGE[0] <= os.lstat(os.path.join(folder, name)).st_uid < UID_RANGE[1]:
                out.append(name)
        except OSError:
            continue
    return out


def wait_for(condition, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.2)
    return condition()


@pytest.mark.parametrize("how", ["SIGTERM", "SIGKILL"])
@pytest.mark.parametrize("layer", ISOLATING)
def test_stopping_the_grader_leaves_no_process_and_no_scratch(tmp_path, layer, how):
    if not layer_works(layer):
        pytest.skip(f"the {layer} layer cannot run here")
    folder = tmp_path / "class"
    folder.mkdir()
    for i, cells in enumerate(STUBBORN):
        nb = nbformat.v4.new_notebook()
        nb.cells = [nbformat.v4.new_code_cell(c) for c in cells.split("\n#\n")]
        nbformat.write(nb, folder / f"student{i}.ipynb")
    litter = {d: sandbox_owned(d) for d in ("/tmp", "/dev/shm")}
    env = {**os.environ, "KIT_SANDBOX": layer}
    grader = subprocess.Popen(
        [sys.executable, "-m", "grader", "grade", str(folder), "--lab", "01", "--practice",
         "--jobs", "2", "--timeout", "200", "--out", str(tmp_path / "gb.csv")],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        # both sandboxes up, their submissions asleep (a worker plus its children each)
        assert wait_for(lambda: len(marked(grader.pid)) >= 6, 60), marked(grader.pid)
        grader.send_signal(getattr(signal, how))
        if how == "SIGTERM":
            _, err = grader.communicate(timeout=30)
            assert grader.returncode == 143 and "interrupted (SIGTERM)" in err
        else:
            grader.wait(timeout=30)
        assert wait_for(lambda: not marked(grader.pid), 10), marked(grader.pid)
    finally:
        if grader.poll() is None:
            grader.kill()
            grader.wait()
    assert {d: sandbox_owned(d) for d in ("/tmp", "/dev/shm")} == litter
    # nothing was recorded for the submissions cut short: a re-run grades them
    assert not (tmp_path / "gb.csv").exists() or "student" not in Path(
        tmp_path / "gb.csv").read_text().split("\n", 1)[1]

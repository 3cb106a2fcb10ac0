"""The sandbox's allow-list and limits, seen from inside each isolating layer: only the
system, the Python installation and the kit's packages; its own user id with a process limit
that binds although the grader runs as root; private, bounded /tmp and home; no network."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from grader.sandbox import (
    HOME,
    ISOLATING,
    UID_RANGE,
    Limits,
    Sandbox,
    SandboxUnavailable,
    detect_layer,
    layer_works,
    mount_plan,
)

ROOT = Path(__file__).resolve().parents[2]

INSIDE = r"""
import json, os, socket, sys
report = {"uid": os.getuid(), "euid": os.geteuid(), "home": os.getcwd(),
          "root": sorted(os.listdir("/")), "tmp": os.listdir("/tmp"),
          "notebook": open("nb.ipynb").read()}
try:
    open("/usr/evil", "w")
except OSError as exc:
    report["usr"] = type(exc).__name__
try:
    socket.create_connection(("1.1.1.1", 53), timeout=2)
    report["net"] = "connected"
except OSError as exc:
    report["net"] = type(exc).__name__
pids = []
try:
    for _ in range(500):
        pid = os.fork()
        if pid == 0:
            import time
            time.sleep(30)
            os._exit(0)
        pids.append(pid)
except OSError as exc:
    report["fork"] = type(exc).__name__
report["forked"] = len(pids)
try:
    for name in ("/tmp/a", "/tmp/b"):
        with open(name, "wb") as fh:
            fh.write(b"x" * (40 << 20))
    report["tmpfs"] = "fits"
except OSError as exc:
    report["tmpfs"] = exc.strerror
print(json.dumps(report))
"""


@pytest.mark.parametrize("layer", ISOLATING)
def test_inside_the_sandbox(layer):
    if not layer_works(layer):
        pytest.skip(f"the {layer} layer cannot run here")
    limits = Limits(processes=24, scratch_mb=64)
    box = Sandbox.create(layer, limits, {}, files={"nb.ipynb": "my notebook"})
    proc = box.start([sys.executable, "-I", "-B", "-c", INSIDE], subprocess.DEVNULL,
                     subprocess.PIPE, subprocess.PIPE)
    out, err = proc.communicate(timeout=120)
    box.finish(proc)
    assert out, err.decode()
    report = json.loads(out.decode().strip().splitlines()[-1])
    assert UID_RANGE[0] <= report["uid"] == report["euid"] < UID_RANGE[1]
    assert report["home"] == HOME and report["notebook"] == "my notebook"
    # its config folder and nothing of the host's — but the way to the kit's own packages,
    # when the checkout itself lives under /tmp (a clone made with mktemp -d)
    to_kit = [ROOT.parts[2]] if ROOT.parts[1:2] == ("tmp",) and len(ROOT.parts) > 2 else []
    assert sorted(report["tmp"]) == sorted(["matplotlib", *to_kit])
    assert report["usr"] in ("OSError", "PermissionError")
    assert set(report["root"]) <= {"usr", "bin", "sbin", "lib", "lib32", "lib64", "libx32",
                                   "etc", "dev", "proc", "tmp", "home", *Path(ROOT).parts[1:2],
                                   *(Path(p).resolve().parts[1] for p in (sys.prefix,
                                                                           sys.base_prefix))}
    assert report["net"] == "OSError"
    # the process limit binds: the worker and at most a few helpers count against it
    assert report["fork"] == "BlockingIOError" and limits.processes - 4 <= report["forked"] < \
        limits.processes
    assert report["tmpfs"] == "No space left on device"  # 2 × 40 MB into a 64 MB /tmp


def test_the_plan_binds_only_what_the_allow_list_names(tmp_path):
    stub = str(ROOT / "kit" / "kinematics.py")
    plan = mount_plan(UID_RANGE[0], Limits(), {"mine.ipynb": "{}"}, {stub: "# stub"})
    binds = {m.source for m in plan if m.kind == "bind"}
    for forbidden in (ROOT, ROOT / "solutions", ROOT / "labs", ROOT / ".git", ROOT / "tests",
                      Path.home(), Path("/etc")):
        assert str(forbidden) not in binds
    packages = {str(ROOT / name) for name in ("kit", "grader", "sim", "hardware")}
    assert packages <= binds
    assert all(Path(source).exists() for source in binds)
    data = {m.dest: m.data for m in plan if m.kind in ("data", "file")}
    assert data[f"{HOME}/mine.ipynb"] == "{}" and data[stub] == "# stub"
    assert {m.dest for m in plan if m.kind == "file"} >= {f"{HOME}/mine.ipynb"}  # writable
    assert "student" in data["/etc/passwd"]
    tmpfs = {m.dest for m in plan if m.kind == "tmpfs"}
    caches = {d for d in tmpfs if d.endswith("/__pycache__")}  # numba's, copied in
    assert tmpfs - caches == {"/tmp", "/dev/shm", HOME}
    assert all(any(Path(d).is_relative_to(p) for p in packages) for d in caches)
    # a stub comes after the bind it covers
    order = [m.dest for m in plan]
    assert order.index(stub) > order.index(str(ROOT / "kit"))


def test_a_forced_layer_that_cannot_run_is_an_error_not_a_weaker_layer(monkeypatch):
    monkeypatch.setenv("KIT_SANDBOX", "nsjail")
    with pytest.raises(SandboxUnavailable, match="the layers are bwrap, unshare, rlimits"):
        detect_layer()
    monkeypatch.setenv("KIT_SANDBOX", "bwrap")
    monkeypatch.setattr("grader.sandbox.layer_works", lambda layer: False)
    with pytest.raises(SandboxUnavailable, match="the bwrap sandbox layer cannot run"):
        detect_layer()


def test_the_rlimits_layer_works_in_a_scratch_folder_it_removes():
    box = Sandbox.create("rlimits", Limits(), {}, files={"nb.ipynb": "x"})
    assert box.scratch is not None and (box.scratch / "nb.ipynb").read_text() == "x"
    proc = box.start([sys.executable, "-c", "import os; print(os.getcwd())"],
                     subprocess.DEVNULL, subprocess.PIPE, subprocess.DEVNULL)
    out, _ = proc.communicate(timeout=60)
    box.finish(proc)
    assert out.decode().strip() == str(box.scratch.resolve())
    assert not box.scratch.exists()


def test_scratch_left_by_a_killed_rlimits_grader_is_removed_by_the_next(tmp_path, monkeypatch):
    from grader import sandbox

    monkeypatch.setattr(sandbox.tempfile, "gettempdir", lambda: str(tmp_path))
    dead = tmp_path / "kit-grade-999999999-abc"  # above any pid the kernel hands out
    alive = tmp_path / f"kit-grade-{os.getppid()}-def"
    for folder in (dead, alive):
        folder.mkdir()
        (folder / "nb.ipynb").write_text("x")
    sandbox._remove_stale_scratch.cache_clear()
    sandbox._remove_stale_scratch()
    assert not dead.exists() and alive.exists()


NUMBA = r"""
import json
from sim import Simulation, raycast
sim = Simulation(world="square", robot="uiabot", seed=1)
for _ in sim.run(0.3):
    pass
stats = raycast._cast_scan.stats
print(json.dumps({"hits": sum(stats.cache_hits.values()),
                  "misses": sum(stats.cache_misses.values())}))
"""


@pytest.mark.parametrize("layer", ISOLATING)
def test_numba_finds_its_compiled_lidar_in_the_sandbox(layer):
    """The simulated lidar's compiled functions are loaded from numba's cache beside their
    source, not compiled again in every sandbox."""
    if not layer_works(layer):
        pytest.skip(f"the {layer} layer cannot run here")
    env = {"NUMBA_NUM_THREADS": "1", "KIT_FAST": "1"}
    # on the host first: a fresh checkout has no cache yet, and this run writes it
    subprocess.run([sys.executable, "-c", NUMBA], capture_output=True, check=True,
                   env={**os.environ, **env})
    box = Sandbox.create(layer, Limits(), env)
    assert any(m.kind == "tmpfs" and m.dest.endswith("sim/__pycache__") for m in box.plan)
    proc = box.start([sys.executable, "-I", "-B", "-c", NUMBA], subprocess.DEVNULL,
                     subprocess.PIPE, subprocess.PIPE)
    out, err = proc.communicate(timeout=300)
    box.finish(proc)
    assert out, err.decode()
    stats = json.loads(out.decode().splitlines()[-1])
    assert stats == {"hits": 1, "misses": 0}

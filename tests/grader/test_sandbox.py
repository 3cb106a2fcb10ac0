"""The prison a submission's code runs in, seen from inside, under each isolating layer: only
the system, the Python installation and the kit's packages (with the lab's references cut out
and none of the grader's specifications); a user id of its own, no capabilities, a process
limit that binds although the grader runs as root; private, bounded /tmp, /dev/shm and home
that no other submission sees; no network; no way to make a namespace, mount, trace, raise its
limits or kill itself with SIGKILL."""

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
    SANDBOX_MODULES,
    UID_RANGE,
    Limits,
    Sandbox,
    SandboxUnavailable,
    detect_layer,
    grader_dir,
    layer_works,
    mount_plan,
)
from grader.server import GradingServer
from grader.spec import load_lab

ROOT = Path(__file__).resolve().parents[2]
KEPT_IN_TMP = sorted({Path(p).resolve().parts[2] for p in (ROOT, sys.prefix)
                      if Path(p).resolve().parts[1:2] == ("tmp",)})
"""what a submission's /tmp holds: nothing but the way to the kit and its Python when they were
checked out under /tmp (``mktemp -d``), bound there read-only."""

PROBE = r'''
import ctypes, json, os, resource, signal, socket, subprocess, sys

def probe():
    report = {"uid": os.getuid(), "euid": os.geteuid(), "pid": os.getpid(),
              "home": os.getcwd(), "root": sorted(os.listdir("/")),
              "tmp": sorted(os.listdir("/tmp")), "shm": sorted(os.listdir("/dev/shm")),
              "grader": sorted(n for n in os.listdir(os.path.dirname(__import__("grader").__file__))
                               if n.endswith(".py")),
              "proc": sorted(int(p) for p in os.listdir("/proc") if p.isdigit())}
    status = open("/proc/self/status").read()
    report["capabilities"] = status.split("CapEff:")[1].split()[0]
    report["seccomp"] = status.split("Seccomp:")[1].split()[0]
    try:
        open("/usr/evil", "w")
    except OSError as exc:
        report["usr"] = type(exc).__name__
    try:
        socket.create_connection(("1.1.1.1", 53), timeout=2)
        report["net"] = "connected"
    except OSError as exc:
        report["net"] = type(exc).__name__
    libc = ctypes.CDLL(None, use_errno=True)
    report["unshare_user"] = libc.unshare(0x10000000)
    report["unshare_mount"] = libc.unshare(0x00020000)
    report["mount"] = libc.mount(b"none", b"/tmp", b"tmpfs", 0, None)
    report["unshare_tool"] = subprocess.run(["unshare", "-U", "-r", "true"],
                                            capture_output=True).returncode
    try:
        os.kill(os.getpid(), signal.SIGKILL)
    except PermissionError:
        report["self_sigkill"] = "refused"
    try:
        resource.setrlimit(resource.RLIMIT_CPU, (1, 1))
        report["setrlimit"] = "allowed"
    except (OSError, ValueError):
        report["setrlimit"] = "refused"
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
    for pid in pids:
        os.kill(pid, signal.SIGTERM)
    try:
        for name in ("/tmp/a", "/tmp/b"):
            with open(name, "wb") as fh:
                fh.write(b"x" * (40 << 20))
        report["tmpfs"] = "fits"
    except OSError as exc:
        report["tmpfs"] = exc.strerror
    for name in ("/tmp/a", "/tmp/b"):
        if os.path.exists(name):
            os.remove(name)
    open("/tmp/mine", "w").write("left for the next submission")
    return json.dumps(report)
'''


@pytest.fixture(scope="module", params=ISOLATING)
def server(request: pytest.FixtureRequest):
    layer = request.param
    if not layer_works(layer):
        pytest.skip(f"the {layer} layer cannot run here (root, {layer} and a kit other users "
                    f"can read are needed; CI has them)")
    s = GradingServer(load_lab("lab01"), layer, Limits(processes=24, scratch_mb=64), slots=3)
    yield s
    s.close()


def _probe(server: GradingServer) -> dict:
    session = server.session(512, 60)
    try:
        session.ask("cells", {"cells": [{"position": 1, "first_line": "import", "mode": "run",
                                         "source": PROBE}], "cpu_limit": 60}, wall=180)
        header, _ = session.ask("call", {"function": "probe", "args": (), "kwargs": {},
                                         "cpu_limit": 60}, wall=180)
    finally:
        session.finish()
    assert header["status"] == "returned", header
    return json.loads(header["value"])


def test_inside_a_submissions_prison(server):
    report = _probe(server)
    assert UID_RANGE[0] <= report["uid"] == report["euid"] < UID_RANGE[1]
    # in a PID namespace of its own: its init (pid 1) and itself, no other process
    assert report["pid"] == 2 and report["proc"] == [1, 2]
    assert report["capabilities"] == "0000000000000000" and report["seccomp"] == "2"
    assert report["home"] == HOME and report["tmp"] == KEPT_IN_TMP and report["shm"] == []
    assert report["usr"] in ("OSError", "PermissionError")
    assert set(report["root"]) <= {"usr", "bin", "sbin", "lib", "lib32", "lib64", "libx32",
                                   "etc", "dev", "proc", "tmp", "home", *Path(ROOT).parts[1:2],
                                   *(Path(p).resolve().parts[1] for p in (sys.prefix,
                                                                           sys.base_prefix))}
    # the grader's package holds its side of the questions and nothing that judges
    assert set(report["grader"]) == {"__init__.py", *SANDBOX_MODULES}
    assert report["net"] == "OSError"
    # no nested user namespace, no mount, no self-inflicted SIGKILL, no raised limits
    assert report["unshare_user"] == report["unshare_mount"] == report["mount"] == -1
    assert report["unshare_tool"] != 0
    assert report["self_sigkill"] == "refused" and report["setrlimit"] == "refused"
    # the process limit binds: the submission, its init and at most a few helpers count
    assert report["fork"] == "BlockingIOError" and 24 - 5 <= report["forked"] < 24
    assert report["tmpfs"] == "No space left on device"  # 2 × 40 MB into a 64 MB /tmp


def test_one_submission_leaves_nothing_for_the_next(server):
    first, second = _probe(server), _probe(server)  # each left a file in its own /tmp
    assert first["tmp"] == second["tmp"] == KEPT_IN_TMP
    assert first["uid"] != second["uid"] or first["uid"] in server.free


def test_the_plan_binds_only_what_the_allow_list_names():
    stripped = str(ROOT / "kit" / "kinematics.py")
    plan = mount_plan([UID_RANGE[0]], Limits(), {stripped: "# stripped"})
    binds = {m.source for m in plan if m.kind == "bind"}
    for forbidden in (ROOT, ROOT / "solutions", ROOT / "labs", ROOT / ".git", ROOT / "tests",
                      ROOT / "grader", ROOT / "grader" / "labs", Path.home(), Path("/etc")):
        assert str(forbidden) not in binds
    assert {str(ROOT / name) for name in ("kit", "sim", "hardware")} <= binds
    grader = grader_dir()
    assert {m.source for m in plan if m.kind == "bind" and m.dest.startswith(grader)} == \
        {f"{grader}/{name}" for name in SANDBOX_MODULES}
    assert all(Path(source).exists() for source in binds)
    data = {m.dest: m.data for m in plan if m.kind in ("data", "file")}
    assert data[stripped] == "# stripped" and "def checker" in data[f"{grader}/__init__.py"]
    assert "student000" in data["/etc/passwd"]
    # the stripped module's compiled copies are hidden behind empty files
    cache = ROOT / "kit" / "__pycache__"
    for compiled in cache.glob("kinematics.*"):
        assert data[str(compiled)] == ""
    # a replacement comes after the bind it covers
    order = [m.dest for m in plan]
    assert order.index(stripped) > order.index(str(ROOT / "kit"))


def test_a_forced_layer_that_cannot_run_is_an_error_not_a_weaker_layer(monkeypatch):
    monkeypatch.setenv("KIT_SANDBOX", "nsjail")
    with pytest.raises(SandboxUnavailable, match="the layers are bwrap, unshare, rlimits"):
        detect_layer()
    monkeypatch.setenv("KIT_SANDBOX", "bwrap")
    monkeypatch.setattr("grader.sandbox.layer_works", lambda layer: False)
    with pytest.raises(SandboxUnavailable, match="the bwrap sandbox layer cannot run"):
        detect_layer()


def test_the_rlimits_layer_works_in_a_scratch_folder_it_removes():
    box = Sandbox.create("rlimits", Limits(), {})
    assert box.scratch is not None and box.scratch.is_dir()
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


NUMBA = r'''
import json
def lidar_cache():
    import numba
    from sim import Simulation, raycast
    sim = Simulation(world="square", robot="uiabot", seed=1)
    for _ in sim.run(0.3):
        pass
    stats = raycast._cast_scan.stats
    return json.dumps({"hits": sum(stats.cache_hits.values()),
                       "misses": sum(stats.cache_misses.values()),
                       "target": numba.config.CPU_NAME})
'''


def lidar_cache_in_a_prison(layer: str) -> dict:
    """What numba's cache gave the simulated lidar: on the host first (a fresh checkout has
    no cache yet for the environment's CPU target, and this run writes it), then in a
    submission's prison of a lab that leaves the simulator whole."""
    env = {"NUMBA_NUM_THREADS": "1", "KIT_FAST": "1"}
    subprocess.run([sys.executable, "-c", NUMBA + "\nlidar_cache()"], capture_output=True,
                   check=True, env={**os.environ, **env})
    server = GradingServer(load_lab("lab09"), layer, Limits(), slots=1)
    try:
        session = server.session(1024, 120)
        session.ask("cells", {"cells": [{"position": 1, "first_line": "", "mode": "run",
                                         "source": NUMBA}], "cpu_limit": 120}, wall=300)
        header, _ = session.ask("call", {"function": "lidar_cache", "args": (), "kwargs": {},
                                         "cpu_limit": 120}, wall=300)
        session.finish()
    finally:
        server.close()
    assert header["status"] == "returned", header
    return json.loads(header["value"])


@pytest.mark.parametrize("layer", ISOLATING)
def test_numba_finds_its_compiled_lidar_in_a_submissions_prison(layer):
    """The simulated lidar's compiled functions are loaded from numba's cache beside their
    source (a private copy per submission), not compiled again in every one."""
    if not layer_works(layer):
        pytest.skip(f"the {layer} layer cannot run here")
    assert lidar_cache_in_a_prison(layer) == {"hits": 1, "misses": 0,
                                              "target": os.environ.get("NUMBA_CPU_NAME")}


def test_a_site_that_pins_numbas_cpu_target_has_its_caches_found_in_the_prison(monkeypatch):
    """``NUMBA_CPU_NAME=generic`` (a site whose caches must serve every machine of a
    cluster): the prison compiles for the same target, so the cache the host wrote for it is
    found; before, the prison's numba looked for code for the host's own CPU."""
    layer = next((layer for layer in ISOLATING if layer_works(layer)), None)
    if layer is None:
        pytest.skip("no isolating layer can run here")
    monkeypatch.setenv("NUMBA_CPU_NAME", "generic")
    assert lidar_cache_in_a_prison(layer) == {"hits": 1, "misses": 0, "target": "generic"}


def test_the_prisons_environment_takes_the_cpu_target_and_nothing_else_of_the_graders(
        monkeypatch):
    from grader.server import CPU_TARGET_VARIABLES, _server_env

    for name in CPU_TARGET_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    monkeypatch.setenv("NUMBA_CPU_NAME", "haswell")
    monkeypatch.setenv("NPY_DISABLE_CPU_FEATURES", "X86_V4 AVX512_ICL")
    monkeypatch.setenv("KIT_COURSE_SECRET", "s3cret")
    monkeypatch.setenv("AWS_SECRET_ACCESS_KEY", "k3y")
    env = _server_env("rlimits")
    assert env["NUMBA_CPU_NAME"] == "haswell"
    assert env["NPY_DISABLE_CPU_FEATURES"] == "X86_V4 AVX512_ICL"
    assert not {"NUMBA_CPU_FEATURES", "NPY_ENABLE_CPU_FEATURES", "OPENBLAS_CORETYPE"} & set(env)
    assert not {"KIT_COURSE_SECRET", "AWS_SECRET_ACCESS_KEY", "PATH", "HOME"} & set(env)


def test_a_kit_other_users_cannot_read_leaves_no_isolating_layer_and_says_why(tmp_path):
    """A checkout made under ``umask 077`` starts as root in the sandbox, but a submission's
    user cannot import the kit there: each isolating layer's probe, run as that user, fails,
    so grading falls to the rlimits layer (refused for a class unless allowed) with the
    reason — instead of a gradebook where every submission 'crashed' with exit code 70."""
    import shutil

    if os.geteuid() != 0 or not any(shutil.which(n) for n in ("bwrap", "unshare")):
        pytest.skip("needs root and bubblewrap or unshare (CI has them)")
    copy = tmp_path / "private"
    for name in ("kit", "grader", "sim", "hardware"):
        shutil.copytree(ROOT / name, copy / name,
                        ignore=shutil.ignore_patterns("__pycache__", "*.nbi", "*.nbc"))
    for folder, _dirs, files in os.walk(copy):
        os.chmod(folder, 0o700)
        for f in files:
            os.chmod(os.path.join(folder, f), 0o600)
    # the probe finds the copy where an installed kit's path entry would be
    where = f"import sys\nsys.path.insert(0, {str(copy)!r})\n"
    code = ("import json\nfrom grader import sandbox\n"
            f"sandbox._PROBE = {where!r} + sandbox._PROBE\n"
            "works = {layer: sandbox.layer_works(layer) for layer in sandbox.ISOLATING}\n"
            "print(json.dumps([works, sandbox.detect_layer(), sandbox.why_not_isolated(),\n"
            "                  sandbox.grader_dir()]))\n")
    env = {**os.environ, "PYTHONPATH": str(copy)}
    env.pop("KIT_SANDBOX", None)
    run = subprocess.run([sys.executable, "-c", code], cwd=copy, env=env, capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    works, layer, why, graders = json.loads(run.stdout)
    assert graders == str(copy / "grader")  # the copy was the one probed
    assert works == dict.fromkeys(ISOLATING, False) and layer == "rlimits"
    assert "readable by other users" in why and "umask 077" in why
    assert "Permission denied" in why and str(copy) in why

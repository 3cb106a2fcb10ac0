"""Where a submission runs: the strongest isolation layer this machine offers.

Layers, strongest first (the grader reports which one ran):

``bwrap``
    bubblewrap, started as root: new mount, PID, network, IPC and UTS namespaces whose file
    system is built from an allow-list (:func:`mount_plan`), then ``setpriv`` drops to a user id
    of the submission's own, without capabilities.
``unshare``
    as root without bubblewrap: ``unshare`` makes the same namespaces and :mod:`grader.jail`
    builds the same file system with ``mount(2)`` before dropping to the submission's user.
``rlimits``
    neither: resource limits and killing the process group only. It cannot keep a submission
    away from the grader's files, so ``grader grade`` refuses it unless told otherwise.

The allow-list of both isolating layers: the system's programs and libraries (``/usr`` and
its ``/lib``, ``/bin`` links), a few files of ``/etc``, the Python installation, the kit's
packages — with the graded references' modules replaced by stubs that raise — and the
submission's own copy of its notebook in a private home directory. ``/tmp``, ``/dev/shm`` and
the home directory are private tmpfs mounts of bounded size that vanish with the sandbox;
nothing of the submission is ever written on the grading machine's disks.

Every sandbox runs as a user id of its own (drawn at random from a range no account uses), so
its process-count limit counts its own processes only, and binds even when grading as root.
All layers add the same resource limits (address space, CPU time, file size, processes, no
core dumps), a wall-clock timeout enforced by the grader, and die with the grader: each
sandbox gets the parent-death signal, and :func:`kill_all` ends every live one.
"""

from __future__ import annotations

import base64
import ctypes
import functools
import importlib
import json
import os
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from collections.abc import Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import IO, Any

__all__ = ["HOME", "ISOLATING", "LAYERS", "Interrupted", "Limits", "Mount", "Sandbox",
           "SandboxUnavailable", "detect_layer", "kill_all", "layer_works", "mount_plan",
           "resume", "stop", "stopping"]

LAYERS = ("bwrap", "unshare", "rlimits")
ISOLATING = ("bwrap", "unshare")
HOME = "/home/student"
"""the submission's home and working directory inside an isolating sandbox."""
MPL_DIR = "/tmp/matplotlib"
"""matplotlib's configuration and cache folder inside an isolating sandbox."""
PACKAGES = ("kit", "grader", "sim", "hardware")
UID_RANGE = (1_500_000_000, 1_900_000_000)
"""user ids of sandboxes: far above any account's."""
ETC_FILES = ("ld.so.cache", "ld.so.conf", "ld.so.conf.d", "nsswitch.conf", "hosts",
             "mime.types", "alternatives", "localtime")
SYSTEM_LINKS = ("bin", "sbin", "lib", "lib32", "lib64", "libx32")
PR_SET_PDEATHSIG = 1


class SandboxUnavailable(RuntimeError):
    """The requested layer cannot run on this machine."""


class Interrupted(RuntimeError):
    """Grading was stopped (SIGINT/SIGTERM): no new sandbox starts."""


@dataclass(frozen=True)
class Limits:
    memory_mb: int = 2048
    cpu_seconds: int = 121
    file_mb: int = 64
    """largest file the submission may write, its captured output included."""
    processes: int = 64
    """processes and threads of the submission's user at once."""
    scratch_mb: int = 256
    """size of each private tmpfs (home, /tmp, /dev/shm)."""


@dataclass(frozen=True)
class Mount:
    """One step of building the sandbox's file system, in order.

    ``kind`` is ``bind`` (read-only bind of host path ``source``), ``tmpfs`` (private, of
    ``size`` bytes and permission bits ``mode``), ``data`` (a read-only file holding ``data``),
    ``file`` (a writable copy of ``data``, or of the bytes ``blob``, in a tmpfs), ``dir`` (an
    empty directory), ``symlink`` (to ``source``), ``dev`` or ``proc``.
    """

    kind: str
    dest: str
    source: str = ""
    data: str = ""
    size: int = 0
    mode: int = 0o755
    blob: bytes = b""


# ------------------------------------------------------------------ the allow-list

def _real(path: str | Path) -> str:
    return str(Path(path).resolve())


def _package_dirs() -> list[str]:
    """Where the kit's packages are installed (a folder holding ``__init__.py`` each): the
    packages as imported, so that a folder of the same name elsewhere on ``sys.path`` (the
    tests mirror the packages' names) is never taken for them."""
    dirs: list[str] = []
    for name in PACKAGES:
        try:
            origin = getattr(importlib.import_module(name), "__file__", None)
        except ImportError:
            continue
        if origin and origin.endswith("__init__.py"):
            dirs.append(_real(Path(origin).parent))
    return dirs


def _python_dirs() -> list[str]:
    prefixes = {_real(p) for p in (sys.prefix, sys.base_prefix, sys.exec_prefix,
                                   sys.base_exec_prefix)}
    prefixes.add(_real(Path(sys.executable).resolve().parent.parent))
    return sorted(prefixes)


def _covered(path: str, roots: Sequence[str]) -> bool:
    return any(path == r or path.startswith(r.rstrip("/") + "/") for r in roots)


def _system_mounts() -> list[Mount]:
    mounts = [Mount("bind", "/usr", "/usr")]
    for name in SYSTEM_LINKS:
        path = Path("/") / name
        if path.is_symlink():
            mounts.append(Mount("symlink", str(path), os.readlink(path)))
        elif path.is_dir():
            mounts.append(Mount("bind", str(path), str(path)))
    for name in ETC_FILES:
        path = Path("/etc") / name
        if path.exists():
            # a symlink (localtime → zoneinfo) is bound as the file it names
            mounts.append(Mount("bind", str(path), _real(path)))
    return mounts


def _etc_passwd(uids: Sequence[int]) -> list[Mount]:
    """Accounts for the sandbox: root, nobody, and one ``studentNNN`` per user id its
    submissions may run as (a program asking who it is gets an answer)."""
    passwd = ("root:x:0:0:root:/root:/usr/sbin/nologin\n"
              "nobody:x:65534:65534:nobody:/nonexistent:/usr/sbin/nologin\n"
              + "".join(f"student{i:03d}:x:{uid}:{uid}:student:{HOME}:/usr/sbin/nologin\n"
                        for i, uid in enumerate(uids)))
    group = "root:x:0:\nnogroup:x:65534:\n" + "".join(
        f"student{i:03d}:x:{uid}:\n" for i, uid in enumerate(uids))
    return [Mount("data", "/etc/passwd", data=passwd), Mount("data", "/etc/group", data=group)]


def _font_cache() -> Path | None:
    """The grading user's matplotlib font list, if matplotlib built one (found without
    importing matplotlib)."""
    folder = os.environ.get("MPLCONFIGDIR") or str(
        Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "matplotlib")
    found = sorted(Path(folder).glob("fontlist-v*.json")) if Path(folder).is_dir() else []
    return found[-1] if found else None


SHIM = '''"""The grader as a graded submission sees it: ``check`` does nothing here.

While a notebook is graded, its check cells are not run and nothing of the grader's
specifications, references or hidden cases is in this process; ``checker`` only keeps a
notebook's setup cell working.
"""


def checker(lab):
    def check(fn, exercise=None):
        return None

    return check
'''
SANDBOX_MODULES = ("frames.py", "runner.py", "seccomp.py", "serialize.py", "zygote.py")
"""the grader's modules a sandbox holds: the submission's side of the questions, and none of
the specifications, references, hidden cases or scoring."""


def grader_dir() -> str:
    return _real(Path(__file__).parent)


def cache_folders(roots: Sequence[str]) -> list[str]:
    """The ``__pycache__`` folders of the kit's packages that hold numba's compiled code
    (each submission gets a private, writable copy: numba uses a cache only where it could
    write; without it the simulated lidar would be compiled again in every sandbox)."""
    folders = []
    for root in roots:
        if Path(root).name not in PACKAGES:
            continue
        folders += [str(c) for c in sorted(Path(root).rglob("__pycache__"))
                    if any(c.glob("*.nbi"))]
    return folders


def mount_plan(uids: Sequence[int], limits: Limits,
               stripped: Mapping[str, str] | None = None) -> list[Mount]:
    """The sandbox's file system, in the order it is built.

    The system's libraries, the Python installation and the kit's packages, read-only; in
    place of the grader's package a folder holding :data:`SHIM` as its ``__init__`` and only
    :data:`SANDBOX_MODULES`; ``stripped`` (host path → text) replaces the modules that hold
    the lab's references, whose compiled copies (Python's and numba's) are hidden too.
    """
    size = limits.scratch_mb * 1024 * 1024
    plan = _system_mounts() + _etc_passwd(uids)
    plan += [Mount("dev", "/dev"), Mount("proc", "/proc"),
             Mount("tmpfs", "/tmp", size=size, mode=0o1777),
             Mount("tmpfs", "/dev/shm", size=size, mode=0o1777),
             Mount("tmpfs", HOME, size=size, mode=0o777)]
    roots = ["/usr"]
    grader = grader_dir()
    for path in [*_python_dirs(), *_package_dirs()]:
        if path == grader:
            continue
        if not _covered(path, roots):
            plan.append(Mount("bind", path, path))
            roots.append(path)
    plan.append(Mount("tmpfs", grader, size=1 << 20, mode=0o755))
    plan.append(Mount("data", f"{grader}/__init__.py", data=SHIM, mode=0o444))
    plan += [Mount("bind", f"{grader}/{name}", f"{grader}/{name}") for name in SANDBOX_MODULES]
    plan.append(Mount("dir", MPL_DIR, mode=0o777))
    font_cache = _font_cache()
    if font_cache is not None:  # else matplotlib rebuilds it in the sandbox (≈ 0.5 s)
        plan.append(Mount("file", f"{MPL_DIR}/{font_cache.name}",
                          data=font_cache.read_text(encoding="utf-8"), mode=0o644))
    hidden: set[str] = set()
    for path, text in (stripped or {}).items():
        plan.append(Mount("data", path, data=text, mode=0o444))
        cache = Path(path).parent / "__pycache__"
        stem = Path(path).stem
        compiled = sorted(cache.glob(f"{stem}.*")) if cache.is_dir() else []
        plan += [Mount("data", str(f), data="", mode=0o444) for f in compiled if f.is_file()]
        hidden |= {str(f) for f in compiled}
    plan += _numba_caches(roots[1:], size, hidden)
    return _with_parents(plan)


def _numba_caches(roots: Sequence[str], size: int, hidden: set[str]) -> list[Mount]:
    """numba picks where a compiled function's cache lives when the module is imported, and
    uses the folder beside the source only if it can write there: each ``__pycache__`` of the
    kit's packages holding numba's index becomes a writable tmpfs with copies of its files
    (those of stripped modules left out), so the grading server's imported kit keeps finding
    its compiled code; each submission then gets its own fresh copy
    (:mod:`grader.zygote`)."""
    mounts = []
    for folder in cache_folders(roots):
        mounts.append(Mount("tmpfs", folder, size=size, mode=0o755))
        mounts += [Mount("file", str(f), blob=f.read_bytes(), mode=0o644)
                   for f in sorted(Path(folder).iterdir())
                   if f.is_file() and str(f) not in hidden]
    return mounts


def _with_parents(plan: list[Mount]) -> list[Mount]:
    """Each mount preceded by the directories above it that nothing mounted yet made, as
    ``dir`` steps of mode 0755 (bubblewrap would make them 0700, unreadable to the
    submission's user)."""
    made = {"/"}
    bound: list[str] = []
    out = []
    for m in plan:
        for parent in reversed(Path(m.dest).parents):
            if str(parent) not in made and not _covered(str(parent), bound):
                out.append(Mount("dir", str(parent)))
                made.add(str(parent))
        out.append(m)
        made.add(m.dest)
        if m.kind == "bind":  # what lies below a bound folder is the host's, already there
            bound.append(m.dest)
    return out


# ------------------------------------------------------------------ which layer

NEEDS = {"bwrap": ("bwrap",), "unshare": ("unshare",)}


_PROBE = """import os
os.setgroups([])
os.setresgid({uid}, {uid}, {uid})
os.setresuid({uid}, {uid}, {uid})
import grader.runner, grader.seccomp, grader.zygote, kit.geometry, numpy
"""
"""What a submission's process does first, as the user a submission runs as: a checkout or an
environment made under ``umask 077`` starts as root in the sandbox but cannot be read there."""

_PROBE_FAILURES: dict[str, str] = {}
"""The last line a layer's failed probe printed (for :func:`why_not_isolated`)."""


@functools.cache
def layer_works(layer: str) -> bool:
    """Whether ``layer`` can run the kit's Python here as a submission's user (bubblewrap may
    be missing or refused, the namespaces need root, the kit may be unreadable to other
    users)."""
    if layer == "rlimits":
        return True
    needed = NEEDS.get(layer)
    if needed is None or os.geteuid() != 0 or not all(shutil.which(n) for n in needed):
        return False
    box = Sandbox.create(layer, Limits(), {}, slots=1)
    with tempfile.TemporaryFile() as errors:
        try:
            proc = box.start([sys.executable, "-I", "-B", "-c", _PROBE.format(uid=box.uids[0])],
                             stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=errors)
        except (OSError, subprocess.SubprocessError, Interrupted) as exc:
            _PROBE_FAILURES[layer] = str(exc)
            return False
        try:
            works = proc.wait(timeout=60) == 0
        except subprocess.TimeoutExpired:
            works = False
        finally:
            box.finish(proc)
        if not works:
            errors.seek(0)
            lines = errors.read().decode("utf-8", "replace").strip().splitlines()
            _PROBE_FAILURES[layer] = lines[-1][-300:] if lines else "no output"
    return works


def why_not_isolated() -> str:
    """Why neither isolating layer works here, in the words an instructor can act on."""
    if os.geteuid() != 0:
        return ("the grader is not running as root, and both isolating layers run each "
                "submission as a user of its own, which takes root")
    missing = [tool for layer in ISOLATING for tool in NEEDS[layer] if not shutil.which(tool)]
    if len(missing) == len(ISOLATING):
        return "neither bubblewrap (bwrap) nor unshare is installed"
    seen = "; ".join(f"{layer}: {_PROBE_FAILURES[layer]}" for layer in ISOLATING
                     if layer in _PROBE_FAILURES)
    return ("bubblewrap and unshare could not run the kit's Python as another user: is the "
            "kit's installation readable by other users (a checkout or .venv made under umask "
            "077: chmod -R o+rX it)?" + (f" They said: {seen}" if seen else ""))


def detect_layer(forced: str | None = None) -> str:
    """``"bwrap"``, ``"unshare"`` or ``"rlimits"``: the strongest that works here.

    ``forced`` (or the environment variable ``KIT_SANDBOX``) asks for one layer; a layer that
    cannot run here raises :class:`SandboxUnavailable` rather than quietly running a weaker one.
    """
    wanted = forced or os.environ.get("KIT_SANDBOX") or None
    if wanted:
        if wanted not in LAYERS:
            raise SandboxUnavailable(f"KIT_SANDBOX={wanted!r}: the layers are "
                                     f"{', '.join(LAYERS)}")
        if not layer_works(wanted):
            tools = " and ".join(NEEDS.get(wanted, ()))
            raise SandboxUnavailable(f"the {wanted} sandbox layer cannot run on this machine: "
                                     f"it needs root, {tools}, and a kit installation other "
                                     f"users can read")
        return wanted
    return next(layer for layer in LAYERS if layer_works(layer))


# ------------------------------------------------------------------ live sandboxes

_LIVE: set[subprocess.Popen[bytes]] = set()
_LIVE_LOCK = threading.Lock()
_STOPPING = threading.Event()


def _kill_group(proc: subprocess.Popen[bytes]) -> None:
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def kill_all() -> int:
    """Kill every live sandbox (and, with it, every process inside); returns how many."""
    with _LIVE_LOCK:
        live = list(_LIVE)
    for proc in live:
        _kill_group(proc)
    return len(live)


def stop() -> None:
    """Refuse new sandboxes and kill the live ones (an interrupted grading run)."""
    _STOPPING.set()
    kill_all()


def stopping() -> bool:
    """Whether :func:`stop` was called (and :func:`resume` not yet)."""
    return _STOPPING.is_set()


def resume() -> None:
    """Allow sandboxes again after :func:`stop` (a new grading run in the same process)."""
    _STOPPING.clear()


_PRCTL = ctypes.CDLL(None, use_errno=True).prctl
"""resolved here, not in a freshly forked child."""


def _parent_death_signal() -> None:
    """In the child before exec: die when the thread that forked it ends (see
    :func:`_from_spawner`: that thread lives as long as the grader's process)."""
    _PRCTL(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)


_SPAWNER_LOCK = threading.Lock()
_SPAWNER: tuple[int, ThreadPoolExecutor] | None = None


def _from_spawner(call: Any) -> Any:
    """``call()`` run by the one thread of this process that forks every sandbox.

    The kernel's parent-death signal fires when the *thread* that forked a child ends, not its
    process. A sandbox forked by a grading pool's thread was killed as soon as that pool shut
    down, though its server was kept for the next run; the fifth run in one process (an
    instructor's notebook, a Dask worker) then found its server "stopped too often". This
    thread lives as long as the process (one executor per process: a forked child, which
    inherits the executor but not its thread, makes its own)."""
    global _SPAWNER
    with _SPAWNER_LOCK:
        if _SPAWNER is None or _SPAWNER[0] != os.getpid():
            _SPAWNER = (os.getpid(), ThreadPoolExecutor(1, "kit-sandbox-spawner"))
        spawner = _SPAWNER[1]
    return spawner.submit(call).result()


# ------------------------------------------------------------------ one sandbox

@functools.cache
def _remove_stale_scratch() -> None:
    """The rlimits layer's scratch folders left by graders that were killed (SIGKILL leaves
    no chance to clean up): removed by the next grader, once per process."""
    for folder in Path(tempfile.gettempdir()).glob("kit-grade-*-*"):
        pid = folder.name.split("-")[2]
        if not pid.isdigit() or int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
        except PermissionError:
            pass  # alive, another user's


BWRAP_CAPS = ("CAP_SYS_ADMIN", "CAP_SETUID", "CAP_SETGID", "CAP_KILL", "CAP_CHOWN",
              "CAP_FOWNER", "CAP_DAC_OVERRIDE")
"""what the grading server keeps inside bubblewrap: enough to make each submission's
namespaces and mounts and to drop it to its own user id — the submission itself keeps none."""


@dataclass
class Sandbox:
    """How to start the grading server (:mod:`grader.zygote`) inside a layer, on a file
    system built from ``plan``; it stays root there and makes each submission's prison."""

    layer: str
    limits: Limits
    plan: list[Mount]
    env: dict[str, str]
    uids: tuple[int, ...] = ()
    """the user ids this sandbox's submissions run as (one per submission at a time)."""
    scratch: Path | None = None
    """the rlimits layer's working directory (a host folder)."""
    _fds: list[int] = field(default_factory=list)

    @classmethod
    def create(cls, layer: str, limits: Limits, env: Mapping[str, str],
               stripped: Mapping[str, str] | None = None, slots: int = 8) -> Sandbox:
        start = UID_RANGE[0] + secrets.randbelow(UID_RANGE[1] - UID_RANGE[0] - 4096)
        uids = tuple(start + i for i in range(max(1, slots)))
        plan = mount_plan(uids, limits, stripped) if layer in ISOLATING else []
        box = cls(layer, limits, plan, {"PATH": "/usr/bin:/bin", **env}, uids)
        if layer == "rlimits":
            _remove_stale_scratch()
            box.scratch = Path(tempfile.mkdtemp(prefix=f"kit-grade-{os.getpid()}-"))
        box.env.update(HOME=box.home, TMPDIR=str(box.scratch) if box.scratch else "/tmp")
        return box

    @property
    def home(self) -> str:
        return str(self.scratch) if self.scratch is not None else HOME

    def _memfd(self, content: str | bytes) -> int:
        fd = os.memfd_create("kit-sandbox")
        data = content.encode("utf-8") if isinstance(content, str) else content
        while data:
            data = data[os.write(fd, data):]
        os.lseek(fd, 0, os.SEEK_SET)
        self._fds.append(fd)
        return fd

    def _bwrap_args(self) -> list[str]:
        args = ["bwrap", "--unshare-ipc", "--unshare-pid", "--unshare-net", "--unshare-uts",
                "--unshare-cgroup-try", "--die-with-parent", "--new-session", "--clearenv"]
        for cap in BWRAP_CAPS:
            args += ["--cap-add", cap]
        for m in self.plan:
            if m.kind == "bind":
                args += ["--ro-bind", m.source, m.dest]
            elif m.kind == "symlink":
                args += ["--symlink", m.source, m.dest]
            elif m.kind == "tmpfs":
                args += ["--perms", f"{m.mode:o}", "--size", str(m.size), "--tmpfs", m.dest]
            elif m.kind == "data":
                args += ["--perms", f"{m.mode:o}", "--ro-bind-data", str(self._memfd(m.data)),
                         m.dest]
            elif m.kind == "file":
                content = m.blob or m.data
                args += ["--perms", f"{m.mode:o}", "--file", str(self._memfd(content)), m.dest]
            elif m.kind == "dir":
                args += ["--perms", f"{m.mode:o}", "--dir", m.dest]
            elif m.kind in ("dev", "proc"):
                args += [f"--{m.kind}", m.dest]
        args += ["--remount-ro", "/", "--chdir", HOME]
        for key, value in self.env.items():
            args += ["--setenv", key, value]
        return args

    def _unshare_args(self) -> list[str]:
        plan = {"home": HOME, "env": self.env,
                "mounts": [{**asdict(m), "blob": base64.b64encode(m.blob).decode()}
                           for m in self.plan]}
        fd = self._memfd(json.dumps(plan))
        jail = Path(__file__).with_name("jail.py")
        return ["unshare", "--mount", "--pid", "--fork", "--net", "--ipc", "--uts",
                "--kill-child", "--propagation", "private", sys.executable, "-I", "-S", "-B",
                str(jail), str(fd), "--"]

    def command(self, argv: Sequence[str]) -> list[str]:
        """The full command line that runs ``argv`` in this sandbox."""
        if self.layer == "bwrap":
            return [*self._bwrap_args(), *argv]
        if self.layer == "unshare":
            return [*self._unshare_args(), *argv]
        return list(argv)

    def start(self, argv: Sequence[str], stdin: Any, stdout: Any, stderr: Any,
              pass_fds: Sequence[int] = ()) -> subprocess.Popen[bytes]:
        """Start ``argv`` in the sandbox as its own process group, registered for
        :func:`kill_all`. Raises :class:`Interrupted` once grading is being stopped."""
        if _STOPPING.is_set():
            raise Interrupted("grading is being stopped")
        command = self.command(argv)
        env = self.env if self.layer == "rlimits" else {"PATH": "/usr/bin:/bin"}
        try:
            proc = _from_spawner(functools.partial(
                subprocess.Popen, command, stdin=stdin, stdout=stdout, stderr=stderr,
                cwd=self.home if self.scratch else "/", env=env,
                pass_fds=(*pass_fds, *self._fds), start_new_session=True,
                preexec_fn=_parent_death_signal))
        finally:
            for fd in self._fds:
                os.close(fd)
            self._fds.clear()
        with _LIVE_LOCK:
            _LIVE.add(proc)
        if _STOPPING.is_set():  # stopped while starting: do not let it run
            _kill_group(proc)
        return proc

    def finish(self, proc: subprocess.Popen[bytes]) -> None:
        """Kill whatever is left of the sandbox and forget it; remove the rlimits scratch."""
        _kill_group(proc)
        proc.wait()
        with _LIVE_LOCK:
            _LIVE.discard(proc)
        if self.scratch is not None:
            shutil.rmtree(self.scratch, ignore_errors=True)


def unlinked_file() -> IO[bytes]:
    """A temporary file with no name on disk (it vanishes with the grader, however it ends)."""
    return tempfile.TemporaryFile()

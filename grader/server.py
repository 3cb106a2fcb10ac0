"""The grader's side of the grading server: one sandbox per run, one prison per submission.

:class:`GradingServer` starts :mod:`grader.zygote` once in the chosen sandbox layer, with the
lab's references cut out of the kit (:mod:`grader.strip`), and asks it for a fresh, isolated
process per submission (:meth:`GradingServer.session`). A :class:`Session` is one such
process: the grader sends it one question at a time and reads one answer, each bounded in
time and size (:mod:`grader.frames`); when it ends, its keeper reports how (exit code or
signal, CPU time, peak memory) on a pipe the submission cannot reach.

Nothing a session sends is a verdict: it is an answer, which :mod:`grader.grade` judges in
this process against the reference it computes itself.
"""

from __future__ import annotations

import collections
import contextlib
import json
import os
import pickle
import secrets
import select
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from grader import frames, sandbox, strip
from grader.sandbox import ISOLATING, Interrupted, Limits, Sandbox, cache_folders
from grader.spec import LabSpec

__all__ = ["Ending", "GradingServer", "ServerLost", "Session", "SessionLost", "preload_modules",
           "stripped_modules"]

READY_TIMEOUT = 300.0
"""seconds the server may take to import the kit on a loaded machine."""
STATUS_TIMEOUT = 30.0
STDERR_TAIL = 4096


class ServerLost(BaseException):
    """The grading server itself stopped (killed from outside, or failed to start).

    Not an ``Exception``: a closed-loop harness that turns its controller's exceptions into an
    episode's verdict must not swallow it — it is the grader's failure, not the student's."""


class SessionLost(RuntimeError):
    """A submission's process stopped answering: ``why`` is ``"timeout"`` (no answer within
    the wall-clock deadline), ``"ended"`` (the stream closed), ``"unreadable"`` (an answer
    that is not one) or ``"too large"``."""

    def __init__(self, why: str, cell: int | None = None) -> None:
        super().__init__(why)
        self.why = why
        self.cell = cell
        """the cell that had started when it stopped, during the cells."""


@dataclass
class Ending:
    """How a submission's process ended, as its keeper saw it."""

    signal: int | None = None
    exit: int | None = None
    cpu: float = 0.0
    maxrss_kb: int = 0
    killed_by_grader: bool = False
    lost: str = ""
    """why the grader stopped waiting (``SessionLost.why``), if it did."""
    unknown: str = ""
    """no report from the keeper: why (the server died, the keeper failed)."""
    stdout_bytes: int = 0
    stderr_bytes: int = 0
    stderr_tail: str = ""
    started: bool = True
    """whether the process finished its own set-up (limits, seccomp, the grader's runner) before
    it ended; ``False``: it failed in the grader's set-up, before any of the submission's
    code could run."""


# ------------------------------------------------------------------ what the server holds

def stripped_modules(spec: LabSpec) -> dict[str, dict[str, Any]]:
    """The modules holding ``spec``'s references, rewritten without them: module name →
    ``{"path", "source", "package"}``."""
    import importlib

    out = {}
    for module, names in strip.defining_places(spec.guarded_names()).items():
        mod = importlib.import_module(module)
        path = str(Path(str(mod.__file__)).resolve())
        source = strip.stripped_source(Path(path).read_text(encoding="utf-8"), module, names,
                                       spec.name)
        out[module] = {"path": path, "source": source, "package": hasattr(mod, "__path__")}
    return out


BASE_PRELOAD = ("numpy", "scipy", "scipy.ndimage", "scipy.stats", "scipy.optimize",
                "scipy.sparse", "scipy.linalg", "matplotlib", "matplotlib.pyplot", "control",
                "IPython.display", "kit", "sim", "hardware")


def preload_modules(spec: LabSpec) -> list[str]:
    """What the grading server imports before forking: the scientific stack and every module
    of the kit, the simulator and the robot descriptions (each submission then starts with
    them in memory instead of importing them again)."""
    import importlib.util

    names = list(BASE_PRELOAD)
    for package in ("kit", "sim", "hardware"):
        found = importlib.util.find_spec(package)
        if found is None or not found.submodule_search_locations:
            continue
        names += [name for name in _submodules(list(found.submodule_search_locations),
                                               package + ".")
                  if not name.rsplit(".", 1)[-1].startswith("test")
                  and ".__main__" not in name and not name.endswith(".cli")]
    return names


def _submodules(paths: list[str], prefix: str) -> list[str]:
    """Every module and package below ``paths``, found on disk (``pkgutil.walk_packages``
    imports each package to look inside it: a second of the grader's time at start-up for
    modules the server imports anyway)."""
    import pkgutil

    names = []
    for info in pkgutil.iter_modules(paths, prefix):
        names.append(info.name)
        if info.ispkg:
            folder = os.path.join(getattr(info.module_finder, "path", ""),
                                  info.name.rsplit(".", 1)[-1])
            names += _submodules([folder], info.name + ".")
    return names


# Which CPU the machine's numerical libraries compile and dispatch for, as the grader's own
# environment sets it: a site that pins numba's target (NUMBA_CPU_NAME=generic, so that its
# caches serve every machine of a cluster), numpy's kernels or OpenBLAS's gets the same in
# its sandboxes. Without them a submission's numba looks for code compiled for the host's
# CPU, which the caches do not hold (they are keyed on the target), and compiles the kit's
# functions again on its own CPU time; and its numpy could differ from the grader's in the
# last bit.
CPU_TARGET_VARIABLES = ("NUMBA_CPU_NAME", "NUMBA_CPU_FEATURES", "NPY_DISABLE_CPU_FEATURES",
                        "NPY_ENABLE_CPU_FEATURES", "OPENBLAS_CORETYPE")


def _server_env(layer: str) -> dict[str, str]:
    """The whole environment of the server and its submissions: nothing of the grader's (no
    course secret, no tokens) but the CPU target of numba, numpy and OpenBLAS
    (:data:`CPU_TARGET_VARIABLES`), and the grader's process id so that an administrator can
    tell whose sandboxes these are."""
    env = {"LANG": "C.UTF-8", "KIT_GRADING": "1", "KIT_FAST": "1", "MPLBACKEND": "Agg",
           "OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1",
           "NUMBA_NUM_THREADS": "1", "PYTHONDONTWRITEBYTECODE": "1",
           "KIT_GRADER_PID": str(os.getpid())}
    env.update({name: os.environ[name] for name in CPU_TARGET_VARIABLES if name in os.environ})
    if layer in ISOLATING:
        env["MPLCONFIGDIR"] = sandbox.MPL_DIR
    return env


# ------------------------------------------------------------------ the server

class GradingServer:
    """One lab's grading server in one layer; thread-safe (each grading thread opens its own
    sessions). Restarts the server once it has died, at most :attr:`RESTARTS` times in a row:
    a session the server saw through to its end makes the count start again, so a
    long-lived process (an instructor's notebook, a Dask worker) is not refused for the
    stops of the past."""

    RESTARTS = 3

    def __init__(self, spec: LabSpec, layer: str, limits: Limits, slots: int = 8) -> None:
        self.spec, self.layer, self.limits, self.slots = spec, layer, limits, max(1, slots)
        self.stripped = stripped_modules(spec)
        self.preload = preload_modules(spec)
        self.lock = threading.Lock()
        self.proc: subprocess.Popen[bytes] | None = None
        self.box: Sandbox | None = None
        self.control: socket.socket | None = None
        self.free: collections.deque[int] = collections.deque()
        self.uid_ready = threading.Condition(self.lock)
        self.starts = 0
        self.stops_in_a_row = 0
        self.failed_imports: list[str] = []
        self.log = tempfile.TemporaryFile()
        with self.lock:
            self._start()

    # -- life

    def _start(self) -> None:
        if self.stops_in_a_row > self.RESTARTS:
            raise ServerLost("the grading server stopped too often")
        self.starts += 1
        env = _server_env(self.layer)
        stripped_files = {entry["path"]: entry["source"] for entry in self.stripped.values()}
        box = Sandbox.create(self.layer, self.limits, env,
                             stripped_files if self.layer in ISOLATING else None, self.slots)
        roots = [str(Path(p)) for p in sandbox._package_dirs()]
        config = {"layer": self.layer, "home": box.home, "env": box.env,
                  "preload": self.preload, "caches": cache_folders(roots)
                  if self.layer in ISOLATING else [], "stripped": self.stripped}
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        config_fd = os.memfd_create("kit-server-config")
        os.write(config_fd, json.dumps(config).encode("utf-8"))
        os.lseek(config_fd, 0, os.SEEK_SET)
        try:
            proc = box.start([sys.executable, "-I", "-B", f"{sandbox.grader_dir()}/zygote.py",
                              str(theirs.fileno()), str(config_fd)],
                             stdin=subprocess.DEVNULL, stdout=self.log, stderr=self.log,
                             pass_fds=(theirs.fileno(), config_fd))
        finally:
            theirs.close()
            os.close(config_fd)
        self.proc, self.box, self.control = proc, box, ours
        ready, _, _ = select.select([ours], [], [], READY_TIMEOUT)
        message = ours.recv(1 << 16) if ready else b""
        try:
            hello = json.loads(message) if message else {}
        except ValueError:
            hello = {}
        if not hello.get("ready"):
            self._stop()
            raise ServerLost(f"the grading server did not start: {self._log_tail()}")
        self.failed_imports = list(hello.get("failed", []))
        self.free = collections.deque(box.uids)

    def _log_tail(self) -> str:
        self.log.seek(0, os.SEEK_END)
        size = self.log.tell()
        self.log.seek(max(0, size - 2000))
        return self.log.read().decode("utf-8", "replace").strip()[-600:] or "no output"

    def alive(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def _stop(self) -> None:
        if self.control is not None:
            self.control.close()
            self.control = None
        if self.proc is not None and self.box is not None:
            self.box.finish(self.proc)
        self.proc = None

    def close(self) -> None:
        with self.lock:
            self._stop()
            self.uid_ready.notify_all()
        self.log.close()

    # -- sessions

    def _take_uid(self) -> int:
        while not self.free:
            if sandbox.stopping():
                raise Interrupted("grading is being stopped")
            self.uid_ready.wait(timeout=1.0)
        return self.free.popleft()

    def _served(self, generation: int) -> None:
        """A session of this server's ``generation`` ended with its keeper's report."""
        with self.lock:
            if generation == self.starts:
                self.stops_in_a_row = 0

    def _give_uid(self, uid: int, generation: int) -> None:
        with self.lock:
            if generation == self.starts and uid not in self.free:
                self.free.append(uid)
            self.uid_ready.notify()

    def session(self, memory_mb: int, cpu_seconds: int) -> Session:
        """A fresh process for one submission (raises :class:`ServerLost` when the server
        cannot give one, :class:`~grader.sandbox.Interrupted` once grading stops)."""
        with self.lock:
            if sandbox.stopping():
                raise Interrupted("grading is being stopped")
            if not self.alive():
                self.stops_in_a_row += 1
                self._stop()
                self._start()
            uid = self._take_uid()
            generation = self.starts
            home = tempfile.mkdtemp(prefix="home-", dir=str(self.box.scratch)) \
                if self.box is not None and self.box.scratch is not None else ""
            channel, their_channel = socket.socketpair()
            status, their_status = socket.socketpair()
            out, err = tempfile.TemporaryFile(), tempfile.TemporaryFile()
            request = {"uid": uid, "memory_mb": memory_mb, "cpu_seconds": cpu_seconds,
                       "file_mb": self.limits.file_mb, "processes": self.limits.processes,
                       "scratch_mb": self.limits.scratch_mb, "home": home}
            try:
                assert self.control is not None
                socket.send_fds(self.control, [json.dumps(request).encode()],
                                [their_channel.fileno(), their_status.fileno(), out.fileno(),
                                 err.fileno()])
            except OSError:
                for s in (channel, status):
                    s.close()
                out.close()
                err.close()
                self.free.appendleft(uid)
                raise ServerLost("the grading server stopped (killed from outside?)") \
                    from None
            finally:
                their_channel.close()
                their_status.close()
        return Session(self, channel, status, out, err,
                       lambda: self._give_uid(uid, generation), home,
                       lambda: self._served(generation))


class Session:
    """One submission's process: questions out, answers in, then how it ended."""

    def __init__(self, server: GradingServer, channel: socket.socket, status: socket.socket,
                 out: IO[bytes], err: IO[bytes], release: Any, home: str,
                 served: Any = None) -> None:
        self.server, self.channel, self.status = server, channel, status
        self.out, self.err, self.release, self.home = out, err, release, home
        self.served = served
        self.reader = frames.Reader(channel)
        self.started_cell: int | None = None
        self.ending: Ending | None = None

    def ask(self, op: str, payload: Any, wall: float) -> tuple[dict[str, Any], list[bytes]]:
        """Send one question, return its answer; :class:`SessionLost` when none comes within
        ``wall`` seconds (counted again from each cell's start while cells run)."""
        if self.ending is not None:
            raise SessionLost("ended")
        qid = secrets.token_hex(8)
        deadline = time.monotonic() + wall
        try:
            frames.write_all(self.channel, frames.encode(
                {"op": op, "id": qid}, [_pickled(payload)]), deadline)
            while True:
                header, blobs = self.reader.read(deadline)
                if header.get("op") == "started" and isinstance(header.get("cell"), int):
                    self.started_cell = header["cell"]
                    deadline = time.monotonic() + wall
                    continue
                if header.get("id") != qid:
                    raise SessionLost("unreadable", self.started_cell)
                return header, blobs
        except frames.FrameTimeout:
            raise SessionLost("timeout", self.started_cell) from None
        except frames.FrameError as exc:
            why = "too large" if "larger" in str(exc) else (
                "ended" if "ended" in str(exc) or "failed" in str(exc) else "unreadable")
            raise SessionLost(why, self.started_cell) from None

    def finish(self, lost: str = "", read_stderr: bool = True) -> Ending:
        """End the process (politely, else by force) and return how it ended. ``read_stderr``
        is ``False`` once it has held hidden inputs: then nothing it printed is read."""
        if self.ending is not None:
            return self.ending
        with contextlib.suppress(OSError, frames.FrameError, frames.FrameTimeout):
            if not lost:
                frames.write_all(self.channel, frames.encode({"op": "bye"}),
                                 time.monotonic() + 2.0)
        self.channel.close()
        report = self._report(kill=bool(lost) and lost != "ended")
        ending = Ending(lost=lost)
        if report is None:
            ending.unknown = ("the grading server stopped (killed from outside?)"
                              if not self.server.alive() else "its keeper did not report")
        elif "keeper_error" in report:
            ending.unknown = f"its keeper failed: {str(report['keeper_error'])[-300:]}"
        else:
            if self.served is not None:
                self.served()
            ending.signal = report.get("signal")
            ending.exit = report.get("exit")
            ending.cpu = float(report.get("cpu", 0.0))
            ending.maxrss_kb = int(report.get("maxrss_kb", 0))
            ending.killed_by_grader = bool(report.get("killed_by_grader"))
            ending.started = report.get("started", True) is not False
        ending.stdout_bytes = os.fstat(self.out.fileno()).st_size
        ending.stderr_bytes = os.fstat(self.err.fileno()).st_size
        if read_stderr:
            self.err.seek(max(0, ending.stderr_bytes - STDERR_TAIL))
            ending.stderr_tail = self.err.read().decode("utf-8", "replace")
        self.out.close()
        self.err.close()
        self.status.close()
        if self.home:
            shutil.rmtree(self.home, ignore_errors=True)
        self.release()
        self.ending = ending
        return ending

    def _report(self, kill: bool) -> dict[str, Any] | None:
        """The keeper's one line; asking it to kill first when ``kill``, and anyway once the
        process does not end by itself within a few seconds."""
        deadline = time.monotonic() + (0.0 if kill else 5.0)
        for attempt in ("wait", "kill"):
            if attempt == "kill":
                with contextlib.suppress(OSError):
                    self.status.shutdown(socket.SHUT_WR)  # the keeper kills on EOF
                deadline = time.monotonic() + STATUS_TIMEOUT
            line = self._read_line(deadline)
            if line is not None:
                try:
                    report = json.loads(line)
                except ValueError:
                    return None
                return report if isinstance(report, dict) else None
            if not self.server.alive():
                return None
        return None

    def _read_line(self, deadline: float) -> bytes | None:
        data = b""
        while b"\n" not in data:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            ready, _, _ = select.select([self.status], [], [], left)
            if not ready:
                return None
            chunk = self.status.recv(1 << 16)
            if not chunk:
                return data or None
            data += chunk
        return data.split(b"\n", 1)[0]


def _reduce_robot(robot: Any) -> tuple[Any, tuple[str]]:
    from kit.robots import load

    return load, (str(robot.source),)


def _pickled(payload: Any) -> bytes:
    """A question's arguments for the submission's process (the grader's own objects, so
    pickle is safe here; answers never travel this way). A robot description travels as the
    file it was loaded from."""
    import copyreg
    import io

    from kit.robots import RobotDescription

    buffer = io.BytesIO()
    pickler = pickle.Pickler(buffer, protocol=5)
    pickler.dispatch_table = copyreg.dispatch_table.copy()
    pickler.dispatch_table[RobotDescription] = _reduce_robot
    pickler.dump(payload)
    return buffer.getvalue()


@contextlib.contextmanager
def serving(spec: LabSpec, layer: str, limits: Limits, slots: int) -> Iterator[GradingServer]:
    server = GradingServer(spec, layer, limits, slots)
    try:
        yield server
    finally:
        server.close()

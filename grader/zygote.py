"""The grading server inside the sandbox: imports the kit once, forks a fresh prison per
submission. ``python -I -B grader/zygote.py CONTROL_FD``.

The grader starts one per grading run and lab, inside the strongest sandbox layer
(:mod:`grader.sandbox`: bubblewrap, or ``unshare`` with :mod:`grader.jail`), on a read-only
file system built from an allow-list in which the lab's references are cut out of their
modules (:mod:`grader.strip`). It imports numpy, matplotlib, the kit, the simulator — the
second of CPU a submission would otherwise spend on imports — and then serves fork requests on
its control socket; it never runs a line of a submission and never holds one.

Its first argument is a SOCK_SEQPACKET socket carrying fork requests (a few numbers and four
descriptors: the submission's channel, its status pipe, its standard output and error); its
second is a file with its configuration (which modules to import, the stripped modules' text,
the environment, the cache folders).

Per request it forks a **keeper**, which enters new mount, PID, network, IPC and UTS
namespaces and forks their first process; that one mounts the namespace's own ``/proc`` and
private ``/tmp``, ``/dev/shm``, home and compiled-code caches (nothing of one submission is
visible to the next), drops to a user id of its own with no capabilities, and forks the
submission's process, which takes its resource limits (address space, CPU time, file size,
processes, no core dumps), loads the seccomp filter (:mod:`grader.seccomp`) and only then
starts answering the grader (:mod:`grader.runner`). The first process stays, deaf to the
submission's signals as a namespace's init is, reaps orphans and reports how the submission's
process ended (exit code or signal, CPU time, peak memory) to the keeper, which stays outside
as root and writes it on a status pipe the grader alone reads; when the grader closes that
pipe, the keeper kills the whole namespace.

In the ``rlimits`` layer (no isolation) the same happens without namespaces or a user id of
its own: resource limits only.

Standard library and the kit only; no secret, no reference and no submission ever enter this
process, so a submission's process — a copy of it — holds none either.
"""

from __future__ import annotations

import ctypes
import importlib
import importlib.util  # here, not in find_spec: importing it there would ask find_spec again
import json
import os
import resource
import select
import signal
import socket
import sys
import traceback
from typing import Any

__all__ = ["main"]

PR_SET_PDEATHSIG = 1
CLONE_NEWNS, CLONE_NEWUTS, CLONE_NEWIPC = 0x00020000, 0x04000000, 0x08000000
CLONE_NEWPID, CLONE_NEWNET = 0x20000000, 0x40000000
MS_NOSUID, MS_NODEV, MS_NOEXEC, MS_BIND, MS_REC, MS_PRIVATE = 2, 4, 8, 4096, 1 << 14, 1 << 18

_libc = ctypes.CDLL(None, use_errno=True)
_libc.mount.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_ulong,
                        ctypes.c_char_p]


def _check(result: int, what: str) -> None:
    if result != 0:
        errno = ctypes.get_errno()
        raise OSError(errno, f"{what}: {os.strerror(errno)}")


def _mount(source: str | None, target: str, fstype: str | None, flags: int,
           data: str | None = None) -> None:
    _check(_libc.mount(source.encode() if source else None, target.encode(),
                       fstype.encode() if fstype else None, flags,
                       data.encode() if data else None), f"mount {target}")


def _die_with_parent() -> None:
    _libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)


# ------------------------------------------------------------------ the template

class _StrippedFinder:
    """Serves the lab's stripped modules from the text the grader sent (the rlimits layer has
    no mounts to replace their files; the isolating layers have both)."""

    def __init__(self, sources: dict[str, dict[str, Any]]) -> None:
        self.sources = sources

    def find_spec(self, name: str, path: Any = None, target: Any = None) -> Any:
        entry = self.sources.get(name)
        if entry is None:
            return None
        loader = _SourceLoader(entry["source"], entry["path"])
        locations = [os.path.dirname(entry["path"])] if entry.get("package") else None
        return importlib.util.spec_from_file_location(
            name, entry["path"], loader=loader,  # type: ignore[arg-type]
            submodule_search_locations=locations)


class _SourceLoader:
    def __init__(self, source: str, path: str) -> None:
        self.source, self.path = source, path

    def create_module(self, spec: Any) -> None:
        return None

    def exec_module(self, module: Any) -> None:
        exec(compile(self.source, self.path, "exec", dont_inherit=True), module.__dict__)


def _preload(names: list[str]) -> list[str]:
    """Import what the lab's cells import, once; returns the modules that failed."""
    failed = []
    for name in names:
        try:
            importlib.import_module(name)
        except Exception:  # a module a lab names but this machine lacks: the cells will say
            failed.append(name)
    return failed


def _read_caches(folders: list[str]) -> dict[str, dict[str, bytes]]:
    """The compiled-code caches' files (numba's, Python's), copied into each submission's
    private tmpfs over their folder — numba needs its cache folder writable to use it."""
    caches = {}
    for folder in folders:
        files = {}
        for name in sorted(os.listdir(folder)):
            path = os.path.join(folder, name)
            if os.path.isfile(path) and os.path.getsize(path) > 0:  # stripped ones are empty
                with open(path, "rb") as fh:
                    files[name] = fh.read()
        caches[folder] = files
    return caches


# ------------------------------------------------------------------ one submission

def _isolate(config: dict[str, Any], request: dict[str, Any]) -> None:
    """In the submission's process, as root, before anything of it runs: its own /proc,
    /tmp, /dev/shm, home and caches, then its own user id."""
    _mount(None, "/", None, MS_REC | MS_PRIVATE)
    size = f"size={int(request['scratch_mb']) * 1024 * 1024}"
    for folder in ("/tmp", "/dev/shm", config["home"]):
        kept = _mounts_below(folder)  # a kit cloned under /tmp: its bound folders stay
        handles = [os.open(point, os.O_PATH) for point in kept]
        _mount("tmpfs", folder, "tmpfs", MS_NOSUID | MS_NODEV, f"{size},mode=1777")
        for point, handle in zip(kept, handles, strict=True):
            _bind_again(handle, point)
            os.close(handle)
    _mount("proc", "/proc", "proc", MS_NOSUID | MS_NODEV | MS_NOEXEC)
    uid = int(request["uid"])
    for folder, files in CACHES.items():
        _mount("tmpfs", folder, "tmpfs", MS_NOSUID | MS_NODEV, f"{size},mode=755")
        for name, data in files.items():
            with open(os.path.join(folder, name), "wb") as fh:
                fh.write(data)
        os.chown(folder, uid, uid)  # numba uses a cache folder only where it could write
    os.chown(config["home"], uid, uid)
    os.setgroups([])
    os.setresgid(uid, uid, uid)
    os.setresuid(uid, uid, uid)  # from root to a user of its own: every capability goes


def _mounts_below(folder: str) -> list[str]:
    """The mount points right below the mount on ``folder`` that can be seen
    (``/proc/self/mountinfo``): the sandbox's read-only binds of the kit, its packages and its
    virtual environment when they live under ``/tmp`` (a checkout in a temporary folder),
    which the submission's own tmpfs over ``/tmp`` would otherwise hide. Mounts already hidden
    by a later one on the same or a higher point are left out."""
    entries = []
    with open("/proc/self/mountinfo", encoding="utf-8", errors="surrogateescape") as fh:
        for line in fh:
            fields = line.split()
            point = fields[4]
            for code in ("\\040", "\\011", "\\012", "\\134"):
                point = point.replace(code, chr(int(code[1:], 8)))
            entries.append((int(fields[0]), int(fields[1]), point))
    on_folder = [mount for mount, _, point in entries if point == folder]
    below = folder.rstrip("/") + "/"
    if on_folder:
        top = {point: mount for mount, parent, point in entries
               if parent == on_folder[-1] and point.startswith(below)}
    else:
        inside = {mount for mount, _, point in entries if point.startswith(below)}
        top = {point: mount for mount, parent, point in entries
               if point.startswith(below) and parent not in inside}
    return sorted(top)


def _bind_again(handle: int, point: str) -> None:
    """Mounts what ``handle`` (an ``O_PATH`` descriptor opened before the tmpfs hid it) holds
    at ``point`` again, with everything mounted below it; a bind keeps its mount's flags, so a
    read-only bind stays read-only."""
    parent = os.path.dirname(point)
    os.makedirs(parent, mode=0o755, exist_ok=True)
    if os.path.isdir(f"/proc/self/fd/{handle}"):
        os.makedirs(point, mode=0o755, exist_ok=True)
    else:
        os.close(os.open(point, os.O_CREAT | os.O_WRONLY, 0o444))
    _mount(f"/proc/self/fd/{handle}", point, None, MS_BIND | MS_REC)


def _limit(request: dict[str, Any], isolating: bool) -> None:
    memory = int(request["memory_mb"]) * 1024 * 1024 + _address_space()
    resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
    cpu = int(request["cpu_seconds"])
    resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu + 5))
    size = int(request["file_mb"]) * 1024 * 1024
    resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))
    resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    if isolating:  # binds the submission's own user id (never root's or the grader's)
        processes = int(request["processes"])
        resource.setrlimit(resource.RLIMIT_NPROC, (processes, processes))


def _address_space() -> int:
    """Bytes of address space this process already maps (the imported kit): the memory
    limit is what a submission may add to it."""
    with open("/proc/self/status", encoding="ascii") as fh:
        for line in fh:
            if line.startswith("VmSize:"):
                return int(line.split()[1]) * 1024
    return 0


def _submission(config: dict[str, Any], request: dict[str, Any], channel: int, out: int,
                err: int, ready: int) -> None:
    """The submission's process: limits, the seccomp filter, then the answers. Writes one
    byte to ``ready`` once its own set-up is done, before any of the submission's code can
    run (a process that ends without it failed in the grader's set-up, not the student's
    code). Never returns."""
    try:
        isolating = config["layer"] != "rlimits"
        os.chdir(config["home"] if isolating else request["home"])
        devnull = os.open("/dev/null", os.O_RDONLY)
        os.dup2(devnull, 0)
        os.dup2(out, 1)
        os.dup2(err, 2)
        low, high = sorted((channel, ready))
        os.closerange(3, low)
        os.closerange(low + 1, high)
        os.closerange(high + 1, 1 << 16)
        os.environ.clear()
        os.environ.update(config["env"])
        os.environ.update(HOME=config["home"] if isolating else request["home"],
                          TMPDIR="/tmp" if isolating else request["home"])
        _limit(request, isolating)
        from grader import runner, seccomp

        if not seccomp.install():
            os.write(2, b"grader: no seccomp filter for this architecture\n")
        sys.stdout = os.fdopen(1, "w", buffering=1, encoding="utf-8", errors="replace")
        sys.stderr = os.fdopen(2, "w", buffering=1, encoding="utf-8", errors="replace")
        os.write(ready, b"1")
        os.close(ready)
        runner.serve(socket.socket(fileno=channel))
    except BaseException:
        try:
            os.write(2, traceback.format_exc().encode("utf-8", "replace")[-4000:])
        finally:
            os._exit(70)
    os._exit(0)


def _init(config: dict[str, Any], request: dict[str, Any], fds: list[int], report: int) -> None:
    """The first process of the submission's PID namespace: makes its private mounts and
    drops to its user, starts the submission's process, reaps orphans, and reports how the
    submission's process ended — as pid 1 it is deaf to the submission's signals, and the
    submission keeps the ordinary ones (a SIGSEGV it sends itself ends it). Never returns."""
    channel, out, err = fds
    try:
        _die_with_parent()
        if config["layer"] != "rlimits":
            _isolate(config, request)
        ready_in, ready_out = os.pipe()
        child = os.fork()
        if child == 0:
            os.close(report)
            os.close(ready_in)
            _die_with_parent()
            _submission(config, request, channel, out, err, ready_out)
        for fd in (channel, out, err, ready_out):
            os.close(fd)
        while True:
            pid, code, usage = os.wait4(-1, 0)
            if pid == child:
                break
        os.set_blocking(ready_in, False)
        try:
            started = os.read(ready_in, 1) == b"1"
        except BlockingIOError:
            started = False
        _report(report, {"signal": os.WTERMSIG(code) if os.WIFSIGNALED(code) else None,
                         "exit": os.WEXITSTATUS(code) if os.WIFEXITED(code) else None,
                         "cpu": usage.ru_utime + usage.ru_stime,
                         "maxrss_kb": usage.ru_maxrss, "started": started})
    except BaseException:
        _report(report, {"keeper_error": traceback.format_exc()[-2000:]})
    os._exit(0)


def _keeper(config: dict[str, Any], request: dict[str, Any], fds: list[int]) -> None:
    """Between the template and the submission: new namespaces, their first process, and the
    submission's ending reported on the status pipe (the grader's alone). Never returns."""
    channel, status, out, err = fds
    try:
        _die_with_parent()
        if config["layer"] != "rlimits":
            _check(_libc.unshare(CLONE_NEWNS | CLONE_NEWPID | CLONE_NEWNET | CLONE_NEWIPC
                                 | CLONE_NEWUTS), "unshare")
        report_in, report_out = os.pipe()
        child = os.fork()
        if child == 0:
            os.close(status)
            os.close(report_in)
            _init(config, request, [channel, out, err], report_out)
        for fd in (channel, out, err, report_out):
            os.close(fd)
        killed = _wait_or_kill(child, status)
        _, code, usage = os.wait4(child, 0)
        with os.fdopen(report_in, "rb") as fh:
            line = fh.readline()
        try:
            ending = json.loads(line) if line else None
        except ValueError:
            ending = None
        if not isinstance(ending, dict):  # the namespace's first process itself was killed
            ending = {"signal": os.WTERMSIG(code) if os.WIFSIGNALED(code) else None,
                      "exit": os.WEXITSTATUS(code) if os.WIFEXITED(code) else None,
                      "cpu": usage.ru_utime + usage.ru_stime, "maxrss_kb": usage.ru_maxrss}
        ending["killed_by_grader"] = killed
        _report(status, ending)
    except BaseException:
        _report(status, {"keeper_error": traceback.format_exc()[-2000:]})
    os._exit(0)


def _report(fd: int, ending: dict[str, Any]) -> None:
    try:
        os.write(fd, json.dumps(ending).encode() + b"\n")
    except OSError:
        pass  # the grader stopped listening


def _wait_or_kill(child: int, status: int) -> bool:
    """Until the submission's process ends; kill it when the grader closes the status pipe.
    Returns whether the grader asked for the kill."""
    pidfd = os.pidfd_open(child)
    try:
        while True:
            ready, _, _ = select.select([pidfd, status], [], [])
            if pidfd in ready:
                return False
            if status in ready:  # the grader's end closed (or wrote): stop it
                os.kill(child, signal.SIGKILL)
                return True
    finally:
        os.close(pidfd)


CACHES: dict[str, dict[str, bytes]] = {}


def _reap(signum: int, frame: Any) -> None:
    while True:
        try:
            pid, _ = os.waitpid(-1, os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return


def main(argv: list[str]) -> int:
    control = socket.socket(fileno=int(argv[0]))
    _die_with_parent()
    with os.fdopen(int(argv[1]), "rb") as fh:
        config = json.loads(fh.read())
    if config.get("stripped"):
        sys.meta_path.insert(0, _StrippedFinder(config["stripped"]))
    os.environ.update(config["env"])
    failed = _preload(config["preload"])
    CACHES.update(_read_caches(config["caches"]))
    signal.signal(signal.SIGCHLD, _reap)
    control.send(json.dumps({"ready": True, "failed": failed, "pid": os.getpid()}).encode())
    while True:
        try:
            data, fds, _, _ = socket.recv_fds(control, 1 << 16, 4)
        except InterruptedError:
            continue
        if not data:
            return 0  # the grader is gone
        request = json.loads(data)
        child = os.fork()
        if child == 0:
            signal.signal(signal.SIGCHLD, signal.SIG_DFL)
            control.close()
            _keeper(config, request, fds)
        for fd in fds:
            os.close(fd)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))


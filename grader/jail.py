"""The ``unshare`` layer's file system: ``python -I -S grader/jail.py PLAN_FD -- COMMAND...``.

Run as root inside the fresh mount, PID, network, IPC and UTS namespaces that ``unshare``
made: builds the sandbox's root from the plan that :func:`grader.sandbox.mount_plan` wrote to
``PLAN_FD`` (the same allow-list bubblewrap builds) and makes it read-only; then a child enters
it and executes ``COMMAND`` there — the grading server (:mod:`grader.zygote`), which stays
root inside these namespaces to make each submission's own prison and drops each submission to
a user of its own —, while this first process stays outside, reaping orphans and keeping the
parent-death signal that kills the whole namespace when ``unshare`` dies.

Standard library only, and run by path, so nothing of the kit is imported with root's rights.
Host paths are opened (``O_PATH``) before anything is mounted and bound through
``/proc/self/fd``, so a tmpfs mounted for staging cannot hide a source.
"""

from __future__ import annotations

import base64
import ctypes
import json
import os
import sys
from typing import Any

MS_RDONLY, MS_NOSUID, MS_NODEV, MS_NOEXEC = 1, 2, 4, 8
MS_REMOUNT, MS_BIND, MS_REC, MS_PRIVATE = 32, 4096, 16384, 1 << 18
STAGE = "/tmp"
ROOT = "/tmp/root"
DEVICES = ("null", "zero", "full", "random", "urandom", "tty")

_libc = ctypes.CDLL(None, use_errno=True)
_libc.mount.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p, ctypes.c_ulong,
                        ctypes.c_char_p]


def mount(source: str | None, target: str, fstype: str | None, flags: int,
          data: str | None = None) -> None:
    """``mount(2)``; raises OSError naming the target."""
    if _libc.mount(source.encode() if source else None, target.encode(),
                   fstype.encode() if fstype else None, flags,
                   data.encode() if data else None) != 0:
        errno = ctypes.get_errno()
        raise OSError(errno, f"mount {source} on {target}: {os.strerror(errno)}")


def _make_target(path: str, directory: bool) -> None:
    if directory:
        os.makedirs(path, exist_ok=True)
    else:
        os.makedirs(os.path.dirname(path), exist_ok=True)
        if not os.path.lexists(path):
            open(path, "w").close()


def _bind(fd: int, target: str, directory: bool, device: bool = False) -> None:
    _make_target(target, directory)
    mount(f"/proc/self/fd/{fd}", target, None, MS_BIND | MS_REC)
    flags = MS_REMOUNT | MS_BIND | MS_RDONLY | MS_NOSUID | (0 if device else MS_NODEV)
    mount(None, target, None, flags)


def _tmpfs(target: str, size: int, mode: int) -> None:
    os.makedirs(target, exist_ok=True)
    mount("tmpfs", target, "tmpfs", MS_NOSUID | MS_NODEV, f"size={size},mode={mode:o}")


def _dev(target: str, fds: dict[str, int]) -> None:
    _tmpfs(target, 1 << 20, 0o755)
    for name in DEVICES:
        if f"/dev/{name}" in fds:
            _bind(fds[f"/dev/{name}"], f"{target}/{name}", False, device=True)
    os.makedirs(f"{target}/pts")
    mount("devpts", f"{target}/pts", "devpts", MS_NOSUID | MS_NOEXEC,
          "newinstance,ptmxmode=0666,mode=0620")
    for link, to in (("ptmx", "pts/ptmx"), ("fd", "/proc/self/fd"), ("stdin", "/proc/self/fd/0"),
                     ("stdout", "/proc/self/fd/1"), ("stderr", "/proc/self/fd/2")):
        os.symlink(to, f"{target}/{link}")


def _data(index: int, item: dict[str, Any]) -> None:
    staged = f"{STAGE}/data{index}"
    with open(staged, "w", encoding="utf-8") as fh:
        fh.write(item["data"])
    os.chmod(staged, item["mode"])
    fd = os.open(staged, os.O_PATH | os.O_CLOEXEC)
    _bind(fd, ROOT + item["dest"], False)
    os.close(fd)


def build(plan: dict[str, Any]) -> None:
    """Build the root at ``ROOT`` from ``plan["mounts"]``, in order."""
    mount(None, "/", None, MS_REC | MS_PRIVATE)
    sources = {m["source"] for m in plan["mounts"] if m["kind"] == "bind"}
    sources |= {f"/dev/{name}" for name in DEVICES if os.path.exists(f"/dev/{name}")}
    fds = {s: os.open(s, os.O_PATH | os.O_CLOEXEC) for s in sorted(sources)}
    _tmpfs(STAGE, 64 << 20, 0o700)
    _tmpfs(ROOT, 1 << 20, 0o755)
    for index, item in enumerate(plan["mounts"]):
        kind, dest = item["kind"], ROOT + item["dest"]
        if kind == "bind":
            _bind(fds[item["source"]], dest, os.path.isdir(f"/proc/self/fd/{fds[item['source']]}"))
        elif kind == "dir" and not os.path.isdir(dest):
            os.makedirs(dest)
            os.chmod(dest, item["mode"])
        elif kind == "symlink":
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            os.symlink(item["source"], dest)
        elif kind == "tmpfs":
            _tmpfs(dest, item["size"], item["mode"])
        elif kind == "data":
            _data(index, item)
        elif kind == "file":
            os.makedirs(os.path.dirname(dest), exist_ok=True)
            with open(dest, "wb") as fh:
                fh.write(base64.b64decode(item["blob"]) if item.get("blob") else
                         item["data"].encode("utf-8"))
            os.chmod(dest, item["mode"])
        elif kind == "dev":
            _dev(dest, fds)
        elif kind == "proc":
            os.makedirs(dest, exist_ok=True)
            mount("proc", dest, "proc", MS_NOSUID | MS_NODEV | MS_NOEXEC)
    for fd in fds.values():
        os.close(fd)
    mount(None, ROOT, None, MS_REMOUNT | MS_RDONLY | MS_NOSUID | MS_NODEV)


def enter(plan: dict[str, Any]) -> None:
    """Into the new root, for good. The grading server started there stays root (inside
    these namespaces) to make each submission's prison; the submissions drop to users of
    their own (:mod:`grader.zygote`)."""
    os.chroot(ROOT)
    os.chdir(plan["home"])


def main(argv: list[str]) -> int:
    if len(argv) < 3 or argv[1] != "--":
        print("usage: jail.py PLAN_FD -- COMMAND...", file=sys.stderr)
        return 2
    fd = int(argv[0])
    with os.fdopen(fd, "rb") as fh:
        plan = json.loads(fh.read())
    build(plan)
    child = os.fork()
    if child == 0:
        enter(plan)
        os.execve(argv[2], argv[2:], plan["env"])
    # this first process keeps root's identity: changing it would clear the parent-death
    # signal that ``unshare --kill-child`` set, and the namespace must die with ``unshare``
    return reap(child)


def reap(child: int) -> int:
    """As the namespace's first process: collect every orphan until ``child`` ends, then end
    with its status (a signal as 128 + n; everything else in the namespace dies with us)."""
    while True:
        try:
            pid, status = os.waitpid(-1, 0)
        except ChildProcessError:
            return 1
        if pid == child:
            return 128 + os.WTERMSIG(status) if os.WIFSIGNALED(status) else \
                os.WEXITSTATUS(status)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

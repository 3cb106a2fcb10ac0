"""Where a submission runs: the strongest isolation layer this machine offers.

Layers, strongest first (the grader reports which one ran):

``bwrap``
    bubblewrap: a read-only view of the whole file system but for the submission's scratch
    directory, the submissions and the gradebook's folder hidden behind empty directories,
    no network, its own PID namespace (every process it starts dies with it).
``unshare``
    as root without bubblewrap: ``unshare --pid --fork --net`` and the submission dropped to
    the unprivileged user ``nobody``, which can write nothing but its scratch directory.
``rlimits``
    neither: resource limits and killing the process group only.

All layers add the same resource limits (address space, CPU time, file size, no core dumps)
and a wall-clock timeout enforced by the grader.
"""

from __future__ import annotations

import functools
import os
import resource
import shutil
import subprocess
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Limits", "Sandbox", "detect_layer", "layer_works"]

NOBODY = 65534


@dataclass(frozen=True)
class Limits:
    memory_mb: int = 2048
    cpu_seconds: int = 121
    file_mb: int = 64
    """largest file the submission may write, its captured output included."""


PROBE = [sys.executable, "-c", "import grader.worker"]


@functools.cache
def layer_works(layer: str) -> bool:
    """Whether ``layer`` can start the worker's Python here (bubblewrap may be missing or
    refused; the user ``nobody`` may be unable to read the kit's installation)."""
    if layer == "rlimits":
        return True
    if layer == "bwrap":
        if not shutil.which("bwrap"):
            return False
        command = ["bwrap", "--ro-bind", "/", "/", "--dev", "/dev", "--proc", "/proc",
                   "--unshare-all", "--die-with-parent", *PROBE]
    elif layer == "unshare":
        if os.geteuid() != 0 or not (shutil.which("unshare") and shutil.which("setpriv")):
            return False
        command = ["unshare", "--pid", "--fork", "--net", "setpriv", "--reuid", str(NOBODY),
                   "--regid", str(NOBODY), "--clear-groups", *PROBE]
    else:
        return False
    try:
        return subprocess.run(command, capture_output=True, timeout=60).returncode == 0
    except (OSError, subprocess.SubprocessError):
        return False


@functools.lru_cache(maxsize=1)
def detect_layer() -> str:
    """``"bwrap"``, ``"unshare"`` or ``"rlimits"``: the strongest that works here
    (``KIT_SANDBOX`` forces one)."""
    forced = os.environ.get("KIT_SANDBOX")
    if forced in ("bwrap", "unshare", "rlimits"):
        return forced
    return next(layer for layer in ("bwrap", "unshare", "rlimits") if layer_works(layer))


def _package_roots() -> list[Path]:
    """Folders the worker must be able to read: where kit, grader and sim are installed,
    and the Python installation itself."""
    import grader
    import kit
    import sim

    roots = [Path(m.__file__).resolve().parent.parent for m in (kit, grader, sim)
             if m.__file__]
    return [*roots, Path(sys.prefix).resolve(), Path(sys.base_prefix).resolve()]


@dataclass(frozen=True)
class Sandbox:
    """How to start ``python -m grader.worker`` for one submission."""

    scratch: Path
    hide: tuple[Path, ...]
    limits: Limits
    layer: str

    @classmethod
    def create(cls, scratch: Path, hide: Sequence[Path], limits: Limits) -> Sandbox:
        roots = _package_roots()
        safe = []
        for folder in {p.resolve() for p in hide if p.exists()}:
            # never hide a folder the kit itself is loaded from (grading `labs/` is fine,
            # grading `.` of an editable checkout would hide the kit)
            if not any(root == folder or folder in root.parents for root in roots):
                safe.append(folder)
        return cls(scratch.resolve(), tuple(sorted(safe)), limits, detect_layer())

    def command(self) -> list[str]:
        worker = [sys.executable, "-m", "grader.worker"]
        if self.layer == "bwrap":
            # no tmpfs over /tmp: the kit itself may live there (a CI checkout); temporary
            # files go to the scratch directory instead
            args = ["bwrap", "--ro-bind", "/", "/", "--dev", "/dev", "--proc", "/proc",
                    "--bind", str(self.scratch), str(self.scratch),
                    "--setenv", "TMPDIR", str(self.scratch)]
            for folder in self.hide:
                args += ["--tmpfs", str(folder), "--remount-ro", str(folder)]
            args += ["--chdir", str(self.scratch), "--unshare-all", "--die-with-parent",
                     "--new-session", "--setenv", "HOME", str(self.scratch)]
            return [*args, *worker]
        if self.layer == "unshare":
            # root makes the namespaces, then setpriv drops to nobody for the submission
            return ["unshare", "--pid", "--fork", "--net", "--kill-child", "setpriv",
                    "--reuid", str(NOBODY), "--regid", str(NOBODY), "--clear-groups",
                    *worker]
        return worker

    def prepare(self) -> None:
        """Give the scratch directory to the user the submission runs as."""
        if self.layer == "unshare":
            for path in (self.scratch, *self.scratch.iterdir()):
                os.chown(path, NOBODY, NOBODY)

    def preexec(self) -> Callable[[], None]:
        limits = self.limits

        def apply() -> None:
            memory = limits.memory_mb * 1024 * 1024
            resource.setrlimit(resource.RLIMIT_AS, (memory, memory))
            resource.setrlimit(resource.RLIMIT_CPU, (limits.cpu_seconds, limits.cpu_seconds + 5))
            size = limits.file_mb * 1024 * 1024
            resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))
            resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
        return apply

"""A background load that keeps every core busy, for running the tests as a busy machine
would (``make test-loaded``): a student's laptop running JupyterLab, a CI runner shared with
other jobs, an instructor grading while testing. No test may fail for that reason.

    python benchmarks/stress.py run [--workers N] -- COMMAND ...   # load, COMMAND, no load
    python benchmarks/stress.py start [--workers N]                 # load until stop
    python benchmarks/stress.py stop

Each worker is a process spinning the CPU at normal priority (``--workers``: one per core by
default). ``run`` exits with COMMAND's status and stops the workers however COMMAND ends
(Ctrl-C included); ``start`` records the workers' process ids in ``.stress.pids`` and ``stop``
ends exactly those.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
from pathlib import Path

PIDS = Path(__file__).resolve().parents[1] / ".stress.pids"
SPIN = "while True:\n    pass\n"


def _die_with_parent() -> None:
    """In a worker: end when the process that started it ends, however it ends (Linux)."""
    try:
        import ctypes

        ctypes.CDLL(None).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG
    except (OSError, AttributeError):
        pass


def start_workers(count: int, with_parent: bool) -> list[subprocess.Popen[bytes]]:
    """``count`` spinning processes; ``with_parent``: they end when this process does."""
    return [subprocess.Popen([sys.executable, "-c", SPIN], stdin=subprocess.DEVNULL,
                             preexec_fn=_die_with_parent if with_parent else None)
            for _ in range(count)]


def stop_workers(pids: list[int]) -> None:
    for pid in pids:
        try:
            os.kill(pid, signal.SIGTERM)
        except ProcessLookupError:
            pass


def _load() -> str:
    return f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python benchmarks/stress.py",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("action", choices=("run", "start", "stop"))
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1,
                        help="spinning processes (default: one per core)")
    argv = list(sys.argv[1:] if argv is None else argv)
    split = argv.index("--") if "--" in argv else len(argv)
    args = parser.parse_args(argv[:split])
    command = argv[split + 1:]
    if args.workers < 1:
        parser.error("--workers must be at least 1")
    if args.action != "run" and command:
        parser.error(f"{args.action} takes no command")
    if args.action == "stop":
        if not PIDS.exists():
            print("stress: no load running (no .stress.pids)")
            return 0
        stop_workers([int(p) for p in PIDS.read_text().split()])
        PIDS.unlink()
        print(f"stress: stopped; {_load()}")
        return 0
    if args.action == "start":
        if PIDS.exists():
            parser.error(f"a load is already running ({PIDS.name}); stop it first")
        workers = start_workers(args.workers, with_parent=False)
        PIDS.write_text(" ".join(str(w.pid) for w in workers) + "\n")
        print(f"stress: {args.workers} spinning processes started ({_load()}); "
              "python benchmarks/stress.py stop ends them")
        return 0
    if not command:
        parser.error("run needs a command after --")
    workers = start_workers(args.workers, with_parent=True)
    try:
        print(f"stress: {args.workers} spinning processes ({_load()}) while: "
              f"{' '.join(command)}", flush=True)
        status = subprocess.call(command)
    except KeyboardInterrupt:
        status = 130
    except OSError as exc:
        print(f"stress: cannot run {command[0]}: {exc.strerror}", file=sys.stderr)
        status = 127
    finally:
        stop_workers([w.pid for w in workers])
        for w in workers:
            w.wait()
    try:
        print(f"stress: stopped ({_load()}); the command exited with {status}", flush=True)
    except BrokenPipeError:         # a reader such as head that has gone: the status counts
        pass
    return status


if __name__ == "__main__":
    sys.exit(main())

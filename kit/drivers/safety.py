"""Motors that stop when the program does: every robot base that can move registers here,
and is stopped on every way out of the program.

=====================================  =================================================
how the program ends                   what stops the motors
=====================================  =================================================
``base.close()``, a ``with`` block     the base itself: zero speed, motors off, port closed
normal end, an uncaught exception      :func:`stop_all` through :mod:`atexit`
a notebook kernel shut down/restarted  the same (the kernel exits normally)
SIGTERM, SIGHUP                        :func:`stop_all`, then the signal's own action
SIGINT (Ctrl-C, a kernel interrupt)    :func:`halt_all` (zero speed, still ready), then
                                       Python's ``KeyboardInterrupt``
SIGKILL, a crash, a frozen host        nothing on the host can: the motor controllers' own
                                       watchdogs (``bases``), fed while the program runs
=====================================  =================================================

The signal handlers are installed once, from the main thread, when the first base
registers, and only over the default handlers (a program's own handlers are left alone and
called after the stop). The registry holds weak references: a base that is garbage is not
kept alive by it.
"""

from __future__ import annotations

import atexit
import os
import signal
import threading
import weakref
from collections.abc import Callable
from types import FrameType
from typing import Any, Protocol

__all__ = ["Stoppable", "active", "halt_all", "register", "stop_all", "unregister"]


class Stoppable(Protocol):
    def halt(self) -> None:
        """Zero speed, motors still under control (ready for the next command)."""

    def emergency_stop(self) -> None:
        """Zero speed and motors off, without raising (the program is ending)."""


_bases: weakref.WeakSet[Any] = weakref.WeakSet()
_lock = threading.Lock()
_installed = False
_previous: dict[int, Any] = {}
_SIGNALS = ("SIGTERM", "SIGHUP", "SIGINT")


def register(base: Stoppable) -> None:
    """Stop ``base`` on every way out of the program (installs the hooks the first time)."""
    global _installed
    with _lock:
        _bases.add(base)
        if _installed:
            return
        _installed = True
        atexit.register(stop_all)
    if threading.current_thread() is threading.main_thread():
        for name in _SIGNALS:
            number = getattr(signal, name, None)
            if number is None:  # (Windows has no SIGHUP)
                continue
            current = signal.getsignal(number)
            if current in (signal.SIG_DFL, signal.default_int_handler):
                _previous[number] = current
                signal.signal(number, _on_signal)


def unregister(base: Stoppable) -> None:
    """``base`` no longer needs stopping (it was stopped and closed)."""
    with _lock:
        _bases.discard(base)


def active() -> list[Stoppable]:
    """The bases that would be stopped now."""
    with _lock:
        return list(_bases)


def _each(action: Callable[[Any], None]) -> None:
    for base in active():
        try:
            action(base)
        except Exception:  # stop the others whatever one of them does
            pass


def stop_all() -> None:
    """Stop every registered base (zero speed, motors off) and forget them."""
    _each(lambda base: base.emergency_stop())
    with _lock:
        _bases.clear()


def halt_all() -> None:
    """Zero speed on every registered base; they stay ready for a new command."""
    _each(lambda base: base.halt())


def _on_signal(number: int, frame: FrameType | None) -> None:
    previous = _previous.get(number, signal.SIG_DFL)
    if number == getattr(signal, "SIGINT", None):
        halt_all()
    else:
        stop_all()
    if callable(previous):
        previous(number, frame)  # default_int_handler: KeyboardInterrupt, as before
    elif previous == signal.SIG_DFL:
        signal.signal(number, signal.SIG_DFL)
        os.kill(os.getpid(), number)  # the signal's own action: the program ends

"""The graded references, out of reach of the code they grade.

A lab's spec names the kit functions and classes a student must not call to solve an exercise
(``Exercise.blocked``, as ``module:name`` or ``module:Class.method``). :func:`install` puts a
guard in front of each: while an exercise function runs on a case — the notebook's ``check``
and the grading worker both call it through :func:`call_refusing` — a guarded reference raises
``PermissionError`` with the kit's explanation, however the student reached it (an import, an
alias in another kit module, an instance made earlier). Outside that call the guard passes the
call through, so the lab's own cells (simulations, plots, the fusion filter) and the kit's
internals keep working in an honest submission. The same rule holds in the notebook and while
grading: a student whose code calls a reference sees ✗ at once, never ✓ and then 0.

This is the notebook's courtesy, not grading's defence: it shows a student at once that a
reference will not count. While a notebook is *graded*, the references do not exist at all in
its process — they are cut out of their modules (:mod:`grader.strip`) — so a closure dug out
of a guard, a reload or a patched module finds nothing to run.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import sys
from collections.abc import Callable, Iterable
from types import FrameType
from typing import Any

__all__ = ["call_refusing", "explanation", "install", "reference_name", "refusing"]

MARK = "__kit_reference__"
"""attribute naming the reference a guard stands for."""


def call_refusing(fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Any:
    """``fn(*args, **kwargs)`` with every guarded reference refusing while it runs."""
    return fn(*args, **kwargs)


_SCOPE = call_refusing.__code__


def refusing() -> bool:
    """Whether the current thread is inside :func:`call_refusing`."""
    frame: FrameType | None = sys._getframe(1)
    while frame is not None:
        if frame.f_code is _SCOPE:
            return True
        frame = frame.f_back
    return False


def explanation(qualified: str) -> str:
    return (f"{qualified} is the kit's reference for this exercise: while it is checked or "
            f"graded, the exercise must be solved with your own code (the rest of the notebook "
            f"may use the kit)")


def _guard_function(real: Callable[..., Any], qualified: str) -> Callable[..., Any]:
    message = explanation(qualified)
    scope = _SCOPE

    @functools.wraps(real)
    def guard(*args: Any, **kwargs: Any) -> Any:
        frame: FrameType | None = sys._getframe(1)
        while frame is not None:
            if frame.f_code is scope:
                raise PermissionError(message)
            frame = frame.f_back
        return real(*args, **kwargs)

    del guard.__wrapped__
    try:
        guard.__signature__ = inspect.signature(real)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        pass
    setattr(guard, MARK, qualified)
    return guard


def _guard_attribute(owner: type, name: str, value: Any, qualified: str) -> Any:
    """The guarded form of one class attribute, or ``None`` when it needs none."""
    if isinstance(value, staticmethod):
        return staticmethod(_guard_function(value.__func__, qualified))
    if isinstance(value, classmethod):
        return classmethod(_guard_function(value.__func__, qualified))
    if isinstance(value, property):
        fget, fset, fdel = (_guard_function(f, qualified) if f else None
                            for f in (value.fget, value.fset, value.fdel))
        return property(fget, fset, fdel, value.__doc__)
    if inspect.isfunction(value) and getattr(value, MARK, None) is None:
        return _guard_function(value, qualified)
    return None


_PLAIN_DUNDERS = {"__init__", "__call__", "__post_init__", "__new__"}


def _guard_class(cls: type, qualified: str, only: str | None = None) -> None:
    """Guard ``cls``'s methods (all of them, or the one named ``only``) in place, so that
    instances made before, and subclasses, refuse too."""
    names = [only] if only else sorted({
        name for klass in cls.__mro__ if klass.__module__.startswith("kit")
        for name in vars(klass)
        if name in _PLAIN_DUNDERS or not name.startswith("__")})
    for name in names:
        owner = next((k for k in cls.__mro__ if name in vars(k)), None)
        if owner is None or owner is object:
            continue
        raw = vars(owner)[name]
        if getattr(raw, MARK, None) is not None and owner is cls:
            continue
        guarded = _guard_attribute(owner, name, raw, f"{qualified}.{name}" if not only
                                   else qualified)
        if guarded is not None:
            setattr(cls, name, guarded)  # shadows an inherited method on this class only
    if only is None:
        setattr(cls, MARK, qualified)


def _resolve(qualified: str) -> tuple[Any, str, Any]:
    """``module:attr`` or ``module:Class.method`` → (owner, attribute name, value)."""
    module_name, _, path = qualified.partition(":")
    owner: Any = importlib.import_module(module_name)
    *parents, attr = path.split(".")
    for part in parents:
        owner = getattr(owner, part)
    return owner, attr, getattr(owner, attr)


def install(blocked: Iterable[str], namespaces: Iterable[dict[str, Any]] = ()) -> int:
    """Guard every ``module:name`` of ``blocked``; returns how many were newly guarded.

    Functions are replaced where they are looked up — their module, and every alias of them
    in a loaded module's namespace or in ``namespaces`` (a notebook's globals); classes and
    methods are guarded in place. Installing twice guards nothing twice.
    """
    originals: dict[int, Any] = {}
    count = 0
    # the kit's names first: a spec module imported to resolve its own names must find the
    # kit's references already guarded (its exercises keep what they found)
    for qualified in sorted(set(blocked), key=lambda q: (q.startswith("grader."), q)):
        owner, attr, value = _resolve(qualified)
        display = qualified.replace(":", ".")
        if isinstance(owner, type):
            _guard_class(owner, display, only=attr)
            count += 1
        elif isinstance(value, type):
            if MARK not in vars(value):
                _guard_class(value, display)
                count += 1
        elif callable(value) and getattr(value, MARK, None) is None:
            guard = _guard_function(value, display)
            setattr(owner, attr, guard)
            originals[id(value)] = (value, guard)
            count += 1
    if originals:
        _replace_aliases(originals, namespaces)
    return count


def _replace_aliases(originals: dict[int, Any], namespaces: Iterable[dict[str, Any]]) -> None:
    spaces = [vars(m) for m in list(sys.modules.values()) if hasattr(m, "__dict__")]
    for space in [*spaces, *namespaces]:
        for key, value in list(space.items()):
            hit = originals.get(id(value))
            if hit is not None and hit[0] is value:
                space[key] = hit[1]


def reference_name(obj: Any) -> str | None:
    """The reference ``obj`` is (a guard, a guarded class or method), or ``None``."""
    target = getattr(obj, "__func__", obj)
    name = getattr(target, MARK, None)
    return name if isinstance(name, str) else None

"""Run All runs: a released lab executes top to bottom even with exercises unfinished.

A released exercise is a stub that raises ``NotImplementedError``. Every cell that calls one
(an example, a plot, a simulation) would stop Restart & Run All there with a traceback. The
setup cell's ``checker("lab01")`` therefore installs, when it runs in IPython, an AST
transformer that wraps every later cell so that

* a ``NotImplementedError`` raised by an exercise stub becomes one line naming it —
  ``needs `forward_kinematics` (exercise 2) — not implemented yet`` — and the notebook goes on;
* a later ``NameError`` for a name that such a skipped cell would have defined becomes
  ``needs the results of an earlier cell that did not run to the end (`path`)``;
* every other exception is raised as before (a real mistake still shows its traceback), and
  the cell's last expression is still displayed as ``Out[n]``.

Nothing changes outside IPython (the grader's worker executes cells as plain Python), while a
submission is graded (``KIT_GRADING``) or under nbgrader (``NBGRADER_EXECUTION``), where a
missing exercise must count as missing.

A lab author writes example cells as plain code: call the student's functions directly, with
no ``try``/``except`` and no "if implemented" tests. A cell that must define names for later
cells should define them in the same cell that calls the exercise (the transformer records
what a skipped cell would have defined).
"""

from __future__ import annotations

import ast
import os
import sys
import traceback
from collections.abc import Iterable
from types import TracebackType
from typing import Any

__all__ = ["RunAllGuard", "cell_wrapper", "defined_names", "install", "installed_guard"]

GUARD_NAME = "__kit_runall__"
"""The name under which the guard lives in the notebook's namespace."""
_VALUE = "__kit_runall_value__"


def defined_names(tree: ast.Module) -> tuple[str, ...]:
    """The names a cell binds at its top level (assignments, ``def``, ``class``, imports,
    ``for`` and ``with`` targets), in order of appearance."""
    names: list[str] = []

    def targets(node: ast.AST) -> None:
        for sub in ast.walk(node):
            if isinstance(sub, ast.Name) and isinstance(sub.ctx, ast.Store):
                names.append(sub.id)

    for stmt in tree.body:
        if isinstance(stmt, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names.append(stmt.name)
        elif isinstance(stmt, (ast.Import, ast.ImportFrom)):
            names.extend((a.asname or a.name).partition(".")[0] for a in stmt.names)
        elif isinstance(stmt, (ast.Assign, ast.AnnAssign, ast.AugAssign)):
            for target in (stmt.targets if isinstance(stmt, ast.Assign) else [stmt.target]):
                targets(target)
        elif isinstance(stmt, (ast.For, ast.AsyncFor, ast.With, ast.AsyncWith, ast.If,
                               ast.While, ast.Try)):
            targets(stmt)
    return tuple(dict.fromkeys(names))


def cell_wrapper(tree: ast.Module) -> ast.Module:
    """``tree`` wrapped in ``try: ... except (NotImplementedError, NameError)`` handed to the
    guard, the last expression (if any) kept as the cell's displayed value."""
    body = list(tree.body)
    future = []
    while body and isinstance(body[0], ast.ImportFrom) and body[0].module == "__future__":
        future.append(body.pop(0))  # must stay first in the cell, outside the try
    if not body:
        return tree
    last_expr = isinstance(body[-1], ast.Expr)
    if last_expr:
        expr = body.pop()
        assert isinstance(expr, ast.Expr)
        body.append(ast.Assign(targets=[ast.Name(_VALUE, ast.Store())], value=expr.value))
    names = ast.Tuple([ast.Constant(n) for n in defined_names(tree)], ast.Load())
    handler_call = ast.Expr(ast.Call(
        ast.Attribute(ast.Name(GUARD_NAME, ast.Load()), "skipped", ast.Load()),
        [ast.Name("__kit_error__", ast.Load()), names], []))
    handler_body: list[ast.stmt] = [handler_call]
    if last_expr:
        handler_body.append(ast.Assign(targets=[ast.Name(_VALUE, ast.Store())],
                                       value=ast.Constant(None)))
    guarded = ast.Try(
        body=body,
        handlers=[ast.ExceptHandler(
            type=ast.Tuple([ast.Name("NotImplementedError", ast.Load()),
                            ast.Name("NameError", ast.Load())], ast.Load()),
            name="__kit_error__", body=handler_body)],
        orelse=[], finalbody=[])
    new_body: list[ast.stmt] = [*future, guarded]
    if last_expr:
        new_body.append(ast.Expr(ast.Name(_VALUE, ast.Load())))
    module = ast.Module(body=new_body, type_ignores=[])
    return ast.fix_missing_locations(ast.copy_location(module, tree))


class RunAllGuard(ast.NodeTransformer):
    """The transformer IPython runs on every cell, and the handler its cells call.

    Parameters
    ----------
    exercises : iterable of str
        The lab's exercise function names, in the notebook's order (exercise 1 first).
    """

    def __init__(self, exercises: Iterable[str]) -> None:
        self.exercises = tuple(exercises)
        self.missing: set[str] = set()
        """names that a skipped cell would have defined (and no later cell has)."""

    # ------------------------------------------------------------------ transforming
    def visit_Module(self, node: ast.Module) -> ast.Module:
        if any(isinstance(n, ast.Name) and n.id == GUARD_NAME for n in ast.walk(node)):
            return node  # already wrapped, or code that manages the guard itself
        defined = set(defined_names(node))
        self.missing -= defined
        return cell_wrapper(node)

    # ------------------------------------------------------------------ at run time
    def stub_name(self, tb: TracebackType | None) -> str | None:
        """The innermost exercise function in the traceback: the stub that raised."""
        found = None
        for frame, _ in traceback.walk_tb(tb):
            if frame.f_code.co_name in self.exercises:
                found = frame.f_code.co_name
        return found

    def skipped(self, error: BaseException, names: tuple[str, ...]) -> None:
        """Report a cell stopped by an unfinished exercise (or by a name such a cell did not
        define) in one line; raise anything else again."""
        if isinstance(error, NameError):
            name = getattr(error, "name", None)
            if name not in self.missing:
                raise error
            print(f"needs the results of an earlier cell that did not run to the end "
                  f"(`{name}`): finish the exercise that cell needs, then run it again")
        else:
            stub = self.stub_name(error.__traceback__)
            if stub is None:
                raise error
            number = self.exercises.index(stub) + 1
            print(f"needs `{stub}` (exercise {number}) — not implemented yet")
        self.missing.update(names)


def _active() -> bool:
    return not (os.environ.get("KIT_GRADING") or os.environ.get("NBGRADER_EXECUTION"))


def installed_guard(shell: Any) -> RunAllGuard | None:
    """The guard already installed in ``shell``, if any."""
    for transformer in getattr(shell, "ast_transformers", ()):
        if isinstance(transformer, RunAllGuard):
            return transformer
    return None


def install(exercises: Iterable[str], shell: Any = None) -> RunAllGuard | None:
    """Install the guard in the running IPython shell (once; a second call replaces the
    exercise list). Returns ``None`` outside IPython, while grading and under nbgrader."""
    if not _active():
        return None
    if shell is None:
        ipython = sys.modules.get("IPython")
        get = getattr(ipython, "get_ipython", None) if ipython is not None else None
        shell = get() if get is not None else None
    if shell is None or not hasattr(shell, "ast_transformers"):
        return None
    guard = installed_guard(shell)
    if guard is None:
        guard = RunAllGuard(exercises)
        shell.ast_transformers.append(guard)
    else:
        guard.exercises = tuple(exercises)
    shell.user_ns[GUARD_NAME] = guard
    return guard

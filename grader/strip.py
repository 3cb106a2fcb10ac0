"""The kit as a graded submission sees it: the lab's references cut out of their modules.

While a lab is graded, the student's process must not hold the code that computes the
expected answers — not behind a guard, not in a closure, not in a source file it can read.
:func:`stripped_source` rewrites a module's source so that each graded name (an exercise's
reference and the kit names its spec blocks) keeps its signature and docstring but its body
only raises :class:`PermissionError` with the kit's explanation; everything else in the module
is untouched, so the rest of the kit imports and works. The sandbox mounts the rewritten text
over the module's file (:mod:`grader.sandbox`) and hides its compiled copies.

A function loses its decorators (a compiled ``@njit`` reference must not survive as machine
code), a class keeps its decorators and bases but every method of it refuses and so does
creating an instance, and a name bound by assignment (``f = functools.partial(...)``) is bound
to a refusing function instead.
"""

from __future__ import annotations

import ast
from collections.abc import Iterable

__all__ = ["REFUSE", "defining_places", "explanation", "stripped_source"]

REFUSE = "_kit_graded_reference"
"""the helper every stripped body calls."""


def explanation(qualified: str, lab: str) -> str:
    return (f"{qualified} is the kit's reference for {lab}'s exercises: it does not exist "
            f"while {lab} is graded; solve the exercise with your own code")


def _refusing_body(message: str, node: ast.AST) -> list[ast.stmt]:
    call = ast.Raise(exc=ast.Call(func=ast.Name(id="PermissionError", ctx=ast.Load()),
                                  args=[ast.Constant(message)], keywords=[]), cause=None)
    return [ast.copy_location(call, node)]


def _strip_function(node: ast.FunctionDef | ast.AsyncFunctionDef, message: str,
                    keep_decorators: bool = False) -> None:
    doc = ast.get_docstring(node, clean=False)
    body: list[ast.stmt] = [ast.Expr(ast.Constant(doc))] if doc else []
    node.body = body + _refusing_body(message, node)
    if not keep_decorators:
        node.decorator_list = []


def _strip_class(node: ast.ClassDef, message: str, only: str | None) -> bool:
    """Methods refuse (all of them, or ``only``); a wholly stripped class refuses to be
    created. Returns whether ``only`` was found."""
    found = False
    for item in node.body:
        if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)) and (
                only is None or item.name == only):
            # staticmethod/classmethod/property keep their kind; other decorators go
            keep: list[ast.expr] = [d for d in item.decorator_list if isinstance(d, ast.Name)
                                    and d.id in ("staticmethod", "classmethod", "property")]
            _strip_function(item, message)
            item.decorator_list = keep
            found = True
        elif only is not None and isinstance(item, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == only for t in item.targets):
            item.value = _refusing_value(message)
            found = True
    if only is None:
        new = ast.parse(f"def __new__(cls, *args, **kwargs):\n    raise PermissionError("
                        f"{message!r})\n").body[0]
        node.body.append(ast.copy_location(new, node))
        found = True
    return found


def _refusing_value(message: str) -> ast.expr:
    return ast.Call(func=ast.Name(id=REFUSE, ctx=ast.Load()), args=[ast.Constant(message)],
                    keywords=[])


HELPER = f'''

def {REFUSE}(message):
    def refuse(*args, **kwargs):
        raise PermissionError(message)
    return refuse
'''


def stripped_source(source: str, module: str, names: Iterable[str], lab: str) -> str:
    """``source`` of ``module`` with each of ``names`` (``name`` or ``Class.method``) cut out.

    Raises ``ValueError`` naming a graded name the module does not define at its top level:
    a spec that names what is not there must not silently leave it working.
    """
    tree = ast.parse(source)
    wanted = {n: explanation(f"{module}.{n}", lab) for n in names}
    done: set[str] = set()
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name in wanted:
            _strip_function(node, wanted[node.name])
            done.add(node.name)
        elif isinstance(node, ast.ClassDef):
            if node.name in wanted:
                _strip_class(node, wanted[node.name], None)
                done.add(node.name)
            for name in [n for n in wanted if n.startswith(node.name + ".")]:
                if _strip_class(node, wanted[name], name.split(".", 1)[1]):
                    done.add(name)
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            hit = [t.id for t in targets if isinstance(t, ast.Name) and t.id in wanted]
            if hit and node.value is not None:
                node.value = _refusing_value(wanted[hit[0]])
                done.update(hit)
    missing = sorted(set(wanted) - done)
    if missing:
        raise ValueError(f"{module} defines no top-level {', '.join(missing)} to strip: the "
                         f"lab's spec names a reference that is not there")
    text = ast.unparse(tree)
    # the helper goes after the module's docstring and __future__ imports, before anything
    # that might use it at import time
    lines = text.split("\n")
    at = _after_preamble(tree)
    return "\n".join(lines[:at]) + HELPER + "\n".join(lines[at:]) + "\n"


def _after_preamble(tree: ast.Module) -> int:
    """The line (0-based, in ``ast.unparse``'s text) after the docstring and ``__future__``
    imports."""
    count = 0
    for node in tree.body:
        if (isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)
                and isinstance(node.value.value, str) and count == 0) or (
                isinstance(node, ast.ImportFrom) and node.module == "__future__"):
            count += 1
            continue
        break
    unparsed = ast.unparse(ast.Module(body=tree.body[:count], type_ignores=[]))
    return len(unparsed.split("\n")) if count else 0


def defining_places(qualified_names: Iterable[str]) -> dict[str, list[str]]:
    """``module:name`` (as a spec names them: where a student finds them) → the module that
    *defines* each, with its name there: ``{"kit.drivers.rplidar._nodes": ["decode_node"]}``.

    A name a package re-exports is cut out where it is defined, so every alias of it refuses
    too. Names of the grader's own modules are left out (the grader is not in the sandbox).
    """
    import importlib
    import inspect

    places: dict[str, list[str]] = {}
    for qualified in qualified_names:
        module_name, _, path = qualified.partition(":")
        if module_name.split(".")[0] == "grader":
            continue
        owner: object = importlib.import_module(module_name)
        *parents, attr = path.split(".")
        for part in parents:
            owner = getattr(owner, part)
        value = getattr(owner, attr)
        target = value if not parents else owner
        where = getattr(inspect.unwrap(target) if callable(target) else target,
                        "__module__", None)
        qualname = getattr(target, "__qualname__", None)
        if isinstance(where, str) and isinstance(qualname, str) and "<" not in qualname \
                and where.split(".")[0] != "grader":
            name = qualname if not parents else f"{qualname}.{attr}"
        else:  # a partial or another callable object bound by assignment
            where, name = module_name, path
        places.setdefault(where, [])
        if name not in places[where]:
            places[where].append(name)
    return places

"""The kit as a graded submission sees it: each lab's references cut out of their modules
(grader/strip.py), so that they do not exist in the submission's process at all."""

from __future__ import annotations

import inspect
import sys
import types
from pathlib import Path

import pytest

from grader import strip
from grader.server import stripped_modules
from grader.spec import lab_names, load_lab

SOURCE = '''"""A module."""
from __future__ import annotations

import functools


def helper(x):
    return x + 1


def answer(x, y=2):
    """The reference."""
    return helper(x) * y


@functools.lru_cache
def cached(x):
    return x


class Filter:
    def __init__(self, gain):
        self.gain = gain

    def step(self, x):
        return self.gain * x

    def other(self, x):
        return -x


class Free:
    def run(self):
        return answer(1)


partial_answer = functools.partial(answer, y=3)
USES_HELPER = helper(1)
'''


def _load(text: str) -> types.ModuleType:
    module = types.ModuleType("stripped_example")
    exec(compile(text, "example.py", "exec"), module.__dict__)
    return module


def test_a_stripped_function_keeps_its_signature_and_doc_and_only_refuses():
    module = _load(strip.stripped_source(SOURCE, "kit.example", ["answer", "cached"], "lab99"))
    assert str(inspect.signature(module.answer)) == "(x, y=2)"
    assert module.answer.__doc__ == "The reference."
    with pytest.raises(PermissionError, match=r"kit\.example\.answer is the kit's reference "
                                              r"for lab99.*does not exist while lab99 is graded"):
        module.answer(1)
    with pytest.raises(PermissionError):
        module.cached(1)
    assert not hasattr(module.cached, "cache_info")     # its decorator is gone with it
    assert module.helper(1) == 2 and module.USES_HELPER == 2  # the rest is untouched
    assert module.answer.__closure__ is None             # nothing to dig out


def test_a_stripped_class_cannot_be_made_and_one_method_can_be_stripped_alone():
    module = _load(strip.stripped_source(SOURCE, "kit.example", ["Filter"], "lab99"))
    with pytest.raises(PermissionError):
        module.Filter(2.0)
    with pytest.raises(PermissionError):
        module.Filter.step(object(), 1.0)
    module = _load(strip.stripped_source(SOURCE, "kit.example", ["Filter.step"], "lab99"))
    f = module.Filter(2.0)
    assert f.other(1.0) == -1.0
    with pytest.raises(PermissionError, match=r"Filter\.step"):
        f.step(1.0)


def test_a_name_bound_by_assignment_is_bound_to_a_refusal():
    module = _load(strip.stripped_source(SOURCE, "kit.example", ["partial_answer"], "lab99"))
    with pytest.raises(PermissionError):
        module.partial_answer(1)
    assert module.answer(1) == 4  # what it was bound to is left, unless named too


def test_a_spec_naming_what_the_module_lacks_is_an_error_not_a_silent_pass():
    with pytest.raises(ValueError, match="defines no top-level nothing_here"):
        strip.stripped_source(SOURCE, "kit.example", ["nothing_here"], "lab99")


@pytest.mark.parametrize("lab", lab_names())
def test_every_labs_references_are_cut_where_they_are_defined(lab):
    """Each graded name of each lab refuses in the stripped module that defines it, and
    every kit module still imports with those modules replaced (the lab's setup cell and
    the rest of the kit keep working in the sandbox)."""
    spec = load_lab(lab)
    stripped = stripped_modules(spec)
    places = strip.defining_places(spec.guarded_names())
    assert set(stripped) == set(places)
    saved = {name: sys.modules.get(name) for name in stripped}
    try:
        for name, entry in stripped.items():
            module = types.ModuleType(name)
            module.__file__ = entry["path"]
            module.__package__ = name if entry["package"] else name.rpartition(".")[0]
            if entry["package"]:
                module.__path__ = [str(Path(entry["path"]).parent)]
            sys.modules[name] = module
            exec(compile(entry["source"], entry["path"], "exec"), module.__dict__)
            # the stripped text's lines (in the sandbox that text is mounted over the file;
            # here the file still holds the references, so inspect.getsource would read them)
            lines = entry["source"].splitlines(keepends=True)
            for qualified in places[name]:
                owner = module
                *parents, attr = qualified.split(".")
                for part in parents:
                    owner = getattr(owner, part)
                target = getattr(owner, attr)
                if inspect.isfunction(target):  # its whole body: the docstring, the refusal
                    block = inspect.getblock(lines[target.__code__.co_firstlineno - 1:])
                    assert "raise PermissionError" in "".join(block), qualified
                else:
                    assert isinstance(target, type), qualified
                args, kwargs = _placeholders(target)
                with pytest.raises(PermissionError):
                    target(*args, **kwargs)
    finally:
        for name, module in saved.items():
            if module is None:
                sys.modules.pop(name, None)
            else:
                sys.modules[name] = module


def _placeholders(target: object) -> tuple[list[None], dict[str, None]]:
    """``None`` for every required argument of ``target`` (its body must refuse first)."""
    try:
        params = inspect.signature(target).parameters.values()  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return [], {}
    required = [p for p in params if p.default is inspect.Parameter.empty]
    return ([None for p in required if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)],
            {p.name: None for p in required if p.kind == p.KEYWORD_ONLY})

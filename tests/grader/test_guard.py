"""Reference guards: they refuse inside an exercise's call and only there, wherever the
reference was reached from; a guarded module's stub refuses from its file."""

from __future__ import annotations

import sys
import types

import pytest

from grader import guard


@pytest.fixture()
def fake_kit(monkeypatch):
    """A stand-in for a kit module with a function, a class and an alias in another module."""
    mod = types.ModuleType("kit_guard_test_ref")

    def wheel_rpm(v):
        """The reference."""
        return 2 * v

    class Filter:
        def __init__(self, gain):
            self.gain = gain

        def step(self, x):
            return self.gain * x

        @staticmethod
        def helper(x):
            return x + 1

    class Tuned(Filter):
        pass

    class Base:
        def speeds(self, v):
            return (v, -v)

        def other(self):
            return "free"

    wheel_rpm.__module__ = Filter.__module__ = Tuned.__module__ = Base.__module__ = mod.__name__
    mod.wheel_rpm, mod.Filter, mod.Tuned, mod.Base = wheel_rpm, Filter, Tuned, Base
    user = types.ModuleType("kit_guard_test_user")
    user.wheel_rpm = wheel_rpm  # `from kit_guard_test_ref import wheel_rpm` elsewhere
    monkeypatch.setitem(sys.modules, mod.__name__, mod)
    monkeypatch.setitem(sys.modules, user.__name__, user)
    return mod, user


NAMES = ["kit_guard_test_ref:wheel_rpm", "kit_guard_test_ref:Filter",
         "kit_guard_test_ref:Base.speeds"]


def test_a_guarded_function_refuses_inside_the_exercise_call_and_only_there(fake_kit):
    mod, user = fake_kit
    notebook = {"rpm": mod.wheel_rpm}
    assert guard.install(NAMES, namespaces=[notebook]) == 3
    # outside an exercise's call the lab's own cells keep working
    assert mod.wheel_rpm(3) == 6 and user.wheel_rpm(3) == 6 and notebook["rpm"](3) == 6

    def student(v):
        return mod.wheel_rpm(v)

    for reached in (student, mod.wheel_rpm, user.wheel_rpm, notebook["rpm"]):
        with pytest.raises(PermissionError, match=r"kit_guard_test_ref\.wheel_rpm is the kit's "
                                                  r"reference .* your own code"):
            guard.call_refusing(reached, 3)
    assert guard.call_refusing(lambda v: 2 * v, 3) == 6  # the student's own code runs
    assert guard.reference_name(user.wheel_rpm) == "kit_guard_test_ref.wheel_rpm"
    assert mod.wheel_rpm.__doc__ == "The reference." and mod.wheel_rpm.__name__ == "wheel_rpm"


def test_guarded_classes_refuse_in_place_even_for_instances_made_before(fake_kit):
    mod, _ = fake_kit
    early = mod.Filter(2.0)
    tuned = mod.Tuned(3.0)
    guard.install(NAMES)
    assert early.step(1.0) == 2.0 and mod.Filter.helper(1) == 2  # outside: unchanged
    with pytest.raises(PermissionError, match=r"Filter\.step"):
        guard.call_refusing(early.step, 1.0)
    with pytest.raises(PermissionError, match=r"Filter\.__init__"):
        guard.call_refusing(mod.Filter, 1.0)
    with pytest.raises(PermissionError, match=r"Filter\.step"):
        guard.call_refusing(tuned.step, 1.0)  # a subclass inherits the guarded method
    with pytest.raises(PermissionError):
        guard.call_refusing(mod.Filter.helper, 1)
    assert isinstance(early, mod.Filter)  # still the same class
    assert guard.reference_name(mod.Filter) == "kit_guard_test_ref.Filter"


def test_one_method_can_be_guarded_and_the_rest_of_its_class_stays_free(fake_kit):
    mod, _ = fake_kit
    base = mod.Base()
    guard.install(NAMES)
    assert base.speeds(1) == (1, -1)
    with pytest.raises(PermissionError, match=r"Base\.speeds"):
        guard.call_refusing(base.speeds, 1)
    assert guard.call_refusing(base.other) == "free"
    assert guard.reference_name(mod.Base) is None


def test_installing_twice_guards_nothing_twice(fake_kit):
    mod, _ = fake_kit
    assert guard.install(NAMES) == 3
    first = mod.wheel_rpm
    assert guard.install(NAMES) == 1  # only the single method entry is re-checked
    assert mod.wheel_rpm is first and mod.wheel_rpm(2) == 4
    assert mod.Filter(2.0).step(2.0) == 4.0


def test_the_refusing_scope_is_seen_from_nested_calls_only_on_its_own_thread(fake_kit):
    mod, _ = fake_kit
    guard.install(NAMES)

    def deep(v, depth):
        return mod.wheel_rpm(v) if depth == 0 else deep(v, depth - 1)

    with pytest.raises(PermissionError):
        guard.call_refusing(deep, 1, 40)
    assert not guard.refusing()
    assert guard.call_refusing(guard.refusing) is True

"""The package's boundaries: ``kit.planning`` stays light and says what it exports."""

import subprocess
import sys

import kit.planning


def test_import_pulls_in_no_plotting_physics_or_other_packages():
    code = ("import sys, kit.planning\n"
            "print([m for m in ('matplotlib', 'pymunk', 'rosbags', 'sim', 'grader', 'hardware')"
            " if m in sys.modules])\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_all_lists_exactly_the_public_names():
    public = {n for n in vars(kit.planning) if not n.startswith("_")}
    modules = {n for n in public if type(getattr(kit.planning, n)).__name__ == "module"}
    assert set(kit.planning.__all__) == public - modules
    assert sorted(kit.planning.__all__) == sorted(set(kit.planning.__all__))

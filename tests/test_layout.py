"""The package boundaries DESIGN.md sets: ``import kit`` stays light and one-directional."""

import subprocess
import sys
from pathlib import Path


def test_import_kit_pulls_in_no_plotting_physics_or_other_packages():
    code = (
        "import sys\n"
        "import kit, kit.geometry, kit.msgs, kit.rosconv, kit.tf, kit.robots, kit.kinematics, "
        "kit.odometry, kit.maps\n"
        "kit.robots.load('uiabot')\n"
        "bad = [m for m in ('matplotlib', 'pymunk', 'rosbags', 'sim', 'grader', 'hardware')\n"
        "       if m in sys.modules]\n"
        "print(bad)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_no_function_in_the_packages_is_over_80_lines():
    """STYLE: a function that does one thing fits on a screen (docstring included)."""
    import ast

    root = Path(__file__).resolve().parents[1]
    long = []
    for package in ("kit", "sim", "grader", "hardware"):
        for path in sorted((root / package).rglob("*.py")):
            for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
                if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                    lines = node.end_lineno - node.lineno + 1
                    if lines > 80:
                        long.append(f"{path.relative_to(root)}:{node.lineno} {node.name} ({lines})")
    assert not long, "functions over 80 lines: " + ", ".join(long)


def test_no_module_of_the_kit_imports_the_simulator_grader_or_hardware():
    """DESIGN: dependencies point one way (``kit`` ← ``sim`` ← ``hardware``, ``grader`` →
    ``kit``); not even a lazy import inside a function may reach back up."""
    import ast

    root = Path(__file__).resolve().parents[1]
    upward = []
    for path in sorted((root / "kit").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            upward += [f"{path.relative_to(root)}:{node.lineno} {n}" for n in names
                       if n.split(".")[0] in ("sim", "grader", "hardware")]
    assert not upward, "kit imports from above it: " + ", ".join(upward)

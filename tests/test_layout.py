"""The package boundaries DESIGN.md sets: ``import kit`` stays light and one-directional."""

import subprocess
import sys


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

"""Run by ``python -m sim bench`` with a Python that has ir-sim (pip install ir-sim): one
differential robot with a 360-beam lidar at 10 Hz among the office's walls (read as JSON on
standard input), stepped headless; prints its real-time factor. Not imported by the kit."""

import json
import sys
import tempfile
import time
from pathlib import Path

request = json.load(sys.stdin)
lines = ["world:", "  height: 12", "  width: 20", "  step_time: 0.1", "  sample_time: 0.1",
         "  offset: [0, 0]", "  collision_mode: 'unobstructed'", "robot:",
         "  - kinematics: {name: 'diff'}", "    shape: {name: 'circle', radius: 0.2}",
         "    state: [1, 6, 0]", "    goal: [18, 6, 0]", "    behavior: {name: 'dash'}",
         "    sensors:", "      - type: 'lidar2d'", "        range_min: 0",
         "        range_max: 12", "        angle_range: 6.283185", "        number: 360",
         "obstacle:"]
for x1, y1, x2, y2 in request["segments"]:
    lines += [f"  - shape: {{name: 'linestring', vertices: [[{x1}, {y1}], [{x2}, {y2}]]}}",
              "    kinematics: {name: 'static'}", "    state: [0, 0, 0]"]
with tempfile.TemporaryDirectory() as tmp:
    path = Path(tmp) / "office.yaml"
    path.write_text("\n".join(lines) + "\n")
    import irsim

    env = irsim.make(str(path), headless=True)
    steps = round(request["seconds"] / 0.1)
    start = time.perf_counter()
    for _ in range(steps):
        env.step()
    elapsed = time.perf_counter() - start
print(f"{steps * 0.1 / elapsed:.1f}x (ir-sim {irsim.__version__})")

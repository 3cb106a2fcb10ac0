"""Lab 11 — the capstone: the student's controller drives the Uiabot, graded closed-loop.

The exercise is ``make_controller(robot)``; the grader does not compare what it returns with a
reference but runs it: :func:`sim.capstone.office_episode` drives seeded office episodes in the
grader's own process, asking the controller — which lives in the submission's sandboxed
process — for each step's command; each episode passes when the goal is reached in (simulated)
time without touching a wall, the glass, a box or a person (a bystander steps into a doorway on
the route in every episode) — partial credit episode by episode. ``time_limit`` is the CPU time
of one controller call. The kit's own controllers are not in the submission's process.
"""

from __future__ import annotations

import numpy as np

from grader.spec import Case, Exercise, LabSpec

PASS = {"reached": True, "no collision": True, "in time": True}


def _every_check_passes(seed: int) -> dict[str, bool]:
    """What an episode's verdict should be, whatever its seed (the harness's result says
    whether it was, and why not)."""
    return dict(PASS)


def _episodes(rng: np.random.Generator) -> list[Case]:
    return [Case(f"episode with seed {s}", (int(s),))
            for s in rng.choice(np.arange(1, 10_000), size=3, replace=False)]


make_controller = Exercise(
    id="lab11.make_controller", function="make_controller",
    title="Your controller in the loop: seeded office episodes", reference=_every_check_passes,
    points=10, public=(Case("episode with seed 0", (0,)),), hidden=_episodes,
    rtol=0.0, atol=0.0, harness="sim.capstone:office_episode", time_limit=2.0,
    blocked=("kit.navigation._pursuit:RegulatedPurePursuit", "kit.navigation._pursuit:PurePursuit",
             "kit.navigation._dwb:DwbController"),
)

SPEC = LabSpec(name="lab11", title="Capstone: closed loop", exercises=(make_controller,))

"""The kit's grader: exercise specs, notebook checks, release and sandboxed grading.

In a lab notebook::

    from grader import checker
    check = checker("lab01")
    check(forward_kinematics)

For instructors, the ``grader`` command: ``grader release`` (with ``check-release``),
``grader grade`` (sandboxed, into a resumable gradebook), ``grader feedback`` and
``grader bundle`` (the student hand-out).
"""

from grader.checker import checker

__all__ = ["checker"]

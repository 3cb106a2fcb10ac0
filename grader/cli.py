"""The instructor's command: ``grader release``, ``grader check-release``, ``grader grade``,
``grader feedback``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from grader import grade, release
from grader.feedback import write_feedback
from grader.sandbox import detect_layer
from grader.spec import load_lab, normalise_lab


def _release(args: argparse.Namespace) -> int:
    written = release.release(Path(args.solutions), Path(args.labs))
    for path in written:
        print(f"wrote {path}")
    return 0


def _check_release(args: argparse.Namespace) -> int:
    problems = release.check_release(Path(args.solutions), Path(args.labs))
    for p in problems:
        print(p)
    if not problems:
        print(f"{args.labs} is up to date with {args.solutions}")
    return 1 if problems else 0


def _grade(args: argparse.Namespace) -> int:
    lab = normalise_lab(args.lab)
    spec = load_lab(lab)
    paths = grade.find_submissions([Path(p) for p in args.submissions], lab)
    if not paths:
        print("no notebooks found in the given submissions", file=sys.stderr)
        return 2
    out = Path(args.out)
    json_path = Path(args.results) if args.results else out.with_suffix(".json")
    counts = {"graded": 0, "reused": 0}

    def progress(result: grade.SubmissionResult, reused: bool) -> None:
        counts["reused" if reused else "graded"] += 1
        note = "unchanged, kept" if reused else result.status
        extra = f" ({result.reason})" if result.status != "ok" and not reused else ""
        print(f"{result.student:<20} {result.total:6g} / {spec.max_points:g}  {note}{extra}",
              flush=True)

    print(f"grading {len(paths)} submissions of {lab}; sandbox: {detect_layer()}", flush=True)
    grade.grade_class(paths, spec, out, json_path, jobs=args.jobs, timeout=args.timeout,
                      memory_mb=args.memory, dask_address=args.dask, progress=progress)
    print(f"graded {counts['graded']}, kept {counts['reused']} unchanged; wrote {out} and "
          f"{json_path}")
    return 0


def _feedback(args: argparse.Namespace) -> int:
    written = write_feedback(Path(args.results), Path(args.out))
    print(f"wrote {len(written)} feedback files to {args.out}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="grader", description="Release lab notebooks to students and grade submissions.")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("release", help="write labs/ from solutions/ (solutions stripped)")
    p.add_argument("--solutions", default="solutions", help="instructor notebooks (solutions)")
    p.add_argument("--labs", default="labs", help="where the student notebooks go (labs)")
    p.set_defaults(func=_release)

    p = sub.add_parser("check-release", help="fail if labs/ differs from a fresh release")
    p.add_argument("--solutions", default="solutions")
    p.add_argument("--labs", default="labs")
    p.set_defaults(func=_check_release)

    p = sub.add_parser("grade", help="grade submitted notebooks into a gradebook CSV")
    p.add_argument("submissions", nargs="+", help="notebooks, or folders of notebooks")
    p.add_argument("--lab", required=True, help="which lab: 01, 1 or lab01")
    p.add_argument("--out", default="gradebook.csv", help="gradebook CSV (gradebook.csv)")
    p.add_argument("--results", help="JSON results with per-case reasons (beside --out); "
                   "also what a re-run resumes from")
    p.add_argument("--jobs", type=int, default=1, help="submissions graded at once (1)")
    p.add_argument("--timeout", type=float, default=grade.DEFAULT_TIMEOUT,
                   help="seconds a submission may run (120)")
    p.add_argument("--memory", type=int, default=grade.DEFAULT_MEMORY_MB,
                   help="memory limit per submission in MB (2048)")
    p.add_argument("--dask", metavar="ADDRESS",
                   help="send the submissions to this Dask scheduler instead of --jobs")
    p.set_defaults(func=_grade)

    p = sub.add_parser("feedback", help="one Markdown feedback file per student")
    p.add_argument("results", help="the JSON results `grader grade` wrote")
    p.add_argument("--out", default="feedback", help="folder for the files (feedback)")
    p.set_defaults(func=_feedback)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except (ValueError, FileNotFoundError) as exc:
        print(f"grader: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

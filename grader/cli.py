"""The instructor's command: ``grader release``, ``grader grade``, ``grader check-release``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from grader import grade, release
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
    results = grade.grade_submissions(paths, spec, jobs=args.jobs, timeout=args.timeout,
                                      memory_mb=args.memory)
    out = Path(args.out)
    grade.write_gradebook(out, results, spec)
    json_path = Path(args.results) if args.results else out.with_suffix(".json")
    grade.write_results(json_path, results, spec)
    width = max(len(r.student) for r in results)
    for r in results:
        print(f"{r.student:<{width}}  {r.total:5g} / {spec.max_points:g}  {r.status}"
              + (f" ({r.reason})" if r.status != "ok" else ""))
    print(f"wrote {out} and {json_path}")
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
    p.add_argument("--results", help="JSON results with per-case reasons (beside --out)")
    p.add_argument("--jobs", type=int, default=1, help="submissions graded at once (1)")
    p.add_argument("--timeout", type=float, default=grade.DEFAULT_TIMEOUT,
                   help="seconds a submission may run (120)")
    p.add_argument("--memory", type=int, default=grade.DEFAULT_MEMORY_MB,
                   help="memory limit per submission in MB (2048)")
    p.set_defaults(func=_grade)
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

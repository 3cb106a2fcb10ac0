"""The instructor's command: ``grader release``, ``grader check-release``, ``grader grade``,
``grader feedback``, ``grader bundle``.

``grader grade`` exits 0 when every row was graded (whatever the students' statuses), 1 when
some rows are ``grader error`` (its last line says how many and whose), 2 when it graded
nothing (bad arguments, no secret, no isolation, a gradebook it must not touch), and 130 or
143 when interrupted by SIGINT or SIGTERM (every sandbox stopped; run it again to resume).
"""

from __future__ import annotations

import argparse
import signal
import statistics
import sys
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from types import FrameType
from typing import Any

from grader import grade
from grader.feedback import write_feedback
from grader.grade import close_servers
from grader.gradebook import grade_class
from grader.results import STATUSES, SubmissionResult, display_points
from grader.sandbox import SandboxUnavailable, detect_layer, why_not_isolated
from grader.spec import LabSpec, load_lab, normalise_lab, read_secret
from grader.submissions import clean_text, find_submissions

NO_ISOLATION = (
    "this machine offers only the rlimits sandbox layer ({why}): it limits time and memory "
    "but cannot keep a submission from reading solutions/, the other submissions or your "
    "files, nor from writing them. Grade as root with bubblewrap installed (apt-get install "
    "bubblewrap); for a class you trust, pass --allow-no-isolation")
NO_SECRET = (
    "no course secret: set KIT_COURSE_SECRET or pass --secret-file FILE (the hidden cases are "
    "seeded from it; without it anyone can regenerate them). To grade for practice with "
    "public hidden cases, pass --practice")


def _release(args: argparse.Namespace) -> int:
    from grader import release  # nbformat, 1.3 s of imports the grading commands do without

    written = release.release(Path(args.solutions), Path(args.labs))
    for path in written:
        print(f"wrote {path}")
    return 0


def _check_release(args: argparse.Namespace) -> int:
    from grader import release

    problems = release.check_release(Path(args.solutions), Path(args.labs))
    for p in problems:
        print(p)
    if not problems:
        print(f"{args.labs} is up to date with {args.solutions}")
    return 1 if problems else 0


class _Progress:
    """A tqdm bar (count, rate, ETA) on a terminal, and one line per finished submission."""

    def __init__(self, total: int, spec: LabSpec, enabled: bool | None) -> None:
        from tqdm import tqdm

        self.spec = spec
        self.counts = {"graded": 0, "reused": 0}
        self.bar = tqdm(total=total, unit="submission", desc="grading", file=sys.stderr,
                        disable=None if enabled is None else not enabled)

    def __call__(self, result: SubmissionResult, reused: bool) -> None:
        self.counts["reused" if reused else "graded"] += 1
        note = "unchanged, kept" if reused else result.status
        extra = f" ({result.reason})" if result.status != "ok" and not reused else ""
        self.bar.write(f"{result.student:<20} {display_points(result.total):>6} / "
                       f"{self.spec.max_points:g}  {note}{extra}", file=sys.stdout)
        self.bar.update(1)

    def close(self) -> None:
        self.bar.close()


def summary(results: Sequence[SubmissionResult], maximum: float) -> list[str]:
    """The end-of-run table: rows per status, then the totals' mean and median."""
    counts = Counter(r.status for r in results)
    lines = [f"{'status':<20}{'rows':>6}"]
    lines += [f"{status:<20}{counts[status]:>6}" for status in STATUSES if counts[status]]
    totals = [r.total for r in results]
    if totals:
        lines.append(f"points: mean {display_points(statistics.fmean(totals))}, median "
                     f"{display_points(statistics.median(totals))} of {maximum:g} "
                     f"({len(totals)} rows)")
    return lines


def _secret(args: argparse.Namespace) -> tuple[str | None, str]:
    """(secret, problem): the course secret, or why grading must not start."""
    secret = read_secret(Path(args.secret_file) if args.secret_file else None)
    if args.practice:
        if secret is not None:
            print("--practice: the course secret is not used; the hidden cases are public")
        return None, ""
    return (secret, "") if secret is not None else (None, NO_SECRET)


def _interrupt(signum: int, frame: FrameType | None) -> None:
    raise KeyboardInterrupt(signal.Signals(signum).name)


def _grade(args: argparse.Namespace) -> int:
    lab = normalise_lab(args.lab)
    spec = load_lab(lab)
    secret, problem = _secret(args)
    if problem:
        print(f"grader: {problem}", file=sys.stderr)
        return 2
    layer = detect_layer() if not args.dask else "(on the Dask workers)"
    if layer == "rlimits" and not args.allow_no_isolation:
        print(f"grader: {NO_ISOLATION.format(why=why_not_isolated())}", file=sys.stderr)
        return 2
    found = find_submissions([Path(p) for p in args.submissions], lab)
    for path, why in found.skipped:
        print(f"skipped {clean_text(str(path))}: {why}")
    if not found.submissions:
        print("no notebooks of this lab found in the given submissions", file=sys.stderr)
        return 2
    out = Path(args.out)
    json_path = Path(args.results) if args.results else out.with_suffix(".json")
    practice = " (practice grading: the hidden cases are public)" if secret is None else ""
    print(f"grading {len(found.submissions)} submissions of {lab}; sandbox: {layer}{practice}",
          flush=True)
    return _run_class(args, spec, found.submissions, out, json_path, secret)


def _run_class(args: argparse.Namespace, spec: LabSpec, submissions: Sequence[Any], out: Path,
               json_path: Path, secret: str | None) -> int:
    progress = _Progress(len(submissions), spec, args.progress)
    previous = signal.signal(signal.SIGTERM, _interrupt)
    try:
        results = grade_class(submissions, spec, out, json_path, jobs=args.jobs,
                              timeout=args.timeout, memory_mb=args.memory, secret=secret,
                              dask_address=args.dask, progress=progress,
                              retry=tuple(args.retry or ()))
    except KeyboardInterrupt as exc:
        progress.close()
        name = str(exc) or "SIGINT"
        print(f"interrupted ({name}): every sandbox was stopped; {out} and {json_path} hold "
              f"the finished rows; run the same command again to resume", file=sys.stderr)
        return 143 if name == "SIGTERM" else 130
    finally:
        signal.signal(signal.SIGTERM, previous)
    progress.close()
    print("\n".join(summary(results, spec.max_points)))
    print(f"graded {progress.counts['graded']}, kept {progress.counts['reused']} unchanged; "
          f"wrote {out} and {json_path}")
    close_servers()
    ungraded = [r for r in results if r.status in ("malformed notebook", "refused", "duplicate")]
    if ungraded:
        kinds = Counter(r.status for r in ungraded)
        print(f"{len(ungraded)} rows have no notebook the grader could run "
              f"({', '.join(f'{k}: {n}' for k, n in sorted(kinds.items()))}; each row's reason "
              f"says why): {', '.join(r.student for r in ungraded)}")
    failed = [r.student for r in results if r.status == "grader error"]
    if failed:
        print(f"{len(failed)} rows are grader errors (the grader failed, not the student; "
              f"their reason says why; a re-run retries them): {', '.join(failed)}")
        return 1
    return 0


def _feedback(args: argparse.Namespace) -> int:
    written = write_feedback(Path(args.results), Path(args.out))
    print(f"wrote {len(written)} feedback files to {args.out}")
    return 0


def _bundle(args: argparse.Namespace) -> int:
    from grader import bundle

    written = bundle.bundle(Path(args.out), Path(args.root))
    print(f"wrote the student bundle to {args.out} ({len(written)} files): "
          f"`make lab` there installs it and opens the labs")
    return 0


def _add_grade(sub: Any) -> None:
    p = sub.add_parser(
        "grade", help="grade submitted notebooks into a gradebook CSV",
        description="Grade submitted notebooks, each in its own sandbox, into a gradebook CSV "
                    "and JSON results beside it (resumable: a re-run keeps finished rows).",
        epilog="A folder may hold one notebook per student (alice.ipynb) or one folder per "
               "student (alice/01-kinematics.ipynb): there only the notebook of the lab being "
               "graded counts, the others are listed as skipped. Exit status: 0 every row "
               "graded, 1 some rows are grader errors, 2 nothing graded, 130/143 interrupted.")
    p.add_argument("submissions", nargs="+", help="notebooks, or folders of notebooks")
    p.add_argument("--lab", required=True, help="which lab: 01, 1 or lab01")
    p.add_argument("--out", default="gradebook.csv", help="gradebook CSV (gradebook.csv)")
    p.add_argument("--results", help="JSON results with per-case reasons (beside --out); "
                   "also what a re-run resumes from")
    p.add_argument("--secret-file", help="file holding the course secret (else the "
                   "environment variable KIT_COURSE_SECRET)")
    p.add_argument("--practice", action="store_true", help="grade without a course secret: "
                   "the hidden cases are public, and every row says so")
    p.add_argument("--jobs", type=int, default=1, help="submissions graded at once (1)")
    p.add_argument("--timeout", type=float, default=grade.DEFAULT_TIMEOUT,
                   help="seconds a submission may run (120)")
    p.add_argument("--memory", type=int, default=grade.DEFAULT_MEMORY_MB,
                   help="memory limit per submission in MB (2048)")
    p.add_argument("--dask", metavar="ADDRESS",
                   help="send the submissions to this Dask scheduler instead of --jobs")
    p.add_argument("--retry", nargs="+", metavar="STATUS", choices=STATUSES,
                   help="also grade again the finished rows of these statuses (a re-run "
                        "always retries 'grader error' rows; e.g. --retry crashed timeout)")
    p.add_argument("--allow-no-isolation", action="store_true",
                   help="grade even when only the rlimits layer works (a trusted class only)")
    p.add_argument("--progress", action=argparse.BooleanOptionalAction, default=None,
                   help="progress bar (default: when standard error is a terminal)")
    p.set_defaults(func=_grade)


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

    _add_grade(sub)

    p = sub.add_parser("feedback", help="one Markdown feedback file per student")
    p.add_argument("results", help="the JSON results `grader grade` wrote")
    p.add_argument("--out", default="feedback", help="folder for the files (feedback)")
    p.set_defaults(func=_feedback)

    p = sub.add_parser("bundle", help="the student hand-out: labs, the kit, Makefile, README; "
                       "no solutions, no .git, no secret")
    p.add_argument("out", help="folder to write (must not exist, or be empty)")
    p.add_argument("--root", default=".", help="the kit's checkout (.)")
    p.set_defaults(func=_bundle)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except (ValueError, FileNotFoundError, SandboxUnavailable) as exc:
        print(f"grader: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

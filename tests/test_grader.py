"""The grader: release, check cells, the codec, comparisons, and grading whole notebooks."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import nbformat
import numpy as np
import pytest

from grader import checker, release, serialize
from grader.compare import compare
from grader.grade import grade_notebook, grade_submissions
from grader.gradebook import write_gradebook, write_results
from grader.results import exact_points
from grader.spec import Case, Exercise, LabSpec, course_seed, lab_names, load_lab
from grader.submissions import find_submissions, student_id
from kit import msgs

ROOT = Path(__file__).resolve().parents[1]
SOLUTIONS, LABS = ROOT / "solutions", ROOT / "labs"


# ------------------------------------------------------------------ release

def test_labs_are_what_release_produces():
    assert release.check_release(SOLUTIONS, LABS) == []


def test_release_keeps_indentation_and_matches_nbgrader_wording():
    src = "def f(x):\n    '''doc'''\n    ### BEGIN SOLUTION\n    return x\n    ### END SOLUTION\n"
    assert release.strip_solutions(src) == (
        "def f(x):\n    '''doc'''\n    # YOUR CODE HERE\n    raise NotImplementedError()\n")


@pytest.mark.dataset
def test_release_equals_nbgrader_generate_assignment(shared_data):
    """nbgrader's own source → release pair: our stripping gives its released code cells."""
    base = shared_data / "nbgrader-samples" / "nbgrader-docs-ps1"
    source = nbformat.read(base / "source" / "problem1.ipynb", as_version=4)
    released = nbformat.read(base / "release" / "problem1.ipynb", as_version=4)
    ours = [release.strip_solutions(c.source) for c in source.cells
            if c.cell_type == "code" and "BEGIN SOLUTION" in c.source]
    theirs = [c.source for c in released.cells
              if c.cell_type == "code" and "raise NotImplementedError()" in c.source
              and c.source.startswith("def ")]
    assert ours and ours == theirs


@pytest.mark.parametrize("bad", [
    "### BEGIN SOLUTION\nx = 1\n",
    "x = 1\n### END SOLUTION\n",
    "### BEGIN SOLUTION\n### BEGIN SOLUTION\n### END SOLUTION\n",
])
def test_unpaired_markers_are_reported_with_their_place(bad):
    with pytest.raises(release.ReleaseError, match=r"lab\.ipynb, cell 3"):
        release.strip_solutions(bad, "lab.ipynb, cell 3")


def one_exercise_spec(lab: str, *functions: str) -> LabSpec:
    """A spec whose exercises are the given functions (one public case each)."""
    return LabSpec(lab, "a test lab", tuple(
        Exercise(id=f"{lab}.{f}", function=f, reference=lambda: 1, points=1,
                 public=(Case("one", ()),), hidden=lambda rng: []) for f in functions))


def test_release_writes_and_detects_stale_labs(tmp_path):
    sol, labs = tmp_path / "solutions", tmp_path / "labs"
    sol.mkdir()
    specs = {"lab07": one_exercise_spec("lab07", "f")}
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell("def f():\n    ### BEGIN SOLUTION\n    return 1\n"
                                          "    ### END SOLUTION")]
    nbformat.write(nb, sol / "07-x.ipynb")
    assert release.check_release(sol, labs, specs) == [f"{labs / '07-x.ipynb'} is missing: run "
                                                       f"`grader release`"]
    release.release(sol, labs, specs)
    assert release.check_release(sol, labs, specs) == []
    assert "raise NotImplementedError()" in (labs / "07-x.ipynb").read_text()
    nb.cells[0].source = nb.cells[0].source.replace("return 1", "return 2")
    nbformat.write(nb, sol / "07-x.ipynb")
    assert release.check_release(sol, labs, specs) == []  # only the hidden solution changed
    nb.cells.append(nbformat.v4.new_code_cell("x = 1"))
    nbformat.write(nb, sol / "07-x.ipynb")
    assert "out of date" in release.check_release(sol, labs, specs)[0]


# ------------------------------------------------------------------ codec and comparison

def test_codec_round_trips_the_values_exercises_return():
    value = (np.arange(6, dtype=np.float32).reshape(2, 3), 3, 2.5, float("nan"), math.inf,
             [1, "a"], {"k": np.int64(7)}, np.float64(1.5), True, None, 2**70,
             msgs.TransformStamped(msgs.Header(msgs.Time(1, 2), "odom"), "base_link"))
    back = serialize.loads(serialize.dumps(value))
    assert back[0].dtype == np.float32 and np.array_equal(back[0], value[0])
    assert back[1:3] == (3, 2.5) and math.isnan(back[3]) and back[4] == math.inf
    assert back[5:7] == ([1, "a"], {"k": 7}) and back[10] == 2**70
    assert back[11] == value[11]


@pytest.mark.parametrize("value", [np.array([object()], dtype=object), {1: 2}, object(),
                                   lambda: 1])
def test_codec_refuses_what_cannot_be_graded(value):
    with pytest.raises(serialize.EncodeError):
        serialize.encode(value)


@pytest.mark.parametrize("text", [
    '{"__ndarray__": [1, 2], "dtype": "O", "shape": [2]}',
    '{"__ndarray__": [1, 2], "dtype": "<f8", "shape": [3]}',
    '{"__msg__": "os/system", "fields": {}}',
    '{"__float__": "1e999"}',
    '{"__evil__": 1}',
    "not json",
])
def test_codec_rejects_malformed_or_hostile_input(text):
    with pytest.raises(serialize.DecodeError):
        serialize.loads(text)


@pytest.mark.parametrize(("got", "fragment"), [
    (np.degrees([0.5, 1.0]), "degrees"),
    ([0.5, 1.0 + 2 * math.pi], "multiple of 2π"),
    ([-0.5, -1.0], "wrong sign"),
    ([1.0, 0.5], "swapped"),
    (None, "forget to return"),
    ([0.5, 1.0, 0.0], "shape"),
    ([0.5, float("nan")], "NaN"),
    ("0.5", "should be a number"),
])
def test_compare_explains_classic_mistakes(got, fragment):
    assert fragment in compare(np.array([0.5, 1.0]), got)


def test_compare_accepts_lists_tuples_and_tolerance():
    assert compare(np.array([1.0, 2.0]), [1.0, 2.0 + 1e-12]) is None
    assert compare((np.float64(1.0), np.float64(2.0)), (1.0, 2.0)) is None
    assert "exact integers" in compare(np.int64(437), 436)
    assert "transposed" in compare(np.array([[1.0, 2.0], [3.0, 4.0]]), [[1.0, 3.0], [2.0, 4.0]])
    stamped = msgs.TransformStamped(msgs.Header(frame_id="odom"), "base_link")
    assert "header.frame_id" in compare(stamped, msgs.TransformStamped(msgs.Header(
        frame_id="base_link"), "base_link"))


def test_messages_never_print_a_negative_zero():
    """The sign of a zero depends on the CPU's vector code path: a message must read the same
    on every machine (a stored notebook output once said ``-0.`` here and ``0.`` there)."""
    message = compare(np.array([0.15708, -0.0]), np.array([0.0, 0.15708]))
    assert "expected [0.15708, 0.     ]" in message
    assert "-0" not in compare(np.array([-1e-12, 1.0]), np.array([2.0, 1.0]))
    assert "-0" not in compare(np.array([[-0.0, 1.0]]), np.array([[-0.0, 3.0]]))
    assert compare(-0.0, 1.0) == "the output: expected 0., got 1."
    assert "-0" not in compare(np.float64(-0.0), "x")


def test_the_largest_error_is_the_first_of_equal_ones():
    """Two errors equal up to the last bit: which one is reported must not depend on it."""
    a = np.array([0.15707963267948966, 0.0])
    for nudge in (0.0, 1e-17, -1e-17):
        got = np.array([0.0, 0.15707963267948966 + nudge])
        assert "at index (0,)" in compare(a, got)


# ------------------------------------------------------------------ check cells

def test_check_says_not_implemented_passes_and_explains(capsys):
    check = checker("lab01")

    def forward_kinematics(wheel_speeds, wheel_radius, wheel_separation):
        raise NotImplementedError

    check(forward_kinematics)
    assert "not implemented yet" in capsys.readouterr().out

    def turning_radius(linear, angular):
        return math.inf if angular == 0 else linear / angular

    check(turning_radius)
    assert "✓ lab01.turning_radius" in capsys.readouterr().out

    def igv_wheel_rpm(linear, angular):  # left first, as the IGV paper writes them
        return (4000 * linear - 1440 * angular) / 67, (4000 * linear + 1440 * angular) / 67

    check(igv_wheel_rpm)
    out = capsys.readouterr().out
    assert "✗ lab01.igv_wheel_rpm" in out and "the paper's order" in out

    def broken(linear, angular):
        return 1 / 0

    check(broken, exercise="turning_radius")
    assert "ZeroDivisionError" in capsys.readouterr().out
    check(broken)
    assert "has no exercise 'broken'" in capsys.readouterr().out


def test_check_lists_up_to_three_failing_cases_after_a_summary(capsys):
    check = checker("lab01")

    def turning_radius(linear, angular):
        return 7.0  # every case wrong

    check(turning_radius)
    lines = capsys.readouterr().out.splitlines()
    ex = load_lab("lab01").exercise("turning_radius")
    assert lines[0] == (f"✗ lab01.turning_radius: {len(ex.public)} of {len(ex.public)} public "
                        f"cases fail.")
    shown = [line for line in lines[1:] if line.startswith("  case '")]
    assert [line.split("'")[1] for line in shown] == [c.name for c in ex.public[:3]]
    assert all("expected" in line and "got 7" in line for line in shown)
    assert lines[-1] == f"  … and {len(ex.public) - 3} more"

    def igv_wheel_rpm(linear, angular):  # left first: two of three cases fail, with the hint
        return (4000 * linear - 1440 * angular) / 67, (4000 * linear + 1440 * angular) / 67

    check(igv_wheel_rpm)
    out = capsys.readouterr().out
    assert "2 of 3 public cases fail." in out and out.count("the paper's order") == 2
    assert "… and" not in out


def test_check_refuses_the_kit_reference_as_grading_does(capsys):
    """A ✓ in the notebook is never a 0 in the gradebook: calling the reference, or handing
    it to check, is ✗ with the kit's explanation at once."""
    import kit.kinematics

    check = checker("lab01")

    def turning_radius(linear, angular):
        return kit.kinematics.turning_radius(linear, angular)

    check(turning_radius)
    out = capsys.readouterr().out
    assert out.startswith("✗ lab01.turning_radius") and "PermissionError" in out
    assert "your own code" in out
    check(kit.kinematics.turning_radius)
    out = capsys.readouterr().out
    assert out.startswith("✗ lab01.turning_radius: kit.kinematics.turning_radius is the kit's "
                          "reference")
    # outside check the kit keeps working for the notebook's own cells
    assert kit.kinematics.turning_radius(1.0, 0.5) == 2.0


def test_check_shows_a_bar_over_closed_loop_episodes_and_none_under_kit_fast(capsys,
                                                                             monkeypatch):
    """The capstone's check runs a simulated episode (seconds on a slow laptop): a progress
    bar names what runs; lab 01's instant cases have none; KIT_FAST=1 (CI, the stored
    outputs) draws no bar either way."""
    def make_controller(robot):
        raise NotImplementedError

    def turning_radius(linear, angular):
        return math.inf if angular == 0 else linear / angular

    monkeypatch.delenv("KIT_FAST", raising=False)
    checker("lab11")(make_controller)
    out, err = capsys.readouterr()
    assert "not implemented yet" in out and "checking make_controller" in err
    checker("lab01")(turning_radius)
    out, err = capsys.readouterr()
    assert "✓ lab01.turning_radius" in out and err == ""
    monkeypatch.setenv("KIT_FAST", "1")
    checker("lab11")(make_controller)
    out, err = capsys.readouterr()
    assert "not implemented yet" in out and err == ""


def test_check_is_silent_while_grading(capsys, monkeypatch):
    monkeypatch.setenv("KIT_GRADING", "1")
    checker("lab02")(lambda: 1)
    assert capsys.readouterr().out == ""


def test_hidden_cases_depend_on_secret_and_student():
    ex = load_lab("lab01").exercise("forward_kinematics")
    a = ex.hidden_cases(course_seed(ex.id, "alice", "s1"))
    b = ex.hidden_cases(course_seed(ex.id, "bob", "s1"))
    c = ex.hidden_cases(course_seed(ex.id, "alice", "s2"))
    again = ex.hidden_cases(course_seed(ex.id, "alice", "s1"))
    assert np.array_equal(a[0].args[0], again[0].args[0])
    assert not np.array_equal(a[0].args[0], b[0].args[0])
    assert not np.array_equal(a[0].args[0], c[0].args[0])


def test_every_exercise_reference_passes_its_own_cases_and_no_diagnostic_equals_it():
    """A diagnostic that gave the right answer would call correct work a mistake."""
    from grader.compare import matches

    for lab in lab_names():
        for ex in load_lab(lab).exercises:
            for case in (*ex.public, *ex.hidden_cases(1)):
                expected = ex.reference(*case.args, **case.kwargs)
                for diag in ex.diagnostics:
                    try:
                        wrong = diag.wrong(*case.args, **case.kwargs)
                    except Exception:
                        continue
                    public = any(case is c for c in ex.public)
                    assert not (public and matches(expected, wrong, ex.rtol, ex.atol) and
                                all(matches(ex.reference(*c.args, **c.kwargs),
                                            diag.wrong(*c.args, **c.kwargs), ex.rtol, ex.atol)
                                    for c in ex.public)), (ex.id, diag.name)


# ------------------------------------------------------------------ grading notebooks

def notebook_with(path: Path, *sources: str) -> Path:
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(s) for s in sources]
    nbformat.write(nb, path)
    return path


def lab_notebook(folder: Path, lab: str) -> Path:
    (path,) = folder.glob(f"{lab[-2:]}-*.ipynb")
    return path


@pytest.fixture(scope="module")
def graded_labs(tmp_path_factory, solved, once_for_all_workers):
    """Every lab graded as a class hands it in, one grading server per lab: the release with
    the solution's exercise cells, the untouched release and the seeded bugs of ``BUGS``
    together. Once in a run, whichever worker asks first: ``{lab: (solution, untouched,
    [(result, notebook, function, hint), ...])}``."""
    def grade():
        tmp = tmp_path_factory.mktemp("graded-labs")
        bugs: dict[str, list[tuple[Path, str, str]]] = {}
        for i, (lab, _name, function, old, new, hint) in enumerate(BUGS):
            bugs.setdefault(lab, []).append((solved(lab, tmp / f"bug{i}.ipynb", old, new),
                                             function, hint))
        assert set(bugs) <= set(lab_names())
        out = {}
        for lab in lab_names():
            seeded = bugs.get(lab, [])
            graded = grade_submissions([solved(lab, tmp / f"{lab}.ipynb"),
                                        lab_notebook(LABS, lab), *[p for p, _, _ in seeded]],
                                       load_lab(lab), jobs=2)
            out[lab] = (graded[0], graded[1],
                        [(result, path.name, function, hint) for result, (path, function, hint)
                         in zip(graded[2:], seeded, strict=True)])
        return out

    return once_for_all_workers("graded-labs", grade)


def test_solutions_score_full_and_untouched_labs_score_zero(tmp_path, graded_labs):
    """Every lab with a spec: the release with the solution's exercise cells in it (what an
    honest student hands in) earns every point with no cell error, warning or accusation
    anywhere in its results; the untouched release earns nothing."""
    results = {}
    for lab in lab_names():
        spec = load_lab(lab)
        solution, untouched, _ = graded_labs[lab]
        results[lab] = [solution, untouched]
        assert solution.status == "ok" and solution.total == spec.max_points, solution.reason
        assert solution.cell_errors == [], solution.cell_errors
        assert all(e.status == "passed" and e.reason == f"all {len(e.cases)} cases pass"
                   for e in solution.exercises.values()), {
            k: e.reason for k, e in solution.exercises.items() if e.status != "passed"}
        assert all(c.passed and c.message == "" for e in solution.exercises.values()
                   for c in e.cases), [(e.id, c.case, c.message) for e in
                                       solution.exercises.values() for c in e.cases if c.message]
        assert untouched.status == "ok" and untouched.total == 0
        assert {e.status for e in untouched.exercises.values()} == {"not implemented"}
        assert all(e.reason == "not implemented yet" for e in untouched.exercises.values())
    spec = load_lab("lab01")
    write_gradebook(tmp_path / "gb.csv", results["lab01"], spec)
    with open(tmp_path / "gb.csv", newline="") as fh:
        header, row = list(csv.reader(fh))[:2]
    assert header == ["student", *[ex.id for ex in spec.exercises], "total", "max", "percent",
                      "status", "reason"]
    expected = [exact_points(ex.points) for ex in spec.exercises]
    assert row[1:-1] == [*expected, f"{spec.max_points:g}", f"{spec.max_points:g}", "100.0",
                         "ok"]
    assert "practice grading" in row[-1]  # graded without a course secret
    write_results(tmp_path / "gb.json", results["lab01"], spec)
    data = json.loads((tmp_path / "gb.json").read_text())
    cases = data["submissions"][0]["exercises"]["lab01.forward_kinematics"]["cases"]
    assert len(cases) > len(spec.exercise("forward_kinematics").public)
    assert all(c["passed"] for c in cases)


BUGS = [
    # (lab, notebook, exercise losing its points, old text, new text, words of the hint)
    ("lab03", "03-drivers.ipynb", "velocity_frame", 'to_bytes(2, "big")',
     'to_bytes(2, "little")', "high byte first"),
    ("lab03", "03-drivers.ipynb", "velocity_frame",
     "units = round(rpm * 400 / 60 * 2**17 / 20000)", "units = round(rpm * 43.7)",
     "43.7 is rounded"),
    ("lab03", "03-drivers.ipynb", "parse_compass",
     "yaw = float(wrap_angle(math.pi / 2 - math.radians(heading)))",
     "yaw = float(wrap_angle(math.radians(heading)))", "yaw = π/2 − heading"),
    ("lab03", "03-drivers.ipynb", "decode_nodes", "            i += 1\n",
     "            i += 5\n", "move on by ONE byte"),
    ("lab03", "03-drivers.ipynb", "axis_state_name", "    if version >= (0, 5, 2):",
     "    if False:", "erratum 9"),
    ("lab03", "03-drivers.ipynb", "uiabot_motor_speeds", "* np.array([1.0, -1.0])",
     "* np.array([1.0, 1.0])", "mounted mirrored"),
    ("lab01", "01-kinematics.ipynb", "forward_kinematics",
     "return np.asarray(wheel_speeds, dtype=float) @ J.T",
     "return np.asarray(wheel_speeds, dtype=float)[..., ::-1] @ J.T", "swapped wheels"),
    ("lab01", "01-kinematics.ipynb", "forward_kinematics",
     "return np.asarray(wheel_speeds, dtype=float) @ J.T",
     "return np.asarray(wheel_speeds, dtype=float) @ J.T * np.array([1, 1, -1])", "erratum 5"),
    ("lab01", "01-kinematics.ipynb", "odometry_twist",
     "return np.stack([v, omega], axis=-1)", "return np.stack([omega, v], axis=-1)",
     "erratum 1"),
    ("lab01", "01-kinematics.ipynb", "twist_to_motor_speeds",
     "wheels = inverse_kinematics([linear, 0.0, angular], wheel_radius, wheel_separation)",
     "b = wheel_separation / 2\n    r = wheel_radius\n"
     "    wheels = np.array([r / 2 * linear + r / (2 * b) * angular, "
     "r / 2 * linear - r / (2 * b) * angular])", "erratum 6"),
    ("lab01", "01-kinematics.ipynb", "saturate_wheel_speeds",
     "return phi * (max_wheel_speed / peak)",
     "return np.clip(phi, -max_wheel_speed, max_wheel_speed)", "clipping"),
    ("lab02", "02-odometry.ipynb", "eddie_odometry_step",
     "theta = float(wrap_angle(theta + (d_right - d_left) / wheel_separation))",
     "theta = float(wrap_angle(theta + (d_left - d_right) / wheel_separation))", "erratum 7"),
    ("lab02", "02-odometry.ipynb", "eddie_odometry_step",
     "theta = float(wrap_angle(theta + (d_right - d_left) / wheel_separation))",
     "theta = theta + math.degrees((d_right - d_left) / wheel_separation)", ""),
    ("lab02", "02-odometry.ipynb", "eddie_odometry_step",
     "theta = float(wrap_angle(theta + (d_right - d_left) / wheel_separation))",
     "theta = theta + (d_right - d_left) / wheel_separation", "unwrapped"),
    ("lab02", "02-odometry.ipynb", "integrate_path",
     "poses.append(exact_arc_step(poses[-1], dr, dl, wheel_separation))",
     "poses.append(exact_arc_step(np.zeros(3), dr, dl, wheel_separation))", "erratum 2"),
    ("lab02", "02-odometry.ipynb", "conversion_factor",
     "return math.pi * wheel_diameter / (gear_ratio * encoder_resolution)",
     "return wheel_diameter / (gear_ratio * encoder_resolution)", "needs pi"),
    ("lab02", "02-odometry.ipynb", "tick_delta",
     "return d - modulus if d >= modulus // 2 else d", "return current - previous",
     "wraps modulo"),
    ("lab04", "04-motor-control.ipynb", "pi_step",
     "    if output != raw and (raw - output) * error > 0:",
     "    if False:", "no anti-windup"),
    ("lab04", "04-motor-control.ipynb", "transfer_coefficients",
     "return (np.array([k_t / gear_ratio]),", "return (np.array([k_t]),", "gearbox"),
    ("lab04", "04-motor-control.ipynb", "pole_placement",
     "kp = (2 * damping * natural_frequency * time_constant - 1) / gain",
     "kp = (2 * damping * natural_frequency * time_constant) / gain", "own damping"),
    ("lab05", "05-fusion.ipynb", "kf_predict",
     "return F @ np.asarray(x, dtype=float), F @ np.asarray(P, dtype=float) @ F.T + Q",
     "return F @ np.asarray(x, dtype=float), F.T @ np.asarray(P, dtype=float) @ F + Q",
     "transposed"),
    ("lab05", "05-fusion.ipynb", "angle_residual",
     "return float(wrap_angle(z - z_hat))", "return float(z - z_hat)", "unwrapped"),
    ("lab05", "05-fusion.ipynb", "planar_jacobian",
     "    return np.array([[1, 0, -s * sn, dt * c, 0, 0.5 * dt * dt * c],",
     "    return np.array([[1, 0, s * sn, dt * c, 0, 0.5 * dt * dt * c],", ""),
    ("lab06", "06-perception.ipynb", "valid_returns",
     "        return np.isfinite(r) & (r >= range_min) & (r <= range_max)\n",
     "        return np.isfinite(r)\n", "not a measurement"),
    ("lab06", "06-perception.ipynb", "scan_to_points",
     "    c, s = math.cos(theta), math.sin(theta)\n    return np.column_stack([x + c * px",
     "    c, s = 1.0, 0.0\n    return np.column_stack([x + c * px", "mounted turned"),
    ("lab06", "06-perception.ipynb", "deskew_beam",
     "    point = geometry.transform_points(laser_at_beam,",
     "    point = geometry.transform_points(laser_at_reference,", "its own time"),
    ("lab06", "06-perception.ipynb", "depth_to_range",
     "    return np.hypot((np.asarray(u, dtype=float) - cx) * z / fx, z)\n",
     "    return z + 0 * np.asarray(u, dtype=float)\n", "distance along its optical axis"),
    ("lab07", "07-localization.ipynb", "sense", "    return posterior / posterior.sum()\n",
     "    return posterior\n", "divide by the sum after multiplying"),
    ("lab07", "07-localization.ipynb", "move",
     "    return (p_exact * np.roll(b, shift) + p_under * np.roll(b, shift - 1) +\n"
     "            p_over * np.roll(b, shift + 1))\n", "    return np.roll(b, shift)\n",
     "spread the belief"),
    ("lab07", "07-localization.ipynb", "odometry_control",
     "    return np.array([rot1, trans, rot2])\n",
     "    return np.array([math.degrees(rot1), trans, math.degrees(rot2)])\n", "in radians"),
    ("lab07", "07-localization.ipynb", "log_likelihoods",
     "    return np.sum(np.log(pz), axis=1)\n", "    return np.log(np.prod(pz, axis=1))\n",
     "sum the logs"),
    ("lab07", "07-localization.ipynb", "normalize_log_weights",
     "    w = np.exp(lw - lw.max())\n", "    w = np.exp(lw)\n", "subtract the largest"),
    ("lab07", "07-localization.ipynb", "should_resample",
     "    return bool(1.0 / np.sum(w ** 2) < threshold * len(w))\n", "    return True\n",
     "every step throws particles away"),
    ("lab07", "07-localization.ipynb", "low_variance_resample",
     'np.arange(n) / n, side="right")', 'np.arange(n) / n, side="left")',
     "belongs to the next particle"),
    ("lab08", "08-slam.ipynb", "update_log_odds",
     "return np.clip(np.asarray(l, dtype=float) + np.asarray(change, dtype=float), l_min, l_max)",
     "return np.asarray(l, dtype=float) + np.asarray(change, dtype=float)", "clamp to"),
    ("lab08", "08-slam.ipynb", "beam_endpoints", "    c, s = math.cos(theta), math.sin(theta)\n",
     "    c, s = 1.0, 0.0\n", "rotate the points by the laser's heading"),
    ("lab08", "08-slam.ipynb", "gauss_newton_step", "    for i, j, z, omega in edges:\n",
     "    for i, j, z, omega in [(i, j, z, np.linalg.inv(om)) for i, j, z, om in edges]:\n",
     "the inverse covariance"),
    ("lab09", "09-planning.ipynb", "inflate", "inflation_cost(cells[near] * resolution,",
     "inflation_cost(cells[near],", "multiply a distance in cells by the resolution"),
    ("lab09", "09-planning.ipynb", "octile_distance",
     "return float(max(dr, dc) - min(dr, dc) + math.sqrt(2) * min(dr, dc))",
     "return float(max(dr, dc))", "√2 long"),
    ("lab09", "09-planning.ipynb", "astar",
     "                if dr and dc and not (free[r + dr, c] and free[r, c + dc]):\n"
     "                    continue\n", "", "both cells beside it are free"),
    ("lab10", "10-navigation.ipynb", "pure_pursuit_curvature",
     "    x = math.cos(th) * dx + math.sin(th) * dy       # the carrot in the robot's frame\n"
     "    y = -math.sin(th) * dx + math.cos(th) * dy\n",
     "    x, y = dx, dy\n", "into the robot's frame"),
    ("lab10", "10-navigation.ipynb", "regulated_speed",
     "        v = desired * min(1.0, (1.0 / abs(curvature)) / min_radius)",
     "        v = desired * min(1.0, min_radius / (1.0 / abs(curvature)))", "scales DOWN"),
    ("lab10", "10-navigation.ipynb", "dynamic_window",
     "    lo_v, hi_v = max(0.0, v - acc_v * sim_time), min(max_v, v + acc_v * sim_time)\n"
     "    lo_w, hi_w = max(-max_w, w - acc_w * sim_time), min(max_w, w + acc_w * sim_time)\n",
     "    lo_v, hi_v = v - acc_v * sim_time, v + acc_v * sim_time\n"
     "    lo_w, hi_w = w - acc_w * sim_time, w + acc_w * sim_time\n", "clip the window"),
    ("lab10", "10-navigation.ipynb", "rollout", "    dt = sim_time / steps",
     "    dt = sim_time", "sim_time / steps"),
    ("lab11", "11-capstone.ipynb", "make_controller",
     "        if np.any(nav.collides_from(costmap, pose, ahead, outline)):\n"
     "            raise nav.ControlError(\"collision ahead\")\n", "", "touched a person"),
    ("lab10", "10-navigation.ipynb", "goal_reached",
     "    e = float(geometry.wrap_angle(goal[2] - pose[2]))", "    e = goal[2] - pose[2]",
     "wrap the difference"),
]


def test_seeded_bugs_lose_exactly_their_exercise(graded_labs):
    assert sum(len(bugs) for _, _, bugs in graded_labs.values()) == len(BUGS)
    for lab, (_, _, bugs) in graded_labs.items():
        spec = load_lab(lab)
        for result, name, function, hint in bugs:
            lost = {k: v for k, v in result.exercises.items() if v.points < v.max_points}
            assert list(lost) == [f"{lab}.{function}"], (name, {k: v.reason for k, v in
                                                                 lost.items()})
            assert result.cell_errors == [], (name, result.cell_errors)
            ex = lost[f"{lab}.{function}"]
            failed = sum(not c.passed for c in ex.cases)
            assert failed > 0
            # partial credit: the points of the failed cases, and only those, are lost
            expected_loss = spec.exercise(function).points * failed / len(ex.cases)
            assert result.total == pytest.approx(spec.max_points - expected_loss, rel=1e-12)
            assert hint in ex.reason, ex.reason


def test_partial_credit_counts_cases():
    """turning_radius without the straight-line case fails exactly the two ω = 0 cases."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        path = notebook_with(Path(tmp) / "pat.ipynb",
                             "def turning_radius(linear, angular):\n    return linear / angular")
        result = grade_notebook(path, load_lab("lab01"))
    ex = result.exercises["lab01.turning_radius"]
    assert [c.case for c in ex.cases if not c.passed] == ["straight", "hidden case 4"]
    assert ex.points == 2 * 6 / 8 and ex.status == "error"
    assert "ZeroDivisionError" in ex.reason
    hidden = next(c for c in ex.cases if c.case == "hidden case 4")
    assert hidden.message == "raised"  # a verdict: not even which exception


def test_malformed_and_non_utf8_notebooks_get_a_row(tmp_path):
    (tmp_path / "broken.ipynb").write_text('{"cells": [', encoding="utf-8")
    (tmp_path / "latin.ipynb").write_bytes(b'{"cells": "\xe9\xff"}')
    notebook_with(tmp_path / "empty.ipynb", "x = 1")
    spec = load_lab("lab02")
    results = {r.student: r for r in grade_submissions([s.path for s in find_submissions(
        [tmp_path], "lab02").submissions],
                                                       spec, jobs=2)}
    assert results["broken"].status == "malformed notebook"
    assert results["latin"].status == "malformed notebook"
    assert "UTF-8" in results["latin"].reason
    assert results["empty"].status == "ok"
    assert {e.status for e in results["empty"].exercises.values()} == {"missing function"}


def test_student_ids_come_from_file_or_folder_names():
    assert student_id(Path("class/alice.ipynb"), "lab01") == "alice"
    assert student_id(Path("class/bob/01-kinematics.ipynb"), "lab01") == "bob"


def test_lists_get_a_specific_message_and_metadata_never_names_the_student(tmp_path):
    """The file's name names the student; a notebook's metadata is only compared with it."""
    assert "a list was returned" in compare(np.array([1.0, 2.0]), [1.0, 3.0])
    path = notebook_with(tmp_path / "x.ipynb", "def turning_radius(v, w):\n    return 0.0")
    nb = nbformat.read(path, as_version=4)
    nb.metadata["kit"] = {"student": "grace"}
    nbformat.write(nb, path)
    result = grade_notebook(path, load_lab("lab01"))
    assert result.student == "x" and "metadata names another student ('grace')" in result.reason



def test_a_crc_bug_also_costs_the_frames_built_with_it(tmp_path, solved):
    """Lab 03's frame exercise calls the student's own CRC: one bug, two exercises, and
    the CRC's hint names the mistake."""
    spec = load_lab("lab03")
    path = solved("lab03", tmp_path / "crc.ipynb", "crc = 0\n    for byte",
                  "crc = 0xFFFF\n    for byte")
    result = grade_notebook(path, spec)
    lost = {k for k, v in result.exercises.items() if v.points < v.max_points}
    assert lost == {"lab03.crc16_xmodem", "lab03.velocity_frame"}
    assert "starts from 0x0000" in result.exercises["lab03.crc16_xmodem"].reason


def test_a_transposed_jacobian_also_costs_the_gauss_newton_step_built_with_it(tmp_path,
                                                                             solved):
    """Lab 08's Gauss–Newton step calls the student's own Jacobians: one bug, two exercises,
    and the Jacobians' hint names the mistake."""
    spec = load_lab("lab08")
    path = solved("lab08", tmp_path / "jacobian.ipynb", "    return A, B\n    ### END SOLUTION",
                  "    return A.T, B.T\n    ### END SOLUTION")
    result = grade_notebook(path, spec)
    lost = {k for k, v in result.exercises.items() if v.points < v.max_points}
    assert lost == {"lab08.edge_jacobians", "lab08.gauss_newton_step"}
    assert "rows are the error's components" in result.exercises["lab08.edge_jacobians"].reason


def test_an_inflation_cost_bug_also_costs_the_inflation_built_with_it(tmp_path, solved):
    """Lab 09's inflation calls the student's own cost function: the obstacle cell left at
    253 costs both exercises, and the cost function's hint names the mistake."""
    spec = load_lab("lab09")
    path = solved("lab09", tmp_path / "cost.ipynb", "    cost = np.where(d == 0, 254.0, cost)\n",
                  "")
    result = grade_notebook(path, spec)
    lost = {k for k, v in result.exercises.items() if v.points < v.max_points}
    assert lost == {"lab09.inflation_cost", "lab09.inflate"}
    assert "LETHAL_OBSTACLE = 254" in result.exercises["lab09.inflation_cost"].reason


CLOSED_LOOP = {
    # a stack that crashes, one that never returns, one that drives blind: each episode says
    # why it failed, in words for the public one and as a kind alone for the hidden ones
    "crash": ("    return Follower(robot)\n",
              "    raise RuntimeError('my stack is not wired up')\n",
              "make_controller raised RuntimeError: my stack is not wired up", "raised"),
    "hang": ("        pose = np.asarray(pose, dtype=float)\n",
             "        while True:\n            pass\n", "did not answer in time", "timed out"),
    "blind": ("        if np.any(nav.collides_from(costmap, pose, ahead, outline)):\n"
              "            raise nav.ControlError(\"collision ahead\")\n", "",
              "touched a person", "touched a person"),
    "no_return": ("        return v, w\n    ### END SOLUTION", "        v, w\n    ### END SOLUTION",
                  "returned None: a missing return?", "raised"),
}


@pytest.mark.slow
def test_closed_loop_grading_says_why_each_episode_failed(tmp_path, solved):
    """Lab 11 runs each submission's controller in seeded episodes, asking it across the
    sandbox step by step: a stack that raises, one that loops forever, one that drives into
    the bystander and one that forgets to return get a row with the reason and 0 points; the
    grader goes on; the same seed grades the same."""
    spec = load_lab("lab11")
    paths = [solved("lab11", tmp_path / f"{name}.ipynb", old, new)
             for name, (old, new, *_) in CLOSED_LOOP.items()]
    honest = solved("lab11", tmp_path / "honest.ipynb")
    graded = grade_submissions([*paths, honest], spec, jobs=2, timeout=60)
    for result, (name, (_, _, public, hidden)) in zip(graded, CLOSED_LOOP.items(),
                                                      strict=False):
        ex = result.exercises["lab11.make_controller"]
        assert ex.points == 0.0, (name, ex.reason)
        first = ex.cases[0]
        assert first.public and public in first.message, (name, first.message)
        assert {c.message for c in ex.cases if not c.public} == {hidden}, (name, ex.cases)
        assert result.cell_errors == [], (name, result.cell_errors)
    assert graded[-1].total == spec.max_points, graded[-1].exercises
    assert graded[-1].cell_errors == [] and graded[-1].status == "ok"
    again = grade_submissions([paths[2]], spec, jobs=1, timeout=60)[0]
    assert again.exercises["lab11.make_controller"].cases == \
        graded[2].exercises["lab11.make_controller"].cases, (
            again.status, again.reason, again.exercises["lab11.make_controller"].reason)

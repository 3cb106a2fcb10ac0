"""Hostile submissions, graded together with an honest one in one class run, under each layer
that claims to isolate (bubblewrap and unshare, forced with KIT_SANDBOX): every one gets the
grade its own code earns and a defined reason; none can forge an answer or a verdict, reach a
reference, read or write what is not its own, leak a hidden case, leave a file behind, make
the grader read what the instructor did not put there, take another student's row, or stop
the others being graded."""

from __future__ import annotations

import json
import math
import os
import signal
import stat
import sys
from pathlib import Path

import nbformat
import pytest

from grader.feedback import file_names, write_feedback
from grader.gradebook import grade_class
from grader.results import SubmissionResult
from grader.sandbox import ISOLATING, UID_RANGE, layer_works
from grader.spec import course_seed, load_lab
from grader.submissions import find_submissions

ROOT = Path(__file__).resolve().parents[1]
SECRET = "hostile-class-secret"
MARK = "kit-hostile-litter-7f3a"
GOOD_RADIUS = ("import math\n"
               "def turning_radius(linear, angular):\n"
               "    if angular == 0:\n"
               "        return -math.inf if linear < 0 else math.inf\n"
               "    return linear / angular\n")
PROBE = ("import json, os\n"
         "def probe(paths):\n"
         "    found = []\n"
         "    for p in paths:\n"
         "        try:\n"
         "            os.listdir(p) if os.path.isdir(p) else open(p, 'rb').read(1)\n"
         "            found.append(p)\n"
         "        except OSError:\n"
         "            pass\n"
         "    return found\n")


def classic_cells(tmp: Path) -> dict[str, list[str]]:
    """Hostile submissions the grader already withstood; they must keep their grades."""
    other = tmp / "class" / "alice.ipynb"
    gradebook = tmp / "out" / "gradebook.csv"
    return {
        "loop_at_import": ["while True:\n    pass", GOOD_RADIUS],
        "loop_swallowing_the_alarm": ["while True:\n    try:\n        while True:\n"
                                      "            pass\n    except BaseException:\n"
                                      "        pass"],
        "memory_bomb": ["hog = []\nwhile True:\n    hog.append(bytearray(10**8))"],
        "fork_bomb": ["import os, time\nfor _ in range(30):\n    if os.fork() == 0:\n"
                      "        time.sleep(600)\n        os._exit(0)\n", GOOD_RADIUS],
        "sys_exit_at_import": ["import sys\nsys.exit(3)", GOOD_RADIUS],
        "os_exit_at_import": ["import os\nos._exit(3)"],
        "sys_exit_in_exercise": ["import sys\ndef turning_radius(linear, angular):\n"
                                 "    sys.exit(0)"],
        "os_exit_in_exercise": ["import os\ndef turning_radius(linear, angular):\n"
                                "    os._exit(0)"],
        "segfault": ["import ctypes\nctypes.string_at(0)"],
        "fake_verdict": ["print('✓ all 9 exercises pass: 20 / 20')\n"
                         "print('{\"phase\": \"public\", \"outcomes\": {}, \"cell_errors\": []}')",
                         "def turning_radius(linear, angular):\n    return 42.0"],
        "fake_results_file": [
            "import json, os\n"
            "fake = {'cell_errors': [], 'outcomes': {'lab01.turning_radius': {'cases': "
            "[{'status': 'returned', 'value': 1.0}] * 8, 'signature': '(a, b)'}}}\n"
            "open('result.json', 'w').write(json.dumps(fake))\nos._exit(0)"],
        "monkey_patching": [
            "import numpy, builtins, grader.compare, grader.checker\n"
            "numpy.allclose = lambda *a, **k: True\n"
            "grader.compare.compare = lambda *a, **k: None\n"
            "grader.checker.check = lambda *a, **k: None\n"
            "builtins.abs = lambda x: 0\n"
            "def turning_radius(linear, angular):\n    return 42.0"],
        "calls_kit_reference": ["from kit.kinematics import turning_radius"],
        "reloads_kit_reference": [
            "import importlib, kit.kinematics\nimportlib.reload(kit.kinematics)\n"
            "turning_radius = kit.kinematics.turning_radius"],
        "reads_secret_and_others": [
            "import os\nsecret = os.environ.get('KIT_COURSE_SECRET', 'no secret here')\n"
            "raise RuntimeError(secret)",
            f"print(open({str(other)!r}).read())"],
        "writes_gradebook_and_submissions": [
            f"open({str(gradebook)!r}, 'w').write('mallory,20')",
            f"open({str(other)!r}, 'w').write('overwritten')", GOOD_RADIUS],
        "gigabyte_of_output": ["import sys\nchunk = 'x' * 2**20\nfor _ in range(1024):\n"
                               "    sys.stderr.write(chunk)\n    print(chunk)", GOOD_RADIUS],
        "wrong_signature": ["def turning_radius(linear):\n    return linear"],
        "missing_functions": ["x = 1"],
    }


def new_cells(tmp: Path) -> dict[str, list[str]]:
    """The holes issue 10 found, one submission each."""
    home_entries = [str(Path.home() / name) for name in sorted(os.listdir(Path.home()))]
    readable = [str(ROOT / "solutions" / "01-kinematics.ipynb"), str(ROOT / "solutions"),
                str(tmp / "class" / "alice.ipynb"), str(tmp / "class"), str(tmp / "out"),
                str(ROOT / ".git"), str(ROOT / "README.md"), str(ROOT / "tests"), str(ROOT),
                str(Path.home()), *home_entries, "/etc/shadow", "/root"]
    leak_line = "\n" * 3  # padding; the leaky exercise also varies its line by the input
    return {
        "deletes_everything": [
            "import os, shutil\nfor p in ('..', '.', '/tmp', os.path.expanduser('~')):\n"
            "    shutil.rmtree(p, ignore_errors=True)\n"
            "for p in os.listdir('.'):\n    try:\n        os.remove(p)\n"
            "    except OSError:\n        pass", GOOD_RADIUS],
        "tidies_up": ["import os\nopen('scratch.txt', 'w').write('x')\nos.remove('scratch.txt')",
                      GOOD_RADIUS],
        "reads_absolute_paths": [
            PROBE, f"found = probe({readable!r})\n"
                   f"listed = {{p: sorted(os.listdir(p)) for p in {[str(ROOT), str(Path.home())]!r}"
                   f" if os.path.isdir(p)}}", GOOD_RADIUS,
            "raise RuntimeError('FOUND ' + json.dumps([found, listed]))"],
        "leaks_hidden_inputs": [
            "import sys, os\n"
            "def turning_radius(linear, angular):\n"
            f"{leak_line}"
            "    text = f'INPUTS linear={linear!r} angular={angular!r}'\n"
            "    print(text)\n    print(text, file=sys.stderr)\n"
            "    for d in ('.', '/tmp', '/dev/shm', os.environ.get('TMPDIR', '.')):\n"
            f"        open(os.path.join(d, '{MARK}-' + text.replace(' ', '_')), 'w').write(text)\n"
            "    kind = type('Leak_' + repr(linear).replace('.', '_').replace('-', 'm'), "
            "(ValueError,), {})\n"
            "    code = '\\n' * int(abs(linear) * 1000) + 'raise kind(text)'\n"
            "    exec(compile(code, 'leak', 'exec'), {'kind': kind, 'text': text})\n"],
        "leaks_through_a_crash": [
            "import os, signal, sys\n"
            "def turning_radius(linear, angular):\n"
            "    if (linear, angular) not in {(1.0, 0.5), (1.0, -0.5), (0.5, 0.0), (0.0, 1.0)}:\n"
            "        sys.stderr.write(f'INPUTS linear={linear!r} angular={angular!r}\\n')\n"
            "        sys.stderr.flush()\n"
            "        os.kill(os.getpid(), signal.SIGSEGV)\n"
            "    return float('inf') if angular == 0 else linear / angular\n"],
        "leaks_through_an_exit_code": [
            "import os\n"
            "def turning_radius(linear, angular):\n"
            "    if (linear, angular) not in {(1.0, 0.5), (1.0, -0.5), (0.5, 0.0), (0.0, 1.0)}:\n"
            "        os._exit(int(abs(linear) * 1000) % 256)\n"
            "    return float('inf') if angular == 0 else linear / angular\n"],
        "leaks_through_the_answer_channel": [
            "import os, struct\n"
            "def turning_radius(linear, angular):\n"
            "    if (linear, angular) not in {(1.0, 0.5), (1.0, -0.5), (0.5, 0.0), (0.0, 1.0)}:\n"
            "        pad = ' ' * int(abs(linear) * 1000)\n"
            "        text = ('{\"status\": \"error\", \"message\": \"' + repr(linear) + pad + "
            "'\"}').encode()\n"
            "        for fd in range(3, 32):\n"
            "            try:\n"
            "                os.write(fd, struct.pack('>II', len(text), 0) + text)\n"
            "            except OSError:\n"
            "                pass\n"
            "        os._exit(0)\n"
            "    return float('inf') if angular == 0 else linear / angular\n"],
        "litters_tmp": [
            "import os, tempfile\n"
            f"for d in ('/tmp', '/dev/shm', tempfile.gettempdir(), '.'):\n"
            f"    open(os.path.join(d, '{MARK}'), 'w').write('left behind')\n"
            f"    os.makedirs(os.path.join(d, '{MARK}-dir'), exist_ok=True)", GOOD_RADIUS],
        "unbounded_fork_bomb": ["import os\nwhile True:\n    os.fork()", GOOD_RADIUS],
        "loads_reference_by_path": [
            "import importlib.util, kit.kinematics as k\n"
            "spec = importlib.util.spec_from_file_location('mine', k.__file__)\n"
            "mine = importlib.util.module_from_spec(spec)\nspec.loader.exec_module(mine)\n"
            "def turning_radius(linear, angular):\n"
            "    return mine.turning_radius(linear, angular)"],
        "loads_reference_by_spec_and_name": [
            "import importlib.util, sys, kit.kinematics as k\n"
            "def turning_radius(linear, angular):\n"
            "    spec = importlib.util.spec_from_file_location('kit_kinematics_copy', k.__file__)\n"
            "    mod = importlib.util.module_from_spec(spec)\n"
            "    sys.modules['kit_kinematics_copy'] = mod\n    spec.loader.exec_module(mod)\n"
            "    return mod.turning_radius(linear, angular)"],
        "executes_reference_source": [
            "import kit.kinematics as k\nnamespace = {}\n"
            "exec(open(k.__file__).read(), namespace)\n"
            "turning_radius = namespace.get('turning_radius')"],
        "loads_compiled_reference": [
            "import glob, importlib.machinery, importlib.util, os, kit.kinematics as k\n"
            "def turning_radius(linear, angular):\n"
            "    cache = os.path.join(os.path.dirname(k.__file__), '__pycache__')\n"
            "    for pyc in glob.glob(os.path.join(cache, 'kinematics.*.pyc')):\n"
            "        loader = importlib.machinery.SourcelessFileLoader('kc', pyc)\n"
            "        spec = importlib.util.spec_from_loader('kc', loader)\n"
            "        mod = importlib.util.module_from_spec(spec)\n"
            "        loader.exec_module(mod)\n"
            "        return mod.turning_radius(linear, angular)\n"
            "    raise FileNotFoundError('no compiled copy')"],
        "reference_in_a_fresh_process": [
            "import subprocess, sys\n"
            "def turning_radius(linear, angular):\n"
            "    out = subprocess.run([sys.executable, '-c', 'import sys; from kit.kinematics "
            "import turning_radius as t; print(repr(t(float(sys.argv[1]), float(sys.argv[2]))))',"
            " repr(linear), repr(angular)], capture_output=True, text=True, check=True)\n"
            "    return float(out.stdout)"],
        "reference_from_the_spec": [
            "from grader.labs.lab01 import SPEC\n"
            "turning_radius = SPEC.exercise('turning_radius').reference"],
        "reference_inside_own_code": [
            "import kit.kinematics\n"
            "def turning_radius(linear, angular):\n"
            "    return kit.kinematics.turning_radius(linear, angular)"],
        "syntax_error": ["import math\n\ndef turning_radius(linear, angular):\n"
                         "    return linear /\n"],
    }


def write_notebook(path: Path, cells: list[str]) -> Path:
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_markdown_cell("# my lab")] + [nbformat.v4.new_code_cell(c)
                                                              for c in cells]
    nbformat.write(nb, path)
    return path


def _sandbox_owned(folder: str) -> list[str]:
    found = []
    for name in os.listdir(folder):
        try:
            uid = os.lstat(os.path.join(folder, name)).st_uid
        except OSError:
            continue
        if MARK in name or UID_RANGE[0] <= uid < UID_RANGE[1]:
            found.append(name)
    return found


def issue_cells() -> dict[str, list[str]]:
    """The attacks an instructor's security review found to forge grades (issue 25)."""
    return {
        # forged answers on every descriptor the process holds, with the kit's references
        "forges_answers": [
            "import json, os, struct\n"
            "for fd in range(0, 64):\n"
            "    for status in ('returned', 'passed'):\n"
            "        head = json.dumps({'id': None, 'status': status, 'value': 1.0,\n"
            "                           'phase': 'public', 'outcomes': {}}).encode()\n"
            "        try:\n"
            "            os.write(fd, struct.pack('>II', len(head), 0) + head)\n"
            "        except OSError:\n"
            "            pass\n"],
        # reads the question meant for the runner off its own channel and answers it
        "steals_the_question": [
            "import os, socket\n"
            "for fd in range(3, 64):\n"
            "    try:\n"
            "        s = socket.socket(fileno=os.dup(fd))\n"
            "        s.setblocking(False)\n"
            "        s.recv(1 << 20)\n"
            "    except OSError:\n"
            "        pass\n", GOOD_RADIUS],
        # the real function out of its guard: closures, the garbage collector, the module
        "digs_out_the_reference": [
            "import gc, importlib, kit.kinematics as k\n"
            "found = [o for o in gc.get_objects() if callable(o) and\n"
            "         getattr(o, '__name__', '') == 'turning_radius'\n"
            "         and o is not k.turning_radius]\n"
            "cells = k.turning_radius.__closure__ or ()\n"
            "def turning_radius(linear, angular):\n"
            "    for f in [c.cell_contents for c in cells] + found + [k.turning_radius]:\n"
            "        try:\n"
            "            return f(linear, angular)\n"
            "        except Exception:\n"
            "            pass\n"
            "    return None\n"],
        # which built-in exception it raises as a side channel for a hidden case's inputs
        "exception_side_channel": [
            "def turning_radius(linear, angular):\n"
            "    kinds = [ValueError, KeyError, IndexError, ZeroDivisionError, TypeError,\n"
            "             AttributeError, LookupError, ArithmeticError]\n"
            "    raise kinds[int(abs(linear) * 10) % 8]('x')\n"],
        # correct cells, then the memory runs out: graded as far as it ran
        "memory_after_correct_cells": [
            GOOD_RADIUS, "hog = []\nwhile True:\n    hog.append(bytearray(10**8))"],
        "blas_memory_after_correct_cells": [
            GOOD_RADIUS, "import numpy as np\na = np.ones((50000, 50000))\nb = a @ a"],
    }


def _class_folder(tmp: Path) -> Path:
    folder = tmp / "class"
    folder.mkdir()
    return folder


@pytest.fixture(scope="module", params=ISOLATING)
def graded(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory, solved,
           once_for_all_workers):
    """The hostile class graded under one layer: once per run, whichever worker asks first
    (the class takes both cores for about 20 s)."""
    layer = request.param
    if not layer_works(layer):
        pytest.skip(f"the {layer} layer cannot run here (root, {layer} and a kit other users "
                    f"can read are needed; CI has them)")
    return once_for_all_workers(f"hostile-{layer}",
                                lambda: _grade_the_class(layer, tmp_path_factory, solved))


def _grade_the_class(layer: str, tmp_path_factory: pytest.TempPathFactory, solved):
    tmp = tmp_path_factory.mktemp(f"hostile-{layer}")
    folder, out = _class_folder(tmp), tmp / "out"
    out.mkdir()
    alice = solved("lab01", folder / "alice.ipynb")
    os.chmod(alice, stat.S_IRUSR | stat.S_IWUSR)
    cells = {**classic_cells(tmp), **new_cells(tmp), **issue_cells()}
    for name, sources in cells.items():
        write_notebook(folder / f"{name}.ipynb", sources)
    write_notebook(folder / "zed.ipynb", [GOOD_RADIUS])  # graded after the fork bomb
    (folder / "not_json.ipynb").write_text('{"cells": [', encoding="utf-8")
    (folder / "latin1.ipynb").write_bytes(b'{"cells": "\xe9\xff"}')
    _what_the_instructor_did_not_put_there(tmp, folder, solved)
    import py_compile

    import kit.kinematics

    # a compiled copy of the reference beside it, as any checkout that ran Python has
    py_compile.compile(kit.kinematics.__file__, doraise=True)
    litter_before = {d: _sandbox_owned(d) for d in ("/tmp", "/dev/shm")}
    before = alice.read_bytes()
    mp = pytest.MonkeyPatch()
    mp.setenv("KIT_SANDBOX", layer)
    mp.setenv("KIT_COURSE_SECRET", "not-the-secret-given")  # the grader must not pass it on
    try:
        found = find_submissions([folder], "lab01")
        results = grade_class(found.submissions, load_lab("lab01"), out / "gradebook.csv",
                              out / "gradebook.json", jobs=2, timeout=12, memory_mb=1024,
                              secret=SECRET, layer=layer)
    finally:
        mp.undo()
    assert alice.read_bytes() == before
    write_feedback(out / "gradebook.json", out / "feedback")
    litter = {d: _sandbox_owned(d) for d in ("/tmp", "/dev/shm")}
    return {r.student: r for r in results}, tmp, layer, (litter_before, litter)


SECRET_TEXT = "the-course-secret-7f3a9c"
SHADOW_START = "root:"


def _what_the_instructor_did_not_put_there(tmp: Path, folder: Path, solved) -> None:
    """Links, a FIFO and bytes that are not text, as unzip and tar recreate them from a
    student's upload, and a notebook claiming another student's identity."""
    secret = tmp / "secret.txt"
    secret.write_text(SECRET_TEXT + "\n", encoding="utf-8")
    os.symlink(secret, folder / "links_the_secret.ipynb")
    os.symlink("/etc/shadow", folder / "links_a_host_file.ipynb")
    os.symlink(ROOT / "solutions" / "01-kinematics.ipynb", folder / "links_the_solution.ipynb")
    outside = solved("lab01", tmp / "elsewhere" / "full_marks.ipynb")
    os.link(outside, folder / "hard_links_outside.ipynb")
    os.mkfifo(folder / "a_fifo.ipynb")
    write_notebook(folder / "surrogate_in_a_cell.ipynb", ["x = 'PLACEHOLDER'"])
    path = folder / "surrogate_in_a_cell.ipynb"
    path.write_text(path.read_text(encoding="utf-8").replace("PLACEHOLDER", "\\ud800"),
                    encoding="utf-8")
    path = solved("lab01", folder / "surrogate_in_its_id.ipynb")
    nb = nbformat.read(path, as_version=4)
    nb.metadata["kit"] = {"student": "PLACEHOLDER"}
    nbformat.write(nb, path)
    path.write_text(path.read_text(encoding="utf-8").replace("PLACEHOLDER", "\\udc80"),
                    encoding="utf-8")
    (folder / os.fsdecode(b"caf\xe9.ipynb")).write_bytes(
        solved("lab01", tmp / "elsewhere" / "cafe.ipynb").read_bytes())
    nb = nbformat.read(ROOT / "labs" / "01-kinematics.ipynb", as_version=4)
    nb.metadata["kit"] = {"student": "alice"}
    nbformat.write(nb, folder / "mallory.ipynb")


def test_the_honest_student_is_unaffected_and_has_no_cell_error(graded):
    results, _, layer, _ = graded
    alice = results["alice"]
    assert alice.status == "ok" and alice.total == 20 and alice.sandbox == layer
    assert alice.cell_errors == [], alice.cell_errors


@pytest.mark.parametrize(("name", "status", "reason", "points"), [
    # the endless cell loses its own CPU time; the grader goes on with the next cells
    ("loop_at_import", "timeout", "used up its CPU time", 2),
    # one that catches the alarm is stopped by its process's CPU limit
    ("loop_swallowing_the_alarm", "timeout", "s of CPU", 0),
    ("memory_bomb", "memory", "ran out of memory", 0),
    ("memory_after_correct_cells", "memory", "ran out of memory", 2),
    ("blas_memory_after_correct_cells", "memory", "ran out of memory", 2),
    ("os_exit_at_import", "crashed", "exited with code 3", 0),
    ("os_exit_in_exercise", "crashed", "ended while the grader waited", 0),
    ("segfault", "crashed", "SIGSEGV", 0),
    ("fake_results_file", "crashed", "ended while the grader waited", 0),
    ("forges_answers", "crashed", "wrote to the grader's channel", 0),
    ("gigabyte_of_output", "output limit", "printed more than 64 MB", 2),
    ("not_json", "malformed notebook", "not JSON (line 1", 0),
    ("latin1", "malformed notebook", "UTF-8", 0),
])
def test_hostile_submission_gets_its_status_and_reason(graded, name, status, reason, points):
    results, *_ = graded
    r = results[name]
    assert r.status == status, r.reason
    assert reason in r.reason, r.reason
    assert r.total == points, {k: e.reason for k, e in r.exercises.items() if e.points}


def test_exits_and_fork_bombs_do_not_stop_grading_the_rest(graded):
    results, *_ = graded
    for name in ("sys_exit_at_import", "fork_bomb", "unbounded_fork_bomb", "zed"):
        assert results[name].status == "ok", (name, results[name].reason)
        assert results[name].exercises["lab01.turning_radius"].points == 2, name
    bomb = [e["error"] for e in results["unbounded_fork_bomb"].cell_errors]
    assert any("Resource temporarily unavailable" in e or "BlockingIOError" in e for e in bomb)
    case = results["sys_exit_in_exercise"].exercises["lab01.turning_radius"]
    assert case.points == 0 and "called sys.exit" in case.reason
    assert any("SystemExit" in e["error"] for e in results["sys_exit_at_import"].cell_errors)


def test_a_submission_deleting_its_folder_and_above_gets_its_own_row(graded):
    results, tmp, *_ = graded
    for name in ("deletes_everything", "tidies_up"):
        assert results[name].status == "ok", results[name].reason
        assert results[name].exercises["lab01.turning_radius"].points == 2
    assert (tmp / "class" / "alice.ipynb").exists() and (tmp / "out" / "gradebook.csv").exists()


def test_forged_answers_printed_verdicts_and_patches_earn_nothing(graded):
    """No descriptor of the submission's process carries a verdict: a forged frame is not an
    answer to the question asked, a stolen question leaves the grader without an answer, and
    nothing it patches judges anything."""
    results, *_ = graded
    for name in ("fake_verdict", "fake_results_file", "monkey_patching", "forges_answers"):
        assert results[name].total == 0, (name, results[name].reason)
    stolen = results["steals_the_question"]
    assert stolen.total <= 2 and stolen.exercises["lab01.turning_radius"].points <= 2


def test_absolute_paths_outside_the_sandbox_are_not_there(graded):
    """Solutions, another submission, the gradebook, the repository's other files, the home
    directory: nothing is readable. The repository's folder shows only the kit's packages
    (and a virtual environment kept there); the home directory only the Python installation."""
    results, *_ = graded
    r = results["reads_absolute_paths"]
    assert r.exercises["lab01.turning_radius"].points == 2
    message = next(e["error"] for e in r.cell_errors if "FOUND" in e["error"])
    found, listed = json.loads(message.split("FOUND ", 1)[1])
    python = [Path(p).resolve() for p in (sys.base_prefix, sys.prefix)]
    in_home = {p.relative_to(Path.home()).parts[0] for p in python if Path.home() in p.parents}
    in_root = {"kit", "grader", "sim", "hardware"} | {
        p.relative_to(ROOT).parts[0] for p in python if ROOT in p.parents}
    assert set(listed.get(str(Path.home()), [])) <= in_home
    assert set(listed.get(str(ROOT), [])) <= in_root
    allowed = {str(Path.home()), "/root", str(ROOT), *(str(Path.home() / n) for n in in_home)}
    assert set(found) <= allowed, set(found) - allowed


def test_nothing_of_a_hidden_case_leaves_the_grader(graded):
    """Its inputs reach the submission, which prints them, writes them to files, raises them,
    names its exception class and its failing line after them, chooses which exception to
    raise, and crashes after printing them: the JSON, the gradebook and the feedback hold none
    of it."""
    results, tmp, *_ = graded
    ex = load_lab("lab01").exercise("turning_radius")
    data = json.loads((tmp / "out" / "gradebook.json").read_text(encoding="utf-8"))
    csv_rows = (tmp / "out" / "gradebook.csv").read_text(encoding="utf-8").splitlines()
    for student in ("leaks_hidden_inputs", "leaks_through_a_crash",
                    "leaks_through_an_exit_code", "leaks_through_the_answer_channel",
                    "exception_side_channel"):
        texts = [json.dumps(next(s for s in data["submissions"] if s["student"] == student)),
                 (tmp / "out" / "feedback" / f"{student}.md").read_text(encoding="utf-8"),
                 *[row for row in csv_rows if row.startswith(student)]]
        for case in ex.hidden_cases(course_seed(ex.id, student, SECRET)):
            for value in case.args:
                if value == 0 or math.isinf(value):
                    continue
                for shown in (repr(value), f"{value:.4f}", repr(value).replace(".", "_")):
                    assert not any(shown in text for text in texts), (student, shown)
    for student in ("leaks_hidden_inputs", "exception_side_channel"):
        hidden = results[student].exercises["lab01.turning_radius"]
        # passed, wrong output, raised or timed out: never which exception
        assert {c.message for c in hidden.cases if not c.public} == {"raised"}, student
    leaky = results["leaks_hidden_inputs"].exercises["lab01.turning_radius"]
    assert all("INPUTS" in c.message for c in leaky.cases if c.public)  # public: shown
    for student in ("leaks_through_a_crash", "leaks_through_an_exit_code",
                    "leaks_through_the_answer_channel"):
        crash = results[student]
        assert crash.status == "crashed", crash.reason
        assert crash.reason.endswith("while running the hidden cases; graded as far as it "
                                     "ran"), crash.reason  # not its signal, code or answer
        assert "225" not in crash.reason and "SIGSEGV" not in crash.reason
        assert crash.exercises["lab01.turning_radius"].points == 2 * 4 / 8  # public cases


def test_nothing_is_left_in_tmp_or_dev_shm(graded):
    _, _, _, (before, after) = graded
    assert before == after == {"/tmp": [], "/dev/shm": []}


@pytest.mark.parametrize("name", [
    "calls_kit_reference", "reloads_kit_reference", "loads_reference_by_path",
    "loads_reference_by_spec_and_name", "executes_reference_source", "loads_compiled_reference",
    "reference_in_a_fresh_process", "reference_from_the_spec", "reference_inside_own_code",
    "digs_out_the_reference"])
def test_the_reference_is_not_in_the_submissions_process(graded, name):
    results, *_ = graded
    ex = results[name].exercises["lab01.turning_radius"]
    assert ex.points == 0, (name, ex.reason)


def test_reference_calls_are_explained(graded):
    results, *_ = graded
    reason = results["calls_kit_reference"].exercises["lab01.turning_radius"].reason
    assert "PermissionError" in reason and "does not exist while lab01 is graded" in reason
    reason = results["loads_reference_by_path"].exercises["lab01.turning_radius"].reason
    assert "PermissionError" in reason and "your own code" in reason
    spec = results["reference_from_the_spec"]
    assert any("No module named 'grader.labs'" in e["error"] for e in spec.cell_errors)


def test_no_secret_no_other_notebooks_no_writes(graded):
    results, tmp, *_ = graded
    errors = [e["error"] for e in results["reads_secret_and_others"].cell_errors]
    assert any("no secret here" in e for e in errors)
    assert any("No such file" in e or "Permission denied" in e for e in errors), errors
    write_errors = [e["error"] for e in results["writes_gradebook_and_submissions"].cell_errors]
    assert len(write_errors) == 2 and all(
        "Read-only" in e or "Permission denied" in e or "No such file" in e
        for e in write_errors), write_errors
    assert "mallory,20" not in (tmp / "out" / "gradebook.csv").read_text()
    assert results["writes_gradebook_and_submissions"].exercises[
        "lab01.turning_radius"].points == 2


def test_the_grader_reads_only_what_the_instructor_put_there(graded):
    """Links, a hard link to a file outside the class, a FIFO: refused on their own rows,
    quoting nothing of what they point to (the course secret, a host file, the solution)."""
    results, tmp, *_ = graded
    for name in ("links_the_secret", "links_a_host_file", "links_the_solution",
                 "hard_links_outside", "a_fifo"):
        r = results[name]
        assert r.status == "refused" and r.total == 0, (name, r.status, r.reason)
    assert "symbolic link" in results["links_the_secret"].reason
    assert "hard link" in results["hard_links_outside"].reason
    assert "FIFO" in results["a_fifo"].reason
    everything = "".join(p.read_text(encoding="utf-8") for p in (tmp / "out").rglob("*")
                         if p.is_file())
    assert SECRET_TEXT not in everything and SHADOW_START not in everything


def test_bytes_that_are_not_text_are_their_own_rows_and_the_class_is_graded(graded):
    results, tmp, *_ = graded
    for name, words in (("surrogate_in_a_cell", "lone surrogate"),
                        ("surrogate_in_its_id", "lone surrogate"),
                        ("caf\\xe9", "not UTF-8")):
        r = results[name]
        assert r.status == "malformed notebook" and words in r.reason, (name, r.reason)
    csv_text = (tmp / "out" / "gradebook.csv").read_text(encoding="utf-8")
    assert "caf\\xe9" in csv_text  # the name's bytes, escaped
    (name,) = file_names(["caf\\xe9"])
    assert (tmp / "out" / "feedback" / f"{name}.md").exists()


def test_a_metadata_identity_claim_never_touches_another_row(graded):
    results, *_ = graded
    assert results["alice"].total == 20
    mallory = results["mallory"]
    assert mallory.total == 0 and "metadata names another student ('alice')" in mallory.reason


def test_a_syntax_error_names_the_cell_the_student_sees(graded):
    results, *_ = graded
    r = results["syntax_error"]
    error = r.cell_errors[0]
    assert error["cell"] == 2 and error["first_line"] == "import math"  # cell 1 is markdown
    assert error["kind"] == "syntax" and error["line"] == 4 and "SyntaxError" in error["error"]
    reason = r.exercises["lab01.turning_radius"].reason
    assert "no function 'turning_radius'" in reason and "cell 2 (`import math`)" in reason
    assert "SyntaxError" in reason and "line 4" in reason


def test_wrong_signatures_and_missing_functions_are_explained(graded):
    results, *_ = graded
    reason = results["wrong_signature"].exercises["lab01.turning_radius"].reason
    assert "TypeError" in reason and "turning_radius(linear, angular)" in reason
    assert "turning_radius(linear)" in reason
    missing = results["missing_functions"].exercises
    assert {e.status for e in missing.values()} == {"missing function"}


def test_the_sandbox_layer_is_reported(graded):
    results, tmp, layer, _ = graded
    ran = {r.sandbox for r in results.values()
           if r.status not in ("malformed notebook", "refused", "duplicate")}
    assert ran == {layer}
    assert json.loads((tmp / "out" / "gradebook.json").read_text())["sandbox"] == layer


def test_results_are_complete_rows(graded):
    results, *_ = graded
    for r in results.values():
        assert isinstance(r, SubmissionResult)
        assert set(r.exercises) == {ex.id for ex in load_lab("lab01").exercises}
        assert r.status != "grader error", (r.student, r.reason)


# ------------------------------------------------------------------ killed from outside

def _submissions_process(grader_pid: int) -> list[int]:
    """Processes of the grader's sandboxes that run as a submission's own user."""
    tag = f"KIT_GRADER_PID={grader_pid}".encode()
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            uid = os.stat(f"/proc/{entry}").st_uid
            with open(f"/proc/{entry}/environ", "rb") as fh:
                mine = tag in fh.read().split(b"\0")
        except OSError:
            continue
        if mine and UID_RANGE[0] <= uid < UID_RANGE[1]:
            found.append(int(entry))
    return found


def _submissions_own_process(grader_pid: int) -> list[int]:
    """Of those, the ones whose parent is one too: the process running the submission's
    code, not the one that waits for it."""
    tagged = _submissions_process(grader_pid)
    own = []
    for pid in tagged:
        try:
            with open(f"/proc/{pid}/stat", encoding="ascii") as fh:
                parent = int(fh.read().rsplit(")", 1)[1].split()[1])
        except (OSError, ValueError, IndexError):
            continue
        if parent in tagged:
            own.append(pid)
    return own


@pytest.mark.parametrize("layer", ISOLATING)
def test_a_sandbox_killed_from_outside_is_a_grader_error_and_a_rerun_retries_it(tmp_path, layer):
    """An administrator's ``kill -9`` (or another process's clean-up) is not the student's
    doing: the row says ``grader error`` and the next run grades it again; the submission
    graded after it by the same server is graded as usual. One job, so that the process
    killed is the slow one's (a session is a supervisor and the submission's own process, the
    one killed here; with two jobs the quick one's could be met first)."""
    import threading
    import time

    if not layer_works(layer):
        pytest.skip(f"the {layer} layer cannot run here")
    folder = _class_folder(tmp_path)
    # slow, honest, little CPU: alive for the killer below, which looks twice a second
    sleepy = GOOD_RADIUS + "import time\ntime.sleep(6)\n"
    write_notebook(folder / "slow_honest.ipynb", [sleepy])
    write_notebook(folder / "then_quick.ipynb", [GOOD_RADIUS])   # graded second
    out, results = tmp_path / "gb.csv", tmp_path / "gb.json"
    spec = load_lab("lab01")
    done: list = []
    worker = threading.Thread(target=lambda: done.append(grade_class(
        sorted(folder.glob("*.ipynb")), spec, out, results, jobs=1, secret=SECRET,
        layer=layer, timeout=60)))
    worker.start()
    deadline = time.monotonic() + 120
    killed = []
    while time.monotonic() < deadline and not killed:
        time.sleep(0.5)
        for pid in _submissions_own_process(os.getpid()):
            try:
                os.kill(pid, signal.SIGKILL)
                killed.append(pid)
            except OSError:
                pass
            break
    worker.join(timeout=300)
    assert killed and done
    rows = {r.student: r for r in done[0]}
    assert rows["slow_honest"].status == "grader error", rows["slow_honest"].reason
    assert "killed from outside" in rows["slow_honest"].reason
    assert rows["then_quick"].status == "ok" and rows["then_quick"].total == 2
    again = {r.student: r for r in grade_class(sorted(folder.glob("*.ipynb")), spec, out,
                                                results, secret=SECRET, layer=layer,
                                                timeout=60)}
    assert again["slow_honest"].status == "ok" and again["slow_honest"].total == 2


def test_retry_grades_rows_of_the_named_statuses_again(tmp_path):
    """A re-run keeps a finished row whose notebook is unchanged — unless its status is
    ``grader error`` or one named in ``retry``."""
    layer = next((layer for layer in ISOLATING if layer_works(layer)), None)
    if layer is None:
        pytest.skip("no isolating layer here")
    folder = _class_folder(tmp_path)
    write_notebook(folder / "crashy.ipynb", [GOOD_RADIUS, "import os\nos._exit(3)"])
    out, results = tmp_path / "gb.csv", tmp_path / "gb.json"
    spec = load_lab("lab01")
    seen: list = []
    grade_class([folder / "crashy.ipynb"], spec, out, results, secret=SECRET, layer=layer)
    grade_class([folder / "crashy.ipynb"], spec, out, results, secret=SECRET, layer=layer,
                progress=lambda r, reused: seen.append(reused))
    grade_class([folder / "crashy.ipynb"], spec, out, results, secret=SECRET, layer=layer,
                retry=("crashed",), progress=lambda r, reused: seen.append(reused))
    assert seen == [True, False]


def test_a_late_submission_claiming_another_identity_lands_on_its_own_row(tmp_path, solved):
    """Graded alone into an existing gradebook, a notebook whose metadata names another
    student updates the row of the file's student — never the one it names."""
    layer = next((layer for layer in ISOLATING if layer_works(layer)), None)
    if layer is None:
        pytest.skip("no isolating layer here")
    folder = _class_folder(tmp_path)
    solved("lab01", folder / "alice.ipynb")
    write_notebook(folder / "bob.ipynb", [GOOD_RADIUS])
    out, results = tmp_path / "gb.csv", tmp_path / "gb.json"
    spec = load_lab("lab01")
    grade_class(sorted(folder.glob("*.ipynb")), spec, out, results, secret=SECRET, layer=layer)
    nb = nbformat.read(ROOT / "labs" / "01-kinematics.ipynb", as_version=4)
    nb.metadata["kit"] = {"student": "alice"}
    nbformat.write(nb, folder / "mallory.ipynb")
    late = grade_class([folder / "mallory.ipynb"], spec, out, results, secret=SECRET,
                       layer=layer)
    assert [r.student for r in late] == ["mallory"]
    rows = {r["student"]: r for r in json.loads(results.read_text())["submissions"]}
    assert set(rows) == {"alice", "bob", "mallory"}
    assert rows["alice"]["total"] == 20 and rows["mallory"]["total"] == 0
    assert "metadata names another student ('alice')" in rows["mallory"]["reason"]

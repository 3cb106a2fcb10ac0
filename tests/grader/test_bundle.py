"""``grader bundle``: the student hand-out holds the labs, the kit and a student Makefile and
README — no solutions, no .git, no tests, no secret — and runs ``make lab`` on its own."""

from __future__ import annotations

import json
import os
import shutil
import signal
import site
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from grader import bundle, cli

ROOT = Path(__file__).resolve().parents[2]


def test_the_bundle_holds_the_hand_out_and_nothing_else(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("KIT_COURSE_SECRET", "bundle-secret-5d1c")
    out = tmp_path / "bundle"
    assert cli.main(["bundle", str(out), "--root", str(ROOT)]) == 0
    assert "wrote the student bundle" in capsys.readouterr().out
    files = sorted(p for p in out.rglob("*") if p.is_file())
    top = {p.relative_to(out).parts[0] for p in files}
    assert top == {"labs", "kit", "sim", "hardware", "grader", "pyproject.toml", "Makefile",
                   "README.md", ".gitignore"}
    assert not any(part in ("__pycache__", ".git", "solutions", "tests", "benchmarks")
                   for p in files for part in p.relative_to(out).parts)
    assert not any(p.suffix == ".pyc" for p in files)
    labs = sorted((ROOT / "labs").glob("[0-9][0-9]-*.ipynb"))
    assert [p.name for p in sorted((out / "labs").iterdir())] == [p.name for p in labs]
    assert all((out / "labs" / p.name).read_bytes() == p.read_bytes() for p in labs)
    assert (out / "kit" / "kinematics.py").read_bytes() == \
        (ROOT / "kit" / "kinematics.py").read_bytes()
    for path in files:
        assert b"bundle-secret-5d1c" not in path.read_bytes(), path
    readme = (out / "README.md").read_text(encoding="utf-8")
    assert "## For students" in readme and "make lab" in readme
    assert "For instructors" not in readme and "solutions/" not in readme
    makefile = (out / "Makefile").read_text(encoding="utf-8")
    assert all(f"\n{target}:" in makefile for target in ("lab", "reset", "demo"))
    assert "solutions" not in makefile and "pytest" not in makefile


def test_a_used_folder_or_a_stale_release_is_refused(tmp_path):
    (tmp_path / "used").mkdir()
    (tmp_path / "used" / "notes.txt").write_text("mine")
    with pytest.raises(bundle.BundleError, match="is not empty"):
        bundle.bundle(tmp_path / "used", ROOT)
    root = tmp_path / "checkout"
    for name in ("kit", "sim", "hardware", "grader", "solutions", "labs"):
        shutil.copytree(ROOT / name, root / name, ignore=bundle.IGNORED)
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, root / name)
    stale = next((root / "labs").glob("01-*.ipynb"))
    stale.write_text(stale.read_text().replace("Kinematics", "Kinematix"))
    with pytest.raises(bundle.BundleError, match="grader release"):
        bundle.bundle(tmp_path / "new", root)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _prepared_venv(copy: Path) -> None:
    """The bundle's ``.venv`` as ``make lab`` leaves it, without downloading: the kit from the
    bundle's own folders, the other dependencies borrowed from this environment."""
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(copy / ".venv")],
                   check=True)
    purelib = subprocess.run([str(copy / ".venv" / "bin" / "python"), "-c",
                              "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                             check=True, capture_output=True, text=True).stdout.strip()
    deps = [p for p in site.getsitepackages() if Path(p).is_dir()]
    (Path(purelib) / "kit_bundle.pth").write_text("\n".join([str(copy), *deps]) + "\n")
    scripts = (("jupyter", "jupyter_core.command"), ("jupyter-lab", "jupyterlab.labapp"))
    for script, entry in scripts:
        path = copy / ".venv" / "bin" / script
        path.write_text(f"#!{copy / '.venv' / 'bin' / 'python'}\nimport sys\n"
                        f"from {entry} import main\nsys.exit(main())\n")
        path.chmod(0o755)
    (copy / ".venv" / ".installed").touch()


@pytest.mark.slow
def test_the_bundle_runs_make_lab_from_a_scratch_copy(tmp_path):
    made = tmp_path / "made"
    bundle.bundle(made, ROOT)
    copy = tmp_path / "elsewhere" / "course"
    shutil.copytree(made, copy)  # a scratch copy, far from the repository
    _prepared_venv(copy)
    where = subprocess.run([str(copy / ".venv" / "bin" / "python"), "-c",
                            "import kit, grader, sim, hardware; grader.checker('lab01'); "
                            "print(kit.__file__, grader.__file__)"],
                           cwd=tmp_path, check=True, capture_output=True, text=True).stdout
    assert all(path.startswith(str(copy)) for path in where.split())
    port, token = _free_port(), "kit-bundle-test"
    env = {**os.environ, "HOME": str(tmp_path), "JUPYTER_RUNTIME_DIR": str(tmp_path / "rt")}
    server = subprocess.Popen(
        ["make", "lab", f"JUPYTER_ARGS=--no-browser --ServerApp.port={port} "
                        f"--IdentityProvider.token={token} --ServerApp.port_retries=0"],
        cwd=copy, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
        start_new_session=True)
    try:
        listing = None
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and listing is None:
            time.sleep(1)
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/contents?token={token}",
                                            timeout=5) as reply:
                    listing = json.loads(reply.read())
            except OSError:
                assert server.poll() is None, server.stdout.read().decode() if server.stdout \
                    else ""
        assert listing is not None, "JupyterLab did not come up"
        names = sorted(item["name"] for item in listing["content"])
        assert names == sorted(p.name for p in (copy / "labs").glob("*.ipynb"))
        assert sorted(p.name for p in (copy / "work").iterdir()) == names
    finally:
        if server.poll() is None:
            os.killpg(server.pid, signal.SIGTERM)
        server.wait(timeout=30)

"""A kit checked out under ``/tmp`` (``git clone . "$(mktemp -d)/k"``, as CI's recipe does)
grades as one anywhere else.

The sandbox binds the kit's packages and virtual environment read-only at their own paths,
and each submission gets a tmpfs of its own over ``/tmp``: without care that tmpfs hid what
was bound below it, and every submission of such a checkout was a grader error
(``mount …/kit/__pycache__: No such file or directory``). Here the submission's own set-up
(:func:`grader.zygote._isolate`) runs in a mount namespace of its own where a folder is
bound read-only under ``/tmp``, as the sandbox binds a checkout there."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = r"""
import json, os, sys
from grader import zygote

source, point, home = sys.argv[1:4]
os.umask(0o022)  # a checkout other users can read, whatever the caller's umask
MS_RDONLY, MS_REMOUNT, MS_BIND = 1, 32, 4096
held = os.open(source, os.O_PATH)
# the sandbox as the grader builds it: a tmpfs on /tmp, the checkout bound read-only in it
zygote._mount("tmpfs", "/tmp", "tmpfs", 0, "size=1048576,mode=1777")
zygote._mount("tmpfs", home, "tmpfs", 0, "size=1048576,mode=755")
os.makedirs(point)
zygote._mount(f"/proc/self/fd/{held}", point, None, MS_BIND)
zygote._mount(None, point, None, MS_REMOUNT | MS_BIND | MS_RDONLY)
open("/tmp/left-by-an-earlier-submission", "w").close()
zygote._isolate({"home": home, "layer": "unshare"}, {"scratch_mb": 16, "uid": 65534})
report = {"uid": os.getuid(), "read": open(os.path.join(point, "module.py")).read(),
          "tmp": sorted(os.listdir("/tmp"))}
try:
    open(os.path.join(point, "planted.py"), "w").close()
    report["write"] = "written"
except OSError as e:
    report["write"] = e.strerror
open("/tmp/scratch", "w").write("mine")
report["scratch"] = open("/tmp/scratch").read()
print(json.dumps(report))
"""


def test_a_folder_bound_under_tmp_stays_readable_and_read_only_for_the_submission(tmp_path):
    if os.geteuid() != 0 or not shutil.which("unshare") or not Path("/mnt").is_dir():
        pytest.skip("needs root, unshare and /mnt (CI has them)")
    source = tmp_path / "kit"
    source.mkdir()
    (source / "module.py").write_text("ANSWER = 42\n", encoding="utf-8")
    source.chmod(0o755)  # readable by other users, as the sandbox needs (not so under umask 077)
    (source / "module.py").chmod(0o644)
    home = "/mnt"  # the submission's home, a tmpfs inside the namespace only
    point = "/tmp/kit-checkout-under-tmp/k/kit"
    run = subprocess.run(["unshare", "--mount", "--propagation", "private", sys.executable,
                          "-c", SCRIPT, str(source), point, home],
                         capture_output=True, text=True, timeout=60,
                         cwd=Path(__file__).resolve().parents[2])
    assert run.returncode == 0, run.stderr
    report = json.loads(run.stdout)
    assert report["uid"] == 65534
    assert report["read"] == "ANSWER = 42\n"  # the bound folder is there, at its own path
    assert report["write"] == "Read-only file system"  # and still read-only
    # the rest of /tmp is the submission's own: nothing an earlier one left
    assert report["tmp"] == ["kit-checkout-under-tmp"] and report["scratch"] == "mine"
    assert not (source / "planted.py").exists()
    assert not Path("/tmp/kit-checkout-under-tmp").exists()  # all inside the namespace
    assert not Path("/tmp/left-by-an-earlier-submission").exists()

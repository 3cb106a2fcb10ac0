"""What the command-line tools share: help text as plain text, negative numbers in options,
trajectories written in the formats other tools read.

* :func:`plain` turns a module's reStructuredText docstring (``code``, :func:`roles`,
  *emphasis*) into the plain text ``--help`` prints.
* :func:`negative_values` lets an option take a comma-separated list that starts with a minus
  sign (``--initial -2.5,-0.36,-1.44``), which argparse would otherwise take for an option.
* :func:`write_trajectory` writes ``stamp, x, y, yaw`` rows as the kit's CSV or in the TUM
  format (``timestamp tx ty tz qx qy qz qw``) that evo, the TUM RGB-D tools and rpg's
  trajectory evaluation read.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["TRAJECTORY_FORMATS", "negative_values", "output_dir", "output_file", "plain",
           "write_trajectory"]

_ROLE = re.compile(r":[a-z]+:`~?([^`]+)`")
_LITERAL = re.compile(r"``([^`]+)``")
_EMPHASIS = re.compile(r"(?<![\w*])\*{1,2}([^*\s][^*]*?)\*{1,2}(?![\w*])")
_NEGATIVE_LIST = re.compile(r"-[\d.][\d.eE+-]*(,\s*-?[\d.][\d.eE+-]*)+")


def plain(doc: str | None) -> str:
    """A reStructuredText docstring as plain text: ``x`` and `x` → x, :func:`a.b` → a.b,
    *x* and **x** → x (a bullet's ``* `` stays)."""
    text = _ROLE.sub(r"\1", doc or "")
    text = _LITERAL.sub(r"\1", text)
    text = _EMPHASIS.sub(r"\1", text)
    return text.replace("`", "")


def negative_values(argv: Sequence[str]) -> list[str]:
    """``--option -1.5,2,-0.3`` → ``--option=-1.5,2,-0.3`` for every option whose value is a
    list of numbers starting with a minus sign; everything else as it was."""
    out: list[str] = []
    args = list(argv)
    i = 0
    while i < len(args):
        a = args[i]
        if (a.startswith("--") and "=" not in a and i + 1 < len(args)
                and _NEGATIVE_LIST.fullmatch(args[i + 1])):
            out.append(f"{a}={args[i + 1]}")
            i += 2
            continue
        out.append(a)
        i += 1
    return out


def output_dir(out: str | Path, make: bool = True) -> Path:
    """``--out``'s folder, made if need be (``make=False``: only checked, for a command to
    refuse a bad ``--out`` before its work and make the folder after it).

    Raises
    ------
    ValueError
        ``out`` is a file, or cannot be made (the message says why).
    """
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{path} is a file; --out takes a folder")
    if not make:
        return path
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"cannot make the folder {path}: {exc.strerror}") from None
    return path


def output_file(out: str | Path, name: str) -> Path:
    """``--out``: a folder (``name`` in it, the folder made) or, for the commands that once
    took a file, a path ending in ``name``'s suffix, taken as that file."""
    path = Path(out)
    if path.suffix == Path(name).suffix:
        return path
    return output_dir(path) / name


TRAJECTORY_FORMATS = ("csv", "tum")


def write_trajectory(path: str | Path, stamps: ArrayLike, poses: ArrayLike,
                     fmt: str = "csv") -> Path:
    """Write a planar trajectory.

    Parameters
    ----------
    path
        The file to write.
    stamps
        (N,) times [s].
    poses
        (N, 3) ``x, y, yaw`` [m, m, rad]; rows with a NaN are left out of a TUM file and
        written with empty fields in a CSV.
    fmt
        ``"csv"``: ``stamp,x,y,yaw``; ``"tum"``: ``timestamp tx ty tz qx qy qz qw`` with
        z = 0 and the yaw as a quaternion about z (x, y, z, w), a ``#`` header line.
    """
    t = np.asarray(stamps, dtype=np.float64).reshape(-1)
    p = np.asarray(poses, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or len(p) != len(t):
        raise ValueError(f"poses must be (N, 3) x, y, yaw beside N stamps; got {p.shape} "
                         f"and {t.shape}")
    if fmt not in TRAJECTORY_FORMATS:
        raise ValueError(f"trajectory format is one of {', '.join(TRAJECTORY_FORMATS)}; got "
                         f"{fmt!r}")
    path = Path(path)
    with path.open("w", encoding="utf-8") as f:
        if fmt == "csv":
            f.write("stamp,x,y,yaw\n")
            for s, (x, y, yaw) in zip(t, p, strict=True):
                f.write(f"{s:.6f},{x:.6f},{y:.6f},{yaw:.6f}\n" if np.all(np.isfinite((x, y, yaw)))
                        else f"{s:.6f},,,\n")
            return path
        f.write("# timestamp tx ty tz qx qy qz qw\n")
        for s, (x, y, yaw) in zip(t, p, strict=True):
            if np.all(np.isfinite((x, y, yaw))):
                f.write(f"{s:.9f} {x:.6f} {y:.6f} 0 0 0 {math.sin(yaw / 2):.9f} "
                        f"{math.cos(yaw / 2):.9f}\n")
    return path

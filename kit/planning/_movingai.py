"""Moving AI grid benchmarks (Sturtevant 2012): ``.map`` grids and ``.map.scen`` scenarios.

A ``.map`` file is four header lines — ``type octile``, ``height H``, ``width W``, ``map`` —
and then ``H`` lines of ``W`` characters. ``.`` ``G`` ``S`` are passable; ``@`` ``O`` ``T``
``W`` are not (water is passable only from water, which the octile benchmarks never use).

A scenario line is ``bucket map width height start_x start_y goal_x goal_y optimal_length``
(tab separated, after a ``version 1`` line). ``x`` is the column and ``y`` the row, 0-based,
row 0 the *top* line of the map: :class:`GridMap` keeps that order, so the cell of
``(x, y)`` is ``passable[y, x]`` — ``(row, col) = (y, x)``, the order of the kit's planners.
``optimal_length`` is the octile shortest path (straight 1, diagonal √2) *without corner
cutting*, printed with a few decimals; :attr:`Scenario.tolerance` is the file's precision.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from kit.planning._costmap import FREE_SPACE, LETHAL_OBSTACLE

__all__ = ["GridMap", "MovingAIError", "Scenario", "read_grid_map", "read_scenarios"]

PASSABLE = ".GS"
"""Terrain characters a unit may stand on."""
BLOCKED = "@OTW"
"""Out of bounds, trees and water."""


class MovingAIError(ValueError):
    """A ``.map`` or ``.scen`` file that does not follow the format; the message names the file
    and the line."""


@dataclass(frozen=True, eq=False)
class GridMap:
    """A Moving AI grid: ``passable[row, col]``, row 0 the first map line (``y = 0``)."""

    name: str
    passable: NDArray[np.bool_]

    @property
    def height(self) -> int:
        return int(self.passable.shape[0])

    @property
    def width(self) -> int:
        return int(self.passable.shape[1])

    def costs(self) -> NDArray[np.uint8]:
        """The grid as costmap costs: passable cells ``FREE_SPACE`` (0), others
        ``LETHAL_OBSTACLE`` (254), shape ``(height, width)``, so the costmap planners run on it
        with unit step costs."""
        return np.where(self.passable, np.uint8(FREE_SPACE), np.uint8(LETHAL_OBSTACLE))


def _header_value(lines: list[str], index: int, key: str, path: Path) -> str:
    if index >= len(lines):
        raise MovingAIError(f"{path}: ends before the header line {index + 1} ('{key} ...')")
    parts = lines[index].split()
    if len(parts) != 2 or parts[0] != key:
        raise MovingAIError(f"{path}: line {index + 1} must be '{key} <value>'; "
                            f"got {lines[index]!r}")
    return parts[1]


def read_grid_map(path: str | Path) -> GridMap:
    """Read a Moving AI ``.map`` file.

    Raises
    ------
    MovingAIError
        A missing file, a header other than ``type octile / height H / width W / map``, too
        few or too short rows, or a character that is no terrain type.

    >>> import tempfile, os
    >>> with tempfile.TemporaryDirectory() as d:
    ...     p = os.path.join(d, "tiny.map")
    ...     _ = open(p, "w").write("type octile\\nheight 2\\nwidth 3\\nmap\\n.@.\\n..T\\n")
    ...     m = read_grid_map(p)
    >>> m.passable.astype(int).tolist()
    [[1, 0, 1], [1, 1, 0]]
    """
    file = Path(path)
    try:
        lines = file.read_text(encoding="ascii").splitlines()
    except FileNotFoundError:
        raise MovingAIError(f"{file}: no such map file") from None
    except UnicodeDecodeError:
        raise MovingAIError(f"{file}: not a Moving AI map (not ASCII text)") from None
    kind = _header_value(lines, 0, "type", file)
    if kind != "octile":
        raise MovingAIError(f"{file}: line 1 must be 'type octile'; got type {kind!r}")
    try:
        height = int(_header_value(lines, 1, "height", file))
        width = int(_header_value(lines, 2, "width", file))
    except ValueError:
        raise MovingAIError(f"{file}: height and width must be integers") from None
    if height <= 0 or width <= 0:
        raise MovingAIError(f"{file}: height and width must be positive; got {height} x {width}")
    if len(lines) < 4 or lines[3].strip() != "map":
        raise MovingAIError(f"{file}: line 4 must be 'map'")
    rows = lines[4:4 + height]
    if len(rows) < height:
        raise MovingAIError(f"{file}: {len(rows)} map rows, the header says {height}")
    for i, row in enumerate(rows):
        if len(row) < width:
            raise MovingAIError(f"{file}: line {i + 5} has {len(row)} characters, the header "
                                f"says width {width}")
    chars = np.frombuffer("".join(row[:width] for row in rows).encode("ascii"),
                          dtype=np.uint8).reshape(height, width)
    known = np.isin(chars, np.frombuffer((PASSABLE + BLOCKED).encode(), np.uint8))
    if not known.all():
        r, c = np.argwhere(~known)[0]
        raise MovingAIError(f"{file}: line {r + 5}, column {c + 1}: {chr(chars[r, c])!r} is not a "
                            f"terrain type ({PASSABLE} passable, {BLOCKED} blocked)")
    passable = np.isin(chars, np.frombuffer(PASSABLE.encode(), np.uint8))
    passable.flags.writeable = False
    return GridMap(file.stem, passable)


@dataclass(frozen=True)
class Scenario:
    """One benchmark problem. ``start`` and ``goal`` are ``(row, col)`` = ``(y, x)``."""

    index: int
    """0-based position in the file (the CLI's ``index`` column)."""
    bucket: int
    map_path: str
    map_width: int
    map_height: int
    start: tuple[int, int]
    goal: tuple[int, int]
    optimal_length: float
    decimals: int
    """digits printed after the decimal point of ``optimal_length``."""

    @property
    def tolerance(self) -> float:
        """How far a correct length may be from ``optimal_length``: half a unit of the last
        printed digit plus one part per million, the generator's own arithmetic (the
        8-decimal city files are off by up to 7e-8, the 6-digit files round values already
        off by up to ~1 % of that half unit)."""
        return 0.5 * 10.0 ** (-self.decimals) + 1e-6 * max(1.0, self.optimal_length)


def _scenario(fields: list[str], index: int, line_no: int, file: Path) -> Scenario:
    if len(fields) != 9:
        raise MovingAIError(f"{file}: line {line_no}: 9 tab-separated fields expected "
                            f"(bucket map width height start_x start_y goal_x goal_y "
                            f"optimal_length); got {len(fields)}")
    try:
        bucket, width, height, sx, sy, gx, gy = (int(fields[i]) for i in (0, 2, 3, 4, 5, 6, 7))
        optimal = float(fields[8])
    except ValueError:
        raise MovingAIError(f"{file}: line {line_no}: not a scenario line: "
                            f"{chr(9).join(fields)!r}") from None
    for name, value, size in (("start_x", sx, width), ("start_y", sy, height),
                              ("goal_x", gx, width), ("goal_y", gy, height)):
        if not 0 <= value < size:
            raise MovingAIError(f"{file}: line {line_no}: {name} = {value} is off the "
                                f"{width} x {height} map")
    text = fields[8].strip()
    decimals = len(text.split(".")[1]) if "." in text else 0
    return Scenario(index, bucket, fields[1], width, height, (sy, sx), (gy, gx), optimal,
                    decimals)


def read_scenarios(path: str | Path) -> tuple[Scenario, ...]:
    """Read a ``.map.scen`` file (``version 1``), one :class:`Scenario` per problem line.

    Raises
    ------
    MovingAIError
        A missing file, no ``version 1`` first line, a line without nine fields, or a start or
        goal off the map size the line states.
    """
    file = Path(path)
    try:
        lines = file.read_text(encoding="utf-8").splitlines()
    except FileNotFoundError:
        raise MovingAIError(f"{file}: no such scenario file") from None
    except UnicodeDecodeError:
        raise MovingAIError(f"{file}: not a scenario file (not text)") from None
    if not lines or lines[0].split() != ["version", "1"]:
        raise MovingAIError(f"{file}: the first line must be 'version 1'")
    scenarios: list[Scenario] = []
    for line_no, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        scenarios.append(_scenario(line.split("\t") if "\t" in line else line.split(),
                                   len(scenarios), line_no, file))
    return tuple(scenarios)

"""Occupancy-grid maps in the ROS map_server format (a YAML file and an image).

``read_map("map.yaml")`` gives the ``nav_msgs/OccupancyGrid`` map_server would publish, and
``write_map(grid, "map.yaml")`` writes what Nav2's ``map_saver`` writes, so maps move between
the kit and Nav2/RViz both ways.

map_server's rule, followed exactly (Nav2's ``map_io``, Jazzy and newer):

- the image is made grey as GraphicsMagick does for map_server: a colour pixel's grey is its
  Rec. 601 luma ``0.299 R + 0.587 G + 0.114 B``; a 16-bit image keeps its top byte;
- in ``trinary`` and ``scale`` mode a grey ``v`` has occupancy ``p = 1 − v/255`` (``v/255``
  with ``negate: 1``), in single precision; ``p >= occupied_thresh`` is 100,
  ``p <= free_thresh`` is 0, anything else −1 (unknown); ``scale`` mode maps ``p`` between
  the thresholds to 0…100 instead; a pixel that is not fully opaque is −1;
- ``raw`` mode takes the grey itself as the cell, −1 where it is above 100.

The image's bottom row is the grid's row 0. Mind the thresholds a file carries: with
``free_thresh: 0.25`` the grey 205 that map_saver writes for unknown cells (p = 0.196) reads
back as *free*: map_server does the same. (Humble's map_server differs in three corner
cases: it averages a colour pixel's channels, averages the alpha in as a fourth channel in
trinary mode, and asks ``p > occupied_thresh`` and ``p < free_thresh``.)
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kit import geometry, msgs

__all__ = ["FREE_THRESH", "MODES", "OCCUPIED_THRESH", "MapError", "cells_of", "check_thresholds",
           "read_image", "read_map", "read_pgm", "saved_values", "write_map"]

MODES = ("trinary", "scale", "raw")
"""map_server's map modes (the YAML's ``mode``; trinary when it has none)."""
FREE_THRESH = 0.196
"""map_server's default ``free_thresh``: a cell less likely occupied than this is free."""
OCCUPIED_THRESH = 0.65
"""map_server's default ``occupied_thresh``: a cell more likely occupied than this is a wall."""


def check_thresholds(free_thresh: float, occupied_thresh: float) -> None:
    """``ValueError`` unless ``0 ≤ free_thresh ≤ occupied_thresh ≤ 1``."""
    if not 0.0 <= free_thresh <= occupied_thresh <= 1.0:
        raise ValueError("thresholds must satisfy 0 <= free_thresh <= occupied_thresh <= 1; got "
                         f"free_thresh={free_thresh}, occupied_thresh={occupied_thresh}")


def saved_values(free_thresh: float = FREE_THRESH,
                 occupied_thresh: float = OCCUPIED_THRESH) -> tuple[int, int]:
    """map_saver's trinary rule for grid values: ``(free, occupied)`` with ``0 ≤ v ≤ free``
    written free (254), ``occupied ≤ v ≤ 100`` written occupied (0) and every other value
    (−1, 101…127, those between) unknown (205); each is ``100 · thresh`` rounded to the
    nearest integer, halves to even (C's ``rint``, as Nav2's ``map_io`` rounds).

    >>> saved_values(), saved_values(0.25, 0.65)
    ((20, 65), (25, 65))
    """
    check_thresholds(free_thresh, occupied_thresh)
    return int(np.rint(100.0 * free_thresh)), int(np.rint(100.0 * occupied_thresh))


class MapError(ValueError):
    """A map file that is missing, truncated or malformed; the message names the file."""


def _pgm_tokens(data: bytes, count: int, path: Path) -> tuple[list[int], int]:
    """The first ``count`` header integers of a PNM file and the offset after them."""
    values: list[int] = []
    i = 2
    while len(values) < count:
        while i < len(data) and data[i:i + 1].isspace():
            i += 1
        if i < len(data) and data[i:i + 1] == b"#":
            while i < len(data) and data[i:i + 1] not in (b"\n", b"\r"):
                i += 1
            continue
        start = i
        while i < len(data) and data[i:i + 1].isdigit():
            i += 1
        if start == i and i >= len(data):
            raise MapError(f"{path}: truncated PGM header: {len(values)} of the {count} numbers "
                           f"(width, height, maxval)")
        if start == i:
            raise MapError(f"{path}: malformed PGM header")
        values.append(int(data[start:i]))
    return values, i + 1  # one whitespace byte ends the header


def read_pgm(path: Path) -> NDArray[np.uint8]:
    """A binary (P5) or ASCII (P2) PGM image as a (rows, cols) array of 8-bit greys, top row
    first. A 16-bit image (maxval 65535) keeps each pixel's top byte, as GraphicsMagick gives
    map_server; another maxval is scaled to 0…255 and rounded."""
    data = Path(path).read_bytes()
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise MapError(f"{path}: not a PGM image (starts with {magic!r})")
    (width, height, maxval), offset = _pgm_tokens(data, 3, path)
    if width == 0 or height == 0:
        raise MapError(f"{path}: the image has no pixels ({width} x {height})")
    if not 0 < maxval < 65536:
        raise MapError(f"{path}: bad PGM maxval {maxval}")
    pixels: NDArray[Any]
    if magic == b"P5":
        dtype = np.dtype(">u2") if maxval > 255 else np.dtype(np.uint8)
        need = width * height * dtype.itemsize
        if len(data) - offset < need:
            raise MapError(f"{path}: truncated: {len(data) - offset} bytes of pixels, "
                           f"{need} expected for {width} x {height}")
        pixels = np.frombuffer(data, dtype=dtype, count=width * height, offset=offset)
    else:
        pixels = np.array(data[offset:].split(), dtype=np.int64)
        if pixels.size < width * height:
            raise MapError(f"{path}: truncated: {pixels.size} of {width * height} pixels")
        pixels = pixels[: width * height]
    if (pixels > maxval).any():
        raise MapError(f"{path}: a pixel is above the header's maxval {maxval}")
    if maxval == 65535:
        grey = pixels // 257
    else:
        grey = np.rint(np.asarray(pixels, dtype=np.float64) * (255.0 / maxval))
    return grey.astype(np.uint8).reshape(height, width)


def _luma(rgb: NDArray[Any]) -> NDArray[np.uint8]:
    """GraphicsMagick's grey of 8-bit RGB pixels (its 16-bit build, as Debian and Ubuntu ship
    it): Rec. 601 luma of the 16-bit channels, rounded, then the top byte."""
    r, g, b = (rgb[..., i].astype(np.float64) * 257.0 for i in range(3))
    q = np.floor(0.299 * r + 0.587 * g + 0.114 * b + 0.5)
    return (q // 257).astype(np.uint8)


def read_image(path: Path) -> tuple[NDArray[np.uint8], NDArray[np.uint8] | None]:
    """An image's 8-bit greys as map_server sees them and its alpha (``None`` if it has none),
    both (rows, cols), top row first: PGM, PNG, BMP or any image Pillow reads."""
    if path.suffix.lower() in (".pgm", ".pnm"):
        return read_pgm(path), None
    from PIL import Image, UnidentifiedImageError  # Pillow comes with matplotlib

    try:
        with Image.open(path) as opened:
            opened.load()
            img: Image.Image = opened
            if img.mode in ("I;16", "I;16L", "I;16B", "I"):  # 16-bit grey: its top byte
                wide = np.asarray(img).astype(np.int64)
                return (np.clip(wide, 0, 65535) // 257).astype(np.uint8), None
            if img.mode not in ("L", "LA", "RGB", "RGBA") or "transparency" in img.info:
                # palette, 1-bit, CMYK, premultiplied...: to grey or colour, with an alpha
                # where the image has one (a transparent colour or palette entry included)
                has_alpha = "A" in img.mode or "transparency" in img.info
                is_grey = img.mode in ("1", "L", "LA", "La")
                img = img.convert(("LA" if has_alpha else "L") if is_grey else
                                  ("RGBA" if has_alpha else "RGB"))
            array = np.asarray(img)
    except (UnidentifiedImageError, OSError, ValueError) as exc:
        raise MapError(f"{path}: unreadable image ({exc})") from None
    if array.ndim == 2:
        return array.astype(np.uint8), None
    if array.shape[2] == 2:
        return array[..., 0].astype(np.uint8), array[..., 1].astype(np.uint8)
    grey = _luma(array)
    return grey, (array[..., 3].astype(np.uint8) if array.shape[2] == 4 else None)


def cells_of(grey: NDArray[np.uint8], alpha: NDArray[np.uint8] | None, mode: str = "trinary",
             negate: bool = False, free_thresh: float = FREE_THRESH,
             occupied_thresh: float = OCCUPIED_THRESH) -> NDArray[np.int8]:
    """map_server's cells (−1, 0…100) for an image's greys and alpha, top row first.

    The arithmetic is map_server's, in single precision: ``p = 1 − v/255``; a cell is 100 if
    ``p >= occupied_thresh``, else 0 if ``p <= free_thresh``; in ``scale`` mode a ``p``
    strictly between is ``round(100 (p − free) / (occupied − free))``, halves away from zero.
    """
    check_thresholds(free_thresh, occupied_thresh)
    if mode == "raw":
        return np.where(grey <= 100, grey, -1).astype(np.int8)
    if mode not in MODES:
        raise ValueError(f"unknown map mode {mode!r}: {', '.join(MODES)}")
    p = grey.astype(np.float32) / np.float32(255.0)
    if not negate:
        p = np.float32(1.0) - p
    free, occupied = np.float32(free_thresh), np.float32(occupied_thresh)
    cells = np.full(p.shape, -1, dtype=np.int8)
    cells[p >= occupied] = 100
    cells[p <= free] = 0
    if mode == "scale":
        between = (p > free) & (p < occupied)
        scaled = (p[between] - free) / np.float32(occupied_thresh - free_thresh) \
            * np.float32(100.0)
        whole = np.floor(scaled)
        cells[between] = (whole + (scaled - whole >= 0.5)).astype(np.int8)
    if alpha is not None:
        cells[alpha < 255] = -1
    return cells


def _load_yaml(path: Path) -> dict[str, Any]:
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    try:
        data = YAML(typ="safe", pure=True).load(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise MapError(f"{path}: no such map file") from None
    except (YAMLError, UnicodeDecodeError) as exc:
        raise MapError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(data, dict):
        raise MapError(f"{path}: a map YAML is a mapping with image, resolution, origin, ...")
    return data


_REQUIRED = ("image", "resolution", "origin", "negate", "occupied_thresh", "free_thresh")
"""The keys map_server refuses a map YAML without."""


def read_map(path: str | Path, frame_id: str = "map") -> msgs.OccupancyGrid:
    """Load a map_server map (YAML + PGM/PNG/BMP) as an ``OccupancyGrid``: the one Nav2's
    map_server publishes for the file, or a ``MapError`` where map_server refuses it.

    Raises
    ------
    MapError
        Missing keys, a missing or truncated image, thresholds out of range.
    """
    yaml_path = Path(path).expanduser()
    meta = _load_yaml(yaml_path)
    missing = [key for key in _REQUIRED if key not in meta]
    if missing:
        raise MapError(f"{yaml_path}: missing {', '.join(repr(k) for k in missing)} (map_server "
                       f"needs {', '.join(_REQUIRED)}; mode is optional, trinary by default)")
    if not str(meta["image"]):
        raise MapError(f"{yaml_path}: 'image' is empty")
    image_path = yaml_path.parent / str(meta["image"])
    if not image_path.is_file():
        raise MapError(f"{yaml_path}: its image {image_path} does not exist")
    try:
        resolution = float(meta["resolution"])
        origin = [float(v) for v in meta["origin"]]
        occupied = float(meta["occupied_thresh"])
        free = float(meta["free_thresh"])
        if not isinstance(meta["negate"], int):   # an integer or true/false, as map_server
            raise TypeError(meta["negate"])
        negate = bool(meta["negate"])
    except (TypeError, ValueError):
        raise MapError(f"{yaml_path}: resolution, occupied_thresh and free_thresh must be "
                       f"numbers, origin a list [x, y, yaw], negate 0 or 1") from None
    mode = str(meta.get("mode", "trinary"))
    if not (math.isfinite(resolution) and resolution > 0):
        raise MapError(f"{yaml_path}: resolution must be a positive number of metres per "
                       f"cell; got {meta['resolution']!r}")
    if len(origin) != 3 or not all(map(math.isfinite, origin)):
        raise MapError(f"{yaml_path}: origin must be [x, y, yaw] (three finite numbers: m, m, "
                       f"rad, the lower-left cell's corner); got {meta['origin']!r}")
    try:
        check_thresholds(free, occupied)
    except ValueError as exc:
        raise MapError(f"{yaml_path}: {exc}") from None
    if mode not in MODES:
        raise MapError(f"{yaml_path}: unknown mode {mode!r}")
    grey, alpha = read_image(image_path)
    cells = cells_of(grey, alpha, mode, negate, free, occupied)
    grid = np.flipud(cells)
    height, width = grid.shape
    q = geometry.yaw_to_quaternion(origin[2])
    info = msgs.MapMetaData(
        resolution=resolution, width=width, height=height,
        origin=msgs.Pose(msgs.Point(origin[0], origin[1], 0.0), msgs.Quaternion(*map(float, q))))
    return msgs.OccupancyGrid(msgs.Header(frame_id=frame_id), info, grid.ravel())


def write_map(grid: msgs.OccupancyGrid, path: str | Path, free_thresh: float = FREE_THRESH,
              occupied_thresh: float = OCCUPIED_THRESH) -> Path:
    """Write ``path`` (YAML) and a PGM beside it as Nav2's map_saver does in trinary mode: the
    cells classed by the thresholds given (:func:`saved_values`) and written free 254,
    occupied 0, unknown 205. Returns the PGM's path.

    The YAML carries map_server's default thresholds (0.65 and 0.196), not the ones given,
    as map_saver's does since Nav2 PR #5278: they are what tells the three greys apart when
    the map is read back. (Before, a map saved with ``free_thresh: 0.25`` read its unknown
    205 back as free.) Like map_saver, ``free_thresh`` must be below ``occupied_thresh``.
    """
    if not free_thresh < occupied_thresh:
        raise ValueError(f"free_thresh must be below occupied_thresh, as map_saver asks; got "
                         f"free_thresh={free_thresh}, occupied_thresh={occupied_thresh}")
    free, occupied = saved_values(free_thresh, occupied_thresh)
    yaml_path = Path(path)
    pgm_path = yaml_path.with_suffix(".pgm")
    info = grid.info
    cells = grid.data.reshape(info.height, info.width)
    image = np.full(cells.shape, 205, dtype=np.uint8)
    image[(cells >= occupied) & (cells <= 100)] = 0
    image[(cells >= 0) & (cells <= free)] = 254       # map_saver asks "free?" first
    header = (f"P5\n# CREATOR: kit.maps {info.resolution:.3f} m/pix\n"
              f"{info.width} {info.height}\n255\n")
    pgm_path.write_bytes(header.encode() + np.flipud(image).tobytes())
    o = info.origin
    yaw = float(geometry.quaternion_to_yaw([o.orientation.x, o.orientation.y, o.orientation.z,
                                            o.orientation.w]))
    yaml_path.write_text(
        f"image: {pgm_path.name}\nmode: trinary\nresolution: {info.resolution:.6f}\n"
        f"origin: [{o.position.x:.6f}, {o.position.y:.6f}, {yaw:.6f}]\nnegate: 0\n"
        f"occupied_thresh: {OCCUPIED_THRESH}\nfree_thresh: {FREE_THRESH}\n", encoding="utf-8")
    return pgm_path

"""Occupancy-grid maps in the ROS map_server format (a YAML file and an image).

``read_map("map.yaml")`` gives the ``nav_msgs/OccupancyGrid`` map_server would publish, and
``write_map(grid, "map.yaml")`` writes what Nav2's ``map_saver`` writes, so maps move between
the kit and Nav2/RViz both ways.

map_server's trinary rule, followed exactly: a pixel ``v`` (of maxval 255, channels averaged)
has occupancy ``p = (255 − v) / 255`` (``v / 255`` with ``negate: 1``); ``p > occupied_thresh``
is 100, ``p < free_thresh`` is 0, anything else −1 (unknown). The image's bottom row is the
grid's row 0. Mind the thresholds a file carries: with ``free_thresh: 0.25`` the grey 205 that
map_saver writes for unknown cells (p = 0.196) reads back as *free* — map_server does the same.
``scale`` mode keeps ``p`` as 0…100 between the thresholds; ``raw`` takes the pixel value.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from kit import geometry, msgs

__all__ = ["FREE_THRESH", "OCCUPIED_THRESH", "MapError", "check_thresholds", "read_map",
           "read_pgm", "saved_values", "write_map"]

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
    """A binary (P5) or ASCII (P2) PGM image as a (rows, cols) array, top row first."""
    data = Path(path).read_bytes()
    magic = data[:2]
    if magic not in (b"P5", b"P2"):
        raise MapError(f"{path}: not a PGM image (starts with {magic!r})")
    (width, height, maxval), offset = _pgm_tokens(data, 3, path)
    if width == 0 or height == 0:
        raise MapError(f"{path}: the image has no pixels ({width} x {height})")
    if not 0 < maxval < 65536:
        raise MapError(f"{path}: bad PGM maxval {maxval}")
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
    scaled = np.asarray(pixels, dtype=np.float64) * (255.0 / maxval)
    return np.rint(scaled).astype(np.uint8).reshape(height, width)


def _read_image(path: Path) -> NDArray[np.uint8]:
    if path.suffix.lower() in (".pgm", ".pnm"):
        return read_pgm(path)
    from PIL import Image, UnidentifiedImageError  # Pillow comes with matplotlib

    try:
        with Image.open(path) as img:
            array = np.asarray(img.convert("RGB") if img.mode not in ("L", "RGB") else img)
    except (UnidentifiedImageError, OSError) as exc:
        raise MapError(f"{path}: unreadable image ({exc})") from None
    if array.ndim == 3:  # map_server averages the colour channels
        array = np.rint(array[..., :3].astype(np.float64).mean(axis=2)).astype(np.uint8)
    return array.astype(np.uint8)


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


def read_map(path: str | Path, frame_id: str = "map") -> msgs.OccupancyGrid:
    """Load a map_server map (YAML + PGM/PNG/BMP) as an ``OccupancyGrid``.

    Raises
    ------
    MapError
        Missing keys, a missing or truncated image, thresholds out of range.
    """
    yaml_path = Path(path)
    meta = _load_yaml(yaml_path)
    for key in ("image", "resolution", "origin"):
        if key not in meta:
            raise MapError(f"{yaml_path}: missing '{key}'")
    image_path = yaml_path.parent / str(meta["image"])
    if not image_path.is_file():
        raise MapError(f"{yaml_path}: its image {image_path} does not exist")
    try:
        resolution = float(meta["resolution"])
        origin = [float(v) for v in meta["origin"]]
        occupied = float(meta.get("occupied_thresh", OCCUPIED_THRESH))
        free = float(meta.get("free_thresh", FREE_THRESH))
        negate = int(meta.get("negate", 0))
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
    if not 0.0 <= free <= occupied <= 1.0:
        raise MapError(f"{yaml_path}: thresholds must satisfy 0 <= free_thresh <= "
                       f"occupied_thresh <= 1; got {free}, {occupied}")
    if mode not in ("trinary", "scale", "raw"):
        raise MapError(f"{yaml_path}: unknown mode {mode!r}")
    pixels = _read_image(image_path).astype(np.float64)
    if mode == "raw":
        cells = pixels.astype(np.int64)
    else:
        p = pixels / 255.0 if negate else (255.0 - pixels) / 255.0
        cells = np.full(p.shape, -1, dtype=np.int64)
        cells[p > occupied] = 100
        cells[p < free] = 0
        if mode == "scale":
            between = (p >= free) & (p <= occupied)
            cells[between] = np.rint(99 * (p[between] - free) / (occupied - free)).astype(int)
    grid = np.flipud(cells).astype(np.int8)
    height, width = grid.shape
    q = geometry.yaw_to_quaternion(origin[2])
    info = msgs.MapMetaData(
        resolution=resolution, width=width, height=height,
        origin=msgs.Pose(msgs.Point(origin[0], origin[1], 0.0), msgs.Quaternion(*map(float, q))))
    return msgs.OccupancyGrid(msgs.Header(frame_id=frame_id), info, grid.ravel())


def write_map(grid: msgs.OccupancyGrid, path: str | Path, free_thresh: float = FREE_THRESH,
              occupied_thresh: float = OCCUPIED_THRESH) -> Path:
    """Write ``path`` (YAML) and a PGM beside it as map_saver does in trinary mode: free 254,
    occupied 0, unknown 205, the cells classed by the thresholds given (:func:`saved_values`),
    which the YAML then carries. Returns the PGM's path."""
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
        f"occupied_thresh: {occupied_thresh}\nfree_thresh: {free_thresh}\n", encoding="utf-8")
    return pgm_path

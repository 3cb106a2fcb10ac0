"""Writes this folder's images and ``reference.npz``: what Nav2's map_server makes of each
image (its greys, its alpha if it has one, its cells in each mode), computed by
``map_io_reference.cpp`` (GraphicsMagick + Eigen, see README.md).

Run by hand with a compiled ``map_io_reference`` beside it (the suite only reads the files):
``python tests/data/map_images/make_reference.py``.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
from PIL import Image

HERE = Path(__file__).resolve().parent
REFERENCE = HERE / "map_io_reference"
THRESHOLDS = [(0.196, 0.65), (0.25, 0.65), (0.2, 0.6), (0.25, 0.75), (0.0, 1.0), (0.5, 0.5)]
"""map_server's defaults; map_saver's older free 0.25; two pairs that are whole greys (51/255,
153/255); the extremes; a pair with nothing between."""


def images(rng: np.random.Generator) -> dict[str, Image.Image | bytes]:
    every = rng.permutation(256).astype(np.uint8).reshape(16, 16)   # each grey once
    alpha = rng.choice(np.array([0, 1, 128, 254, 255, 255, 255, 255], np.uint8), (16, 16))
    colour = rng.integers(0, 256, (16, 16, 3), dtype=np.uint8)
    wide = rng.integers(0, 65536, (16, 16), dtype=np.uint16)
    palette = Image.fromarray(rng.integers(0, 256, (16, 16, 3), dtype=np.uint8)).quantize(32)
    palette_trns = palette.copy()
    palette_trns.info["transparency"] = 3
    grey_trns = Image.fromarray(every)
    grey_trns.info["transparency"] = int(every[5, 5])
    return {
        "grey.pgm": b"P5\n# CREATOR: kit test 0.050 m/pix\n16 16\n255\n" + every.tobytes(),
        "grey_ascii.pgm": b"P2\n16 16\n255\n" + " ".join(map(str, every.ravel())).encode() + b"\n",
        "grey16.pgm": b"P5\n16 16\n65535\n" + wide.astype(">u2").tobytes(),
        "grey.png": Image.fromarray(every),
        "grey16.png": Image.fromarray(wide),
        "grey_alpha.png": Image.fromarray(np.dstack([every, alpha]), "LA"),
        "grey_trns.png": grey_trns,
        "bilevel.png": Image.fromarray(every > 127),
        "colour.png": Image.fromarray(colour),
        "colour_alpha.png": Image.fromarray(np.dstack([colour, alpha]), "RGBA"),
        "palette.png": palette,
        "palette_trns.png": palette_trns,
        "colour.bmp": Image.fromarray(colour),
        "palette.bmp": palette,
    }


def main() -> None:
    arrays: dict[str, np.ndarray] = {}
    for name, image in images(np.random.default_rng(2026)).items():
        path = HERE / name
        if isinstance(image, bytes):
            path.write_bytes(image)
        else:
            image.save(path, **({"transparency": image.info["transparency"]}
                                if "transparency" in image.info else {}))
        args = [str(REFERENCE), str(path), "raw", "0", "0", "1"]
        keys = [f"{name}|raw"]
        for negate in (0, 1):
            for free, occupied in THRESHOLDS:
                for mode in ("trinary", "scale"):
                    args += [mode, str(negate), repr(free), repr(occupied)]
                    keys.append(f"{name}|{mode}|{negate}|{free}|{occupied}")
        out = subprocess.run(args, check=True, capture_output=True, text=True).stdout
        lines = out.splitlines()
        width, height, has_alpha = map(int, lines.pop(0).split())
        keys = [f"{name}|grey"] + ([f"{name}|alpha"] if has_alpha else []) + keys
        for key, line in zip(keys, lines, strict=True):
            values = np.array(line.split(), dtype=np.int64).reshape(height, width)
            arrays[key] = values.astype(np.uint8 if key.endswith(("grey", "alpha")) else np.int8)
    np.savez_compressed(HERE / "reference.npz", **arrays)


if __name__ == "__main__":
    main()

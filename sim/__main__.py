"""``python -m sim demo [--out DIR] [--seed N]``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim", description="The kit's simulator.")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="drive each robot around a square; plot odometry vs truth")
    demo.add_argument("--out", default="out", help="folder for the PNG (out)")
    demo.add_argument("--seed", type=int, default=7)
    args = parser.parse_args(argv)
    from sim import demo as demo_module

    return demo_module.main(Path(args.out), args.seed)


if __name__ == "__main__":
    sys.exit(main())

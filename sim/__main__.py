"""``python -m sim demo [--out DIR] [--seed N]`` and ``python -m sim bench [--quick]``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m sim", description="The kit's simulator.")
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo",
                          help="the Uiabot drives a route through the office; PNG and MCAP bag")
    demo.add_argument("--out", default="out", help="folder for the PNG (out)")
    demo.add_argument("--seed", type=int, default=7)
    bench = sub.add_parser("bench", help="real-time factors and raycaster throughput")
    bench.add_argument("--quick", action="store_true", help="one short run per figure")
    args = parser.parse_args(argv)
    if args.command == "bench":
        from sim import bench as bench_module

        return bench_module.main(args.quick)
    from sim import demo as demo_module

    return demo_module.main(Path(args.out), args.seed)


if __name__ == "__main__":
    sys.exit(main())

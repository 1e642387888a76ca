"""Prints tensim's speed figures (same as ``tensim bench``): real-time factors, ratio to MuJoCo.

Usage: python benchmarks/bench.py [--json FILE] [--duration S] [--repeats N]
"""

import sys

from tensim.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", *sys.argv[1:]]))

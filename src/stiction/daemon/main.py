"""The `stictiond` entry point (placeholder until the daemon lands)."""

from __future__ import annotations

import sys


def main() -> int:
    print("stictiond: not implemented yet", file=sys.stderr)
    return 1

"""`stiction devices`: every tablet and touchpad this machine shows, from every backend,
and which of a device's nodes stiction reads (stiction.drivers.discovery has the rule)."""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict
from typing import Any

from stiction.drivers.discovery import discover_all


def _devices(args: argparse.Namespace) -> int:
    found = discover_all()
    if args.json:
        # One JSON array, `[]` when nothing is found, so a script can always parse the output.
        print(json.dumps([{**asdict(info), "vid_pid": info.vid_pid} for info in found]))
        return 0
    if not found:
        print("no tablets or touchpads found", file=sys.stderr)
        return 0
    for info in found:
        status = "ok" if info.problem is None else info.problem
        use = "chosen" if info.chosen else "not chosen"
        print(
            f"{info.path}\t{info.vid_pid}\t{info.kind}\t{info.backend}\t{info.name}\t{status}"
            f"\t{use}: {info.reason}"
        )
    return 0


def register(sub: argparse._SubParsersAction[Any]) -> None:
    p = sub.add_parser("devices", help="list the tablets and touchpads found")
    p.add_argument(
        "--json", action="store_true", help="one JSON array, an object per device ([] if none)"
    )
    p.set_defaults(func=_devices)

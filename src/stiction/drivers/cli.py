"""`stiction devices`: every tablet and touchpad this machine shows, from every backend."""

from __future__ import annotations

import argparse
import importlib
import json
import logging
import sys
from dataclasses import asdict
from typing import Any

from stiction.drivers.info import DeviceInfo

# Each backend module offers ``discover() -> list[DeviceInfo]``.
BACKENDS = ("stiction.drivers.hid", "stiction.drivers.evdev")


def discover_all() -> list[DeviceInfo]:
    found: list[DeviceInfo] = []
    for name in BACKENDS:
        module = importlib.import_module(name)
        discover = getattr(module, "discover", None)
        if discover is None:
            continue
        try:
            found.extend(discover())
        except Exception as exc:  # a backend that fails must not hide the other's devices
            logging.getLogger(__name__).warning(
                "discovery_failed backend=%s error=%s: %s", name, type(exc).__name__, exc
            )
    return found


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
        print(f"{info.path}\t{info.vid_pid}\t{info.kind}\t{info.backend}\t{info.name}\t{status}")
    return 0


def register(sub: argparse._SubParsersAction[Any]) -> None:
    p = sub.add_parser("devices", help="list the tablets and touchpads found")
    p.add_argument(
        "--json", action="store_true", help="one JSON array, an object per device ([] if none)"
    )
    p.set_defaults(func=_devices)

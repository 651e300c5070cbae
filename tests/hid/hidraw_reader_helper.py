"""Runs inside umockdev-run: the production hidraw backend reads a mocked node.

Usage: python hidraw_reader_helper.py DEVICE N_REPORTS [--discover]
Prints one JSON line per PenSample, then a final {"stats": ...} line.
Stops once the backend has fed N_REPORTS reports (waiting on the source's
counters with a short timeout per check, never a fixed sleep), or raises
when the device errors.
"""

from __future__ import annotations

import json
import sys
import threading
from dataclasses import asdict

from stiction.drivers.hid import discover, open_hidraw
from stiction.errors import DeviceError


def main() -> int:
    device, wanted = sys.argv[1], int(sys.argv[2])
    if "--discover" in sys.argv:
        for info in discover():
            print(json.dumps({"discover": asdict(info)}), flush=True)
    src = open_hidraw(device)
    print(json.dumps({"kind": src.kind, "size": src.surface_size, "name": src.name}), flush=True)
    out: list[str] = []
    failure: list[str] = []
    done = threading.Event()

    def pump() -> None:
        try:
            for s in src.samples():
                d = asdict(s)
                d["tool"] = s.tool.value
                out.append(json.dumps(d))
        except DeviceError as exc:
            failure.append(str(exc))
        finally:
            done.set()

    t = threading.Thread(target=pump, daemon=True)
    t.start()
    while not done.wait(0.01):
        if src.stats().get("reports", 0) >= wanted:
            break
    src.close()
    done.wait(5.0)
    for line in out:
        print(line)
    print(json.dumps({"stats": src.stats(), "error": failure[0] if failure else None}))
    return 0


if __name__ == "__main__":
    sys.exit(main())

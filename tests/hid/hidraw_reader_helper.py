"""Runs inside umockdev-run: the production hidraw backend reads a mocked node.

Usage: python hidraw_reader_helper.py DEVICE N_REPORTS [--discover] [--until-error]
       [--huion-usb[=v1:X,Y,P,LPI]] [--usb-id=VVVV:PPPP] [--usb-string=INDEX:TEXT ...]
Prints one JSON line per PenSample, then a final {"stats": ...} line.
Stops once the backend has fed N_REPORTS reports (waiting on the source's
counters with a short timeout per check, never a fixed sleep), or when the
device errors. With --until-error it prints {"reached": N} at that point and
keeps reading until the device fails (the unplug test). With --huion-usb
the USB side of the Huion initialisation is the pyusb backend object of
fake_huion_usb.py (umockdev mocks hidraw here, not usbdevfs); --usb-string
adds a USB string descriptor that object answers (for catalogue matches).
"""

from __future__ import annotations

import json
import sys
import threading
import time
from dataclasses import asdict

from stiction.drivers.hid import discover, open_hidraw
from stiction.errors import DeviceError

STALL_S = 10.0  # no report for this long: give up waiting (the test then fails cleanly)


def main() -> int:
    device, wanted = sys.argv[1], int(sys.argv[2])
    if "--discover" in sys.argv:
        for info in discover():
            print(json.dumps({"discover": asdict(info)}), flush=True)
    backend = None
    usb_id = next((a.partition("=")[2] for a in sys.argv if a.startswith("--usb-id=")), None)
    vid, pid = (int(v, 16) for v in usb_id.split(":")) if usb_id else (0x256C, 0x006D)
    for arg in sys.argv:
        if arg.startswith("--huion-usb"):
            from fake_huion_usb import V2, HuionUsbBackend, v1_answer

            _, _, spec = arg.partition("=")
            if spec.startswith("v1:"):
                x, y, p, lpi = (int(v) for v in spec[3:].split(","))
                backend = HuionUsbBackend({100: v1_answer(x, y, p, lpi)}, vid=vid, pid=pid)
            else:
                backend = HuionUsbBackend({200: V2}, vid=vid, pid=pid)
    strings = [a.partition("=")[2] for a in sys.argv if a.startswith("--usb-string=")]
    if strings:
        from fake_huion_usb import HuionUsbBackend, string_descriptor

        answers = {} if backend is None else dict(backend.strings)
        for spec in strings:
            index, _, text = spec.partition(":")
            answers[int(index)] = string_descriptor(text.encode("utf-16-le"))
        backend = HuionUsbBackend(answers, vid=vid, pid=pid)
    try:
        src = open_hidraw(device, usb_backend=backend)
    except DeviceError as exc:
        print(json.dumps({"open_error": str(exc)}))
        return 0
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
    until_error = "--until-error" in sys.argv
    reached = False
    last, last_change = -1, time.monotonic()
    while not done.wait(0.01):
        got = src.stats().get("reports", 0)
        if got != last:
            last, last_change = got, time.monotonic()
        elif not reached and time.monotonic() - last_change > STALL_S:
            print(json.dumps({"stalled_at": got}), flush=True)  # the device sent no more
            break
        if not reached and got >= wanted:
            reached = True
            if not until_error:
                break
            print(json.dumps({"reached": wanted}), flush=True)
    src.close()
    src.close()  # idempotent
    done.wait(5.0)
    for line in out:
        print(line)
    print(json.dumps({"stats": src.stats(), "error": failure[0] if failure else None}))
    return 0


if __name__ == "__main__":
    sys.exit(main())

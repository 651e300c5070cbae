"""`stiction evdev decode|read|describe`: look at evdev recordings and devices frame by frame.

`decode` is the interface of docs/design/architecture.md (one JSON object per SYN_REPORT
frame); `read` prints the same objects from a live node, so a recording and
the device it was made on can be compared line by line.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Iterable, Iterator
from typing import Any, TextIO

from stiction.argtypes import add_size_mm_option, non_negative_int, positive_int
from stiction.errors import StictionError


def register(sub: argparse._SubParsersAction[Any]) -> None:
    p = sub.add_parser(
        "evdev",
        help="decode evdev recordings and read kernel input devices",
        description="Kernel input devices (evdev) and their recordings, frame by frame.",
    )
    evsub = p.add_subparsers(dest="evdev_command", metavar="COMMAND", required=True)

    d = evsub.add_parser(
        "decode",
        help="print the frames of an evemu or libinput record recording",
        description=(
            "Decode an evemu recording (one file, or a description and an events file) "
            "or a `libinput record` YAML file into one object per SYN_REPORT frame."
        ),
    )
    d.add_argument("recording", help="evemu file, evemu .desc, or libinput record .yml")
    d.add_argument("events", nargs="?", help="evemu events file when separate")
    d.add_argument("--json", action="store_true", help="one JSON object per frame")
    d.add_argument(
        "--realtime", action="store_true", help="print at the recorded pace (default: at once)"
    )
    add_size_mm_option(d)
    d.add_argument("--stats", action="store_true", help="print counters to stderr at the end")
    d.add_argument(
        "--index",
        type=non_negative_int,
        metavar="N",
        help="device N of a multi-device libinput recording (default: the first pen/touch)",
    )
    d.set_defaults(func=_decode)

    r = evsub.add_parser(
        "read",
        help="print the frames of a live /dev/input/eventN",
        description="Read a kernel input device and print its frames as `decode` does.",
    )
    r.add_argument("device", help="/dev/input/eventN")
    r.add_argument("--json", action="store_true", help="one JSON object per frame")
    r.add_argument("--grab", action="store_true", help="take the device exclusively")
    r.add_argument("--frames", type=positive_int, metavar="N", help="stop after N frames")
    add_size_mm_option(r)
    r.add_argument("--stats", action="store_true", help="print counters to stderr at the end")
    r.set_defaults(func=_read)

    w = evsub.add_parser(
        "record",
        help="record a live device to an evemu or libinput record file",
        description=(
            "Record the events of /dev/input/eventN, as evemu-record or libinput record "
            "would, so that the session can be decoded and replayed later. The format "
            "follows the file name: .yml/.yaml writes libinput record YAML, anything else "
            "evemu. Stops after --frames N, on Ctrl-C, or when the device goes away; "
            "what was recorded is kept."
        ),
    )
    w.add_argument("device", help="/dev/input/eventN")
    w.add_argument("output", help="file to write (.yml/.yaml: libinput record; else evemu)")
    w.add_argument(
        "--frames", type=positive_int, metavar="N", help="stop after N SYN_REPORT frames"
    )
    w.add_argument("--grab", action="store_true", help="take the device exclusively")
    w.set_defaults(func=_record)

    s = evsub.add_parser(
        "describe",
        help="what stiction makes of a device or recording: kind, axes, size",
    )
    s.add_argument("source", help="/dev/input/eventN or a recording")
    s.add_argument("events", nargs="?", help="evemu events file when separate")
    s.add_argument("--json", action="store_true")
    s.set_defaults(func=_describe)


def frame_json(units: Any, frame: Any) -> dict[str, Any]:
    return {"time": frame.time, "contacts": [units.contact_json(c) for c in frame.contacts]}


def _frame_text(units: Any, frame: Any) -> str:
    parts = []
    for c in frame.contacts:
        j = units.contact_json(c)
        pos = f"{j['x']},{j['y']}"
        if j["x_m"] is not None:
            pos += f" ({j['x_m'] * 1000:.2f},{j['y_m'] * 1000:.2f} mm)"
        p = "" if j["pressure"] is None else f" p={j['pressure']:.3f}"
        state = "tip" if j["tip"] else "hover"
        parts.append(f"#{c.id} {c.tool.value} {state} {pos}{p}")
    for c in frame.ended:
        parts.append(f"#{c.id} ended")
    return f"{frame.time:.6f}  " + ("; ".join(parts) if parts else "-")


def _emit(frames: Iterable[Any], units: Any, as_json: bool, out: TextIO) -> int:
    n = 0
    for frame in frames:
        if as_json:
            out.write(json.dumps(frame_json(units, frame)) + "\n")
        else:
            out.write(_frame_text(units, frame) + "\n")
        n += 1
        if n % 64 == 0:
            out.flush()
    out.flush()
    return n


def _paced(frames: Iterable[Any], realtime: bool) -> Iterator[Any]:
    start: tuple[float, float] | None = None
    for f in frames:
        if realtime:
            if start is None:
                start = (time.monotonic(), f.time)
            delay = start[0] + (f.time - start[1]) - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        yield f


def _decode(args: argparse.Namespace) -> int:
    from stiction.drivers.evdev import sizes
    from stiction.drivers.evdev.frames import FrameAssembler
    from stiction.drivers.evdev.recording import load
    from stiction.drivers.evdev.units import SurfaceUnits

    rec = load(args.recording, args.events, args.index)
    desc = sizes.apply(rec.description, args.size)
    asm = FrameAssembler(desc)

    def frames() -> Iterator[Any]:
        feed = asm.feed
        for s, u, t, c, v in rec.events:
            f = feed(s, u, t, c, v)
            if f is not None:
                yield f

    _emit(_paced(frames(), args.realtime), SurfaceUnits(desc), args.json, sys.stdout)
    if args.stats:
        print(json.dumps(dict(asm.stats)), file=sys.stderr)
    return 0


def _read(args: argparse.Namespace) -> int:
    import itertools

    from stiction.drivers.evdev.device import DeviceSource

    src = DeviceSource(args.device, grab=args.grab, size_mm=args.size, require_size=False)
    try:
        frames: Iterable[Any] = src.frames()
        if args.frames is not None:
            frames = itertools.islice(frames, args.frames)
        _emit(frames, src._units, args.json, sys.stdout)
    finally:
        src.close()
        if args.stats:
            print(json.dumps(src.stats()), file=sys.stderr)
    return 0


def _describe(args: argparse.Namespace) -> int:
    from stiction.drivers.evdev import sizes
    from stiction.drivers.evdev.units import SurfaceUnits

    if args.source.startswith("/dev/"):
        from stiction.drivers.evdev.device import _open, _udev_properties, describe

        dev = _open(args.source)
        try:
            desc = describe(dev, _udev_properties(args.source))
        finally:
            dev.close()
    else:
        from stiction.drivers.evdev.recording import load

        desc = load(args.source, args.events).description
    fixed = sizes.apply(desc)
    problem: str | None = None
    try:
        sizes.require(fixed)
    except StictionError as exc:
        problem = str(exc)
    # a node no size can fix has none, whatever its axes multiply to (an inverted
    # range with a resolution gave a negative width)
    size = SurfaceUnits(fixed).surface_size if problem is None else None
    info = {
        "name": desc.name,
        "id": [desc.bustype, desc.vendor, desc.product, desc.version],
        "kind": desc.kind,
        "multitouch_slots": desc.num_slots,
        "size_m": list(size) if size else None,
        "size_source": (
            None
            if size is None
            else "kernel"
            if SurfaceUnits(desc).resolution_known
            else "device table"
        ),
        "axes": {
            _abs_name(code): [a.minimum, a.maximum, a.resolution] for code, a in desc.axes.items()
        },
        "problem": problem,
    }
    if args.json:
        print(json.dumps(info))
    else:
        for k, v in info.items():
            if k != "problem":
                print(f"{k}: {v}")
        if problem is not None:
            print(f"note: {problem}")
    return 0


def _abs_name(code: int) -> str:
    from evdev import ecodes

    name = ecodes.ABS.get(code, str(code))
    return name[0] if isinstance(name, list) else str(name)


def _record(args: argparse.Namespace) -> int:
    from pathlib import Path

    from stiction.drivers.evdev import evemu, libinput_record
    from stiction.drivers.evdev.device import DeviceGone, DeviceSource

    out_path = Path(args.output)
    yaml_out = out_path.suffix in (".yml", ".yaml")
    src = DeviceSource(args.device, grab=args.grab, require_size=False)
    frames = 0
    events = 0
    try:
        with open(out_path, "w", encoding="utf-8") as out:
            desc = src.description
            head = libinput_record.header(desc, args.device) if yaml_out else evemu.describe(desc)
            out.write(head)
            frame: list[tuple[int, int, int, int, int]] = []
            try:
                for batch in src.batches():
                    for ev in batch:
                        frame.append(ev)
                        if ev[2] == 0 and ev[3] == 0:  # SYN_REPORT: the frame is whole
                            out.write(
                                libinput_record.frame_text(frame)
                                if yaml_out
                                else evemu.write_events(frame)
                            )
                            out.flush()
                            events += len(frame)
                            frame = []
                            frames += 1
                            if args.frames is not None and frames >= args.frames:
                                return 0
            except KeyboardInterrupt:
                pass
            except DeviceGone as exc:
                print(f"stiction: {exc}; recording kept", file=sys.stderr)
    finally:
        src.close()
        print(f"{events} events, {frames} frames written to {out_path}", file=sys.stderr)
    return 0

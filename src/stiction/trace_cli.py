"""`stiction trace`: any recording (or synthetic stroke) -> the trace CSV `simulate` reads.

A command-line module on top of the packages: it opens the recording with the
same driver factories the daemon uses for ``replay:`` and ``synthetic:``
devices (so a trace holds exactly the samples the daemon would have had), or
reads the touch positions of a ``stiction record`` .npz, and writes
``t,x,y,contact,pressure`` rows in seconds and surface metres.
"""

from __future__ import annotations

import argparse
import csv
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any, TextIO

from stiction.argtypes import SIZE_MM_FLAG, size_mm


def register(sub: argparse._SubParsersAction[Any]) -> None:
    p = sub.add_parser(
        "trace",
        help="turn a recording into a trace CSV for `stiction simulate`",
        description=(
            "Write the samples of one contact of a recording as a trace CSV "
            "(t,x,y,contact,pressure; seconds and surface metres; contact 1 while touching). "
            "SOURCE is a hid-recorder .hid file, an evemu recording (.evemu, or .desc with "
            "its .events file as EVENTS), a `libinput record` YAML file, a `stiction record` "
            ".npz, or synthetic:NAME (stroke, circles, demo)."
        ),
    )
    p.add_argument("source", metavar="SOURCE")
    p.add_argument("events", nargs="?", metavar="EVENTS", help="the .events file of a .desc")
    p.add_argument("--out", required=True, metavar="TRACE.csv", help="output CSV ('-' = stdout)")
    p.add_argument(
        "--contact",
        type=int,
        default=None,
        metavar="ID",
        help="which contact (default: the first one that appears)",
    )
    p.add_argument("--device", default=None, help="for an .npz: which device (default: the first)")
    p.add_argument(
        "--size-mm",
        type=size_mm,
        metavar="WxH",
        help="the active area in mm, when the recording does not give it",
    )
    p.add_argument("--force", action="store_true", help="replace OUT if it exists")
    p.set_defaults(func=_trace, size_how=SIZE_MM_FLAG)


Row = tuple[float, float, float, int, float | None]


def _rows_from_source(args: argparse.Namespace) -> Iterator[Row]:
    """(t, x, y, touching, pressure) of one contact, from a device replay or a synthetic stroke."""
    from stiction.daemon.devices import DeviceConfig, open_source, parse_spec
    from stiction.errors import RecordingError

    src = args.source
    spec_text = src if src.startswith("synthetic:") else f"replay:{src}"
    if args.events:
        spec_text += f",{args.events}"
    size = tuple(v / 1e3 for v in args.size_mm) if args.size_mm else None
    spec = parse_spec(spec_text)
    if spec.kind == "replay" and not Path(spec.target).exists():
        raise RecordingError(f"no such recording: {spec.target}")
    source = open_source(
        spec, DeviceConfig(spec_text, surface_size=size), False, False, size_how=SIZE_MM_FLAG
    )
    want = args.contact
    try:
        for s in source.samples():
            if want is None:
                want = s.contact
            if s.contact == want:
                yield s.t, s.x, s.y, int(s.tip), s.pressure
    finally:
        source.close()


def _rows_from_npz(args: argparse.Namespace) -> Iterator[Row]:
    from stiction.clients.recording import read
    from stiction.errors import RecordingError

    rec = read(args.source)
    device, want = args.device, args.contact
    found = False
    for frame in rec.frames():
        if device is None:
            device = frame.device
        if frame.device != device:
            continue
        for c in frame.contacts:
            if want is None:
                want = c.id
            if c.id == want:
                found = True
                touching = int(c.phase in ("stick", "slip"))
                yield frame.t, c.touch_m[0], c.touch_m[1], touching, None
    if not found:
        raise RecordingError(f"{args.source}: no frames of device {device!r} with contact {want!r}")


def _write(rows: Iterator[Row], f: TextIO) -> int:
    w = csv.writer(f, lineterminator="\n")
    w.writerow(("t", "x", "y", "contact", "pressure"))
    n = 0
    for t, x, y, c, p in rows:
        w.writerow((repr(t), repr(x), repr(y), c, "" if p is None else repr(p)))
        n += 1
    return n


def _trace(args: argparse.Namespace) -> int:
    from stiction.errors import RecordingError

    rows = _rows_from_npz(args) if args.source.endswith(".npz") else _rows_from_source(args)
    if args.out == "-":
        n = _write(rows, sys.stdout)
    else:
        out = Path(args.out)
        if out.exists() and not args.force:
            raise RecordingError(f"{out} exists; pass --force to replace it")
        tmp = out.with_name(out.name + ".part")
        try:
            with tmp.open("w", encoding="utf-8", newline="") as f:
                n = _write(rows, f)
            tmp.replace(out)
        finally:
            tmp.unlink(missing_ok=True)
    if n == 0:
        raise RecordingError(f"{args.source}: no samples of the chosen contact")
    print(f"wrote {n} samples to {args.out}", file=sys.stderr)
    return 0

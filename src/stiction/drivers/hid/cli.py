"""`stiction hid describe` and `stiction hid decode` (formats in docs/design/architecture.md)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from stiction.argtypes import SIZE_MM_FLAG, add_size_mm_option, non_negative_int, seconds_or_zero
from stiction.errors import SizeUnknown, StictionError


def _usb_string(text: str) -> tuple[int, str]:
    """INDEX=TEXT: a USB string descriptor the recording does not hold, for catalogue matches."""
    index, sep, value = text.partition("=")
    try:
        i = int(index)
    except ValueError:
        i = -1
    if not sep or not 0 <= i <= 255:
        raise argparse.ArgumentTypeError(
            f"{text!r}: give a USB string as INDEX=TEXT, INDEX 0..255 (e.g. 201=HUION_T194_230101)"
        )
    return i, value


def _json_int(v: int) -> int | str:
    """Values beyond 64 bits (vendor blobs read as one field) print as hex strings."""
    return v if -(1 << 63) <= v < (1 << 64) else hex(v)


def _field_json(f: Any) -> dict[str, Any]:
    from stiction.drivers.hid.usages import usage_hex, usage_name

    return {
        "usage": f.usage,
        "usage_hex": usage_hex(f.usage),
        "usage_name": usage_name(f.usage),
        "bit_offset": f.bit_offset,
        "bit_size": f.bit_size,
        "count": f.count,
        "logical_min": f.logical_min,
        "logical_max": f.logical_max,
        "physical_min": f.physical_min,
        "physical_max": f.physical_max,
        "unit": f.unit,
        "unit_exponent": f.unit_exponent,
        "variable": f.variable,
        "constant": f.constant,
        "relative": f.relative,
    }


def _describe(args: argparse.Namespace) -> int:
    from stiction.drivers.hid.descriptor import parse_descriptor
    from stiction.drivers.hid.facts import describe_device
    from stiction.drivers.hid.recording import load_recording
    from stiction.drivers.hid.units import unit_name
    from stiction.drivers.hid.usages import usage_name

    rec = load_recording(args.file)
    desc = parse_descriptor(rec.descriptor)
    reports = sorted(desc.input_reports.values(), key=lambda r: r.report_id)
    strings = dict(args.usb_string) if args.usb_string else None
    facts = describe_device(rec.vid, rec.pid, rec.name, rec.descriptor, strings=strings)
    if args.json:
        out = {
            "device": facts.as_json(),
            "input_reports": [
                {
                    "report_id": r.report_id,
                    "bit_size": r.bit_size,
                    "fields": [_field_json(f) for f in r.fields],
                }
                for r in reports
            ],
        }
        print(json.dumps(out))
        return 0
    print(f"{rec.name} ({rec.vid:04x}:{rec.pid:04x}), descriptor {len(rec.descriptor)} bytes")
    print(facts.as_text())
    for r in reports:
        print(
            f"input report {r.report_id}: {r.bit_size} bits, application "
            f"0x{r.application:08x} ({usage_name(r.application)})"
        )
        for f in r.fields:
            kind = "const" if f.constant else ("var" if f.variable else "array")
            unit = unit_name(f.unit)
            print(
                f"  bit {f.bit_offset:4d} +{f.bit_size:<3d} x{f.count:<3d}"
                f" 0x{f.usage:08x} {kind:5s}"
                f" logical {f.logical_min}..{f.logical_max}"
                f" physical {f.physical_min}..{f.physical_max} unit {unit} exp {f.unit_exponent}"
                f"  {usage_name(f.usage)}"
            )
    return 0


def _decode(args: argparse.Namespace) -> int:
    from stiction.drivers.hid.decoder import ReportDecoder
    from stiction.drivers.hid.descriptor import parse_descriptor
    from stiction.drivers.hid.devices import lookup
    from stiction.drivers.hid.recording import load_recording
    from stiction.drivers.hid.stream import ReportStream
    from stiction.drivers.hid.usages import usage_name

    rec = load_recording(args.file)
    desc = parse_descriptor(rec.descriptor)
    decoders = {rid: ReportDecoder(r) for rid, r in desc.input_reports.items()}
    stream: ReportStream | None
    try:
        entry = lookup(rec.vid, rec.pid, None, rec.name or None, descriptor=rec.descriptor)
        stream = ReportStream(desc, rec.name or args.file, args.size, entry)
    except StictionError as exc:
        if isinstance(exc, SizeUnknown):
            exc = exc.told(SIZE_MM_FLAG)
        print(f'stiction: warning: {exc}; printing "contacts": null', file=sys.stderr)
        stream = None
    for ev in rec.events:
        rid = ev.data[0] if desc.numbered and ev.data else 0
        dec = decoders.get(rid)
        obj: dict[str, Any] = {"time": ev.t, "report_id": rid}
        if dec is None or len(ev.data) < dec.byte_size:
            obj["error"] = (
                "unknown report id" if dec is None else f"short report ({len(ev.data)} bytes)"
            )
            obj["fields"] = {}
        else:
            values = dec.values(ev.data)
            obj["fields"] = {f"0x{u:08x}": [_json_int(x) for x in v] for u, v in values.items()}
            obj["names"] = {f"0x{u:08x}": usage_name(u) for u in values}
        if stream is None:
            obj["contacts"] = None
        else:
            obj["contacts"] = [
                {k: v for k, v in _sample_json(s).items() if k != "t"}
                for s in stream.feed(ev.t, ev.data)
            ]
        if args.json:
            print(json.dumps(obj))
        else:
            names = obj.get("names", {})
            fields = " ".join(
                f"{names.get(k, k).split(' / ', 1)[-1]}={v[0] if len(v) == 1 else v}"
                for k, v in obj["fields"].items()
            )
            print(f"{ev.t:.6f} report {rid}: {fields}")
    return 0


def _sample_json(s: Any) -> dict[str, Any]:
    return {
        "t": s.t,
        "contact": s.contact,
        "x": s.x,
        "y": s.y,
        "tip": s.tip,
        "in_range": s.in_range,
        "pressure": s.pressure,
        "tool": s.tool.value,
        "tilt_x": s.tilt_x,
        "tilt_y": s.tilt_y,
        "buttons": s.buttons,
    }


def _read(args: argparse.Namespace) -> int:
    from stiction.drivers.hid import open_hidraw

    src = open_hidraw(args.device, size_m=args.size)
    size = src.surface_size
    area = f"{size[0] * 1000:.1f} x {size[1] * 1000:.1f} mm" if size else "unknown size"
    print(f"# {src.name}: {src.kind}, {area}", file=sys.stderr)
    n = 0
    try:
        for s in src.samples():
            if args.json:
                print(json.dumps(_sample_json(s)), flush=True)
            else:
                state = "tip" if s.tip else ("hover" if s.in_range else "out")
                pressure = "-" if s.pressure is None else f"{s.pressure:.3f}"
                print(
                    f"{s.t:.4f} contact {s.contact} {state:5s} x {s.x * 1000:8.3f} mm"
                    f" y {s.y * 1000:8.3f} mm pressure {pressure} {s.tool.value}",
                    flush=True,
                )
            n += 1
            if args.count and n >= args.count:
                break
    finally:
        src.close()
        print(f"# {src.stats()}", file=sys.stderr)
    return 0


def _record(args: argparse.Namespace) -> int:
    from stiction.drivers.hid.record import record

    n = record(args.device, sys.stdout, count=args.count, seconds=args.seconds)
    print(f"# {n} reports recorded", file=sys.stderr)
    return 0


def register(sub: argparse._SubParsersAction[Any]) -> None:
    hid = sub.add_parser("hid", help="inspect HID report descriptors and recordings")
    hsub = hid.add_subparsers(dest="hid_command", metavar="SUBCOMMAND", required=True)
    d = hsub.add_parser("describe", help="the fields of every input report of a .hid file")
    d.add_argument("file", help="hid-recorder file (N:, I:, R:, E: lines)")
    d.add_argument("--json", action="store_true", help="machine-readable output")
    d.add_argument(
        "--usb-string",
        type=_usb_string,
        action="append",
        metavar="INDEX=TEXT",
        help="a USB string descriptor of the device (`lsusb -v`), so that catalogue entries "
        "telling models apart by it apply; repeatable",
    )
    d.set_defaults(func=_describe)
    e = hsub.add_parser("decode", help="decode every recorded report of a .hid file")
    e.add_argument("file", help="hid-recorder file (N:, I:, R:, E: lines)")
    e.add_argument("--json", action="store_true", help="one JSON object per report")
    add_size_mm_option(e, metres=True, when="when the descriptor and catalogue lack it")
    e.set_defaults(func=_decode)
    r = hsub.add_parser("read", help="print the pen/touch samples of a live hidraw device")
    r.add_argument("device", help="/dev/hidrawN, or vid:pid (e.g. 28bd:0907)")
    r.add_argument("--json", action="store_true", help="one JSON object per sample")
    r.add_argument(
        "--count", type=non_negative_int, default=0, help="stop after N samples (0: never)"
    )
    add_size_mm_option(r, metres=True, when="when the descriptor and catalogue lack it")
    r.set_defaults(func=_read)
    rec = hsub.add_parser(
        "record",
        help="write a live device's descriptor and reports in hid-recorder format",
        description="Record a hidraw device to stdout (N:, I:, R:, E: lines) until Ctrl-C, "
        "--count reports or --seconds.",
    )
    rec.add_argument("device", help="/dev/hidrawN, or vid:pid")
    rec.add_argument(
        "--count", type=non_negative_int, default=0, help="stop after N reports (0: never)"
    )
    rec.add_argument(
        "--seconds", type=seconds_or_zero, default=0.0, help="stop after S seconds (0: never)"
    )
    rec.set_defaults(func=_record)

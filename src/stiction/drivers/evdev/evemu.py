"""Reader for evemu recordings (evemu-describe / evemu-record output).

Formats 1.0 to 1.3 (https://www.freedesktop.org/wiki/Evemu/): `N:` name,
`I:` ids in hex, `P:` property bytes, `B: <type> <bytes>` capability bitmasks
(several lines per type, concatenated, little-endian bit order), `A: <code>
min max fuzz flat [resolution]`, `E: <sec>.<usec> <type> <code> <value>`.
The current axis values are not in `A:` lines; evemu-describe writes them in
the `# Event code ... / #   Value N` comment block, which is read when present.

Events are kept as plain tuples (sec, usec, type, code, value) because they
are the hot path of replay and of the benchmark.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from stiction.drivers.evdev.description import EV_ABS, EV_KEY, EV_SYN, AbsAxis, DeviceDescription
from stiction.drivers.limits import read_text
from stiction.errors import RecordingError
from stiction.userfiles import shown

Event = tuple[int, int, int, int, int]

_VALUE_BLOCK = re.compile(r"#\s+Event code (\d+) \(")
_VALUE_LINE = re.compile(r"#\s+Value\s+(-?\d+)")
_TYPE_BLOCK = re.compile(r"#\s+Event type (\d+) \(")


@dataclass
class EvemuFile:
    """What one evemu file held: a description, events, or both."""

    description: DeviceDescription | None
    events: list[Event]


def _bits(data: bytes) -> frozenset[int]:
    return frozenset(i * 8 + b for i, byte in enumerate(data) for b in range(8) if byte >> b & 1)


def _fail(path: Path, lineno: int, why: str) -> RecordingError:
    return RecordingError(f"{path}:{lineno}: {why}")


def parse_event_time(field: str) -> tuple[int, int]:
    """`sec.usec` as evemu writes and reads it: the usec part is decimal microseconds.

    evemu reads it with ``%lu.%06u`` so ``0.1932`` means 1932 us, not 0.1932 s.
    """
    sec_s, dot, usec_s = field.partition(".")
    if not dot or not sec_s.isdigit() or not usec_s.isdigit():
        raise ValueError(f"bad event time {field!r}")
    usec = int(usec_s, 10)
    if usec >= 1_000_000:
        raise ValueError(f"event time {field!r} has microseconds >= 1000000")
    return int(sec_s, 10), usec


def parse(path: Path, text: str | None = None) -> EvemuFile:
    """Parse an evemu file; malformed lines raise RecordingError naming file and line."""
    if text is None:
        text = read_text(path)
    name: str | None = None
    ids = (0, 0, 0, 0)
    props: frozenset[int] = frozenset()
    masks: dict[int, bytearray] = {}
    absinfo: dict[int, tuple[int, int, int, int, int]] = {}
    values: dict[int, int] = {}
    events: list[Event] = []
    in_abs_block = False
    pending_code: int | None = None
    has_description = False
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            m = _TYPE_BLOCK.match(line)
            if m:
                in_abs_block = int(m.group(1)) == EV_ABS
                pending_code = None
                continue
            if in_abs_block:
                m = _VALUE_BLOCK.match(line)
                if m:
                    pending_code = int(m.group(1))
                    continue
                m = _VALUE_LINE.match(line)
                if m and pending_code is not None:
                    values[pending_code] = int(m.group(1))
                    pending_code = None
            continue
        tag, _, rest = line.partition(":")
        fields = rest.split("#", 1)[0].split()
        try:
            if tag == "E":
                if len(fields) != 4:
                    raise ValueError("an event needs time, type, code and value")
                sec, usec = parse_event_time(fields[0])
                if events and (sec, usec) < events[-1][:2]:
                    last_sec, last_usec = events[-1][:2]
                    raise ValueError(
                        f"time {sec}.{usec:06d} runs backwards (after {last_sec}.{last_usec:06d})"
                    )
                ev_type, code, value = int(fields[1], 16), int(fields[2], 16), int(fields[3], 10)
                if not (0 <= ev_type <= 0x1F and 0 <= code <= 0x2FF):
                    raise ValueError(f"type {ev_type:#x} / code {code:#x} out of range")
                if not -(2**31) <= value < 2**31:
                    raise ValueError(f"value {value} does not fit a 32-bit int")
                events.append((sec, usec, ev_type, code, value))
            elif tag == "N":
                name = rest.strip()
                has_description = True
            elif tag == "I":
                if len(fields) != 4:
                    raise ValueError("I: needs bus, vendor, product, version")
                b, v, p, ver = (int(f, 16) for f in fields)
                ids = (b, v, p, ver)
            elif tag == "P":
                props = props | _bits(bytes(int(f, 16) for f in fields))
            elif tag == "B":
                if not fields:
                    raise ValueError("B: needs a type")
                ev_type = int(fields[0], 16)
                masks.setdefault(ev_type, bytearray()).extend(int(f, 16) for f in fields[1:])
            elif tag == "A":
                if len(fields) not in (5, 6):
                    raise ValueError("A: needs code min max fuzz flat [resolution]")
                code = int(fields[0], 16)
                mn, mx, fuzz, flat = (int(f, 10) for f in fields[1:5])
                res = int(fields[5], 10) if len(fields) == 6 else 0
                absinfo[code] = (mn, mx, fuzz, flat, res)
            else:
                raise ValueError(f"unknown line type {tag!r}")
        except ValueError as exc:
            # The reason may quote the line too (an unknown tag is the whole line): bounded.
            raise _fail(path, lineno, f"{shown(exc)} in {raw.strip()[:80]!r}") from None
    if not has_description and (masks or absinfo):
        raise RecordingError(f"{path}: capability lines but no 'N:' device name line")
    if not has_description:
        return EvemuFile(None, events)
    assert name is not None
    keys = _bits(bytes(masks.get(EV_KEY, b"")))
    abs_codes = _bits(bytes(masks.get(EV_ABS, b""))) | frozenset(absinfo)
    axes: dict[int, AbsAxis] = {}
    for code in sorted(abs_codes):
        mn, mx, fuzz, flat, res = absinfo.get(code, (0, 0, 0, 0, 0))
        axes[code] = AbsAxis(values.get(code, 0), mn, mx, fuzz, flat, res)
    other = {
        t: _bits(bytes(m)) for t, m in masks.items() if t not in (EV_SYN, EV_KEY, EV_ABS) and any(m)
    }
    desc = DeviceDescription(
        name=name,
        bustype=ids[0],
        vendor=ids[1],
        product=ids[2],
        version=ids[3],
        properties=props,
        keys=keys,
        axes=axes,
        other=other,
    )
    return EvemuFile(desc, events)


def write_events(events: list[Event]) -> str:
    """evemu `E:` lines with microseconds written without leading zeros.

    Both evemu (``%06u``) and umockdev read these correctly; umockdev reads a
    zero-padded usec field as octal (see docs/design/umockdev-evdev.md).
    """
    return "".join(f"E: {s}.{u} {t:04x} {c:04x} {v}\n" for s, u, t, c, v in events)


def _mask_lines(ev_type: int, bits: frozenset[int] | set[int]) -> list[str]:
    size = max(8, (max(bits) // 64 + 1) * 8) if bits else 8
    data = bytearray(size)
    for b in bits:
        data[b // 8] |= 1 << (b % 8)
    return [
        f"B: {ev_type:02x} " + " ".join(f"{x:02x}" for x in data[i : i + 8])
        for i in range(0, size, 8)
    ]


def describe(desc: DeviceDescription) -> str:
    """An evemu 1.3 description (what evemu-describe prints), readable by parse()."""
    props = bytearray(8)
    for p in desc.properties:
        if p < 64:
            props[p // 8] |= 1 << (p % 8)
    lines = [
        "# EVEMU 1.3",
        f"# Input device name: {desc.name!r}",
        f"N: {desc.name}",
        f"I: {desc.bustype:04x} {desc.vendor:04x} {desc.product:04x} {desc.version:04x}",
        "P: " + " ".join(f"{x:02x}" for x in props),
        *_mask_lines(EV_SYN, {0, 1, 3}),
        *_mask_lines(EV_KEY, desc.keys),
        *_mask_lines(EV_ABS, frozenset(desc.axes)),
        *(line for t, c in sorted(desc.other.items()) for line in _mask_lines(t, c)),
    ]
    for code, a in sorted(desc.axes.items()):
        lines.append(f"A: {code:02x} {a.minimum} {a.maximum} {a.fuzz} {a.flat} {int(a.resolution)}")
    return "\n".join(lines) + "\n"

"""Read and write the hid-recorder text format (N:, I:, R:, E: lines).

This is the format of hid-tools' `hid-recorder` and of shared/data/hid: a
device name, its bus/vendor/product, its report descriptor in hex and one
`E: <sec.usec> <length> <hex bytes>` line per input report. Only the first
device of a multi-device file is read (hid-recorder writes `D: <n>` lines to
separate them; stiction reads one hidraw node at a time).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from stiction.drivers.limits import TimeCheck, read_text
from stiction.errors import RecordingError


@dataclass(frozen=True, slots=True)
class Event:
    """One input report as read from hidraw, with its recorded time in seconds."""

    t: float
    data: bytes


@dataclass(slots=True)
class Recording:
    name: str
    bus: int
    vid: int
    pid: int
    descriptor: bytes
    events: list[Event] = field(default_factory=list)
    source: str = ""


def _hex_bytes(tokens: list[str], where: str) -> bytes:
    try:
        return bytes(int(tok, 16) for tok in tokens)
    except ValueError as exc:
        raise RecordingError(f"{where}: not a list of hex bytes ({exc})") from None


def parse_recording(text: str, source: str = "<recording>") -> Recording:
    name = ""
    bus = vid = pid = 0
    descriptor: bytes | None = None
    events: list[Event] = []
    device_index = 0
    check_time = TimeCheck()
    for lineno, raw in enumerate(text.splitlines(), 1):
        line = raw.strip()
        if not line or line.startswith("#"):
            continue
        where = f"{source}:{lineno}"
        tag, _, rest = line.partition(":")
        rest = rest.strip()
        if tag == "D":
            device_index += 1
            if device_index > 1:
                break
            continue
        if tag == "N":
            name = rest
        elif tag == "I":
            parts = rest.split()
            if len(parts) != 3:
                raise RecordingError(f"{where}: I: needs bus, vendor and product in hex")
            try:
                bus, vid, pid = (int(p, 16) for p in parts)
            except ValueError:
                raise RecordingError(f"{where}: I: values are not hex numbers") from None
        elif tag == "R":
            parts = rest.split()
            if not parts:
                raise RecordingError(f"{where}: R: line is empty")
            try:
                length = int(parts[0])
            except ValueError:
                raise RecordingError(f"{where}: R: must start with the length") from None
            descriptor = _hex_bytes(parts[1:], where)
            if len(descriptor) != length:
                raise RecordingError(
                    f"{where}: R: says {length} bytes but carries {len(descriptor)}"
                )
        elif tag == "E":
            parts = rest.split()
            if len(parts) < 2:
                raise RecordingError(f"{where}: E: needs a time and a length")
            try:
                t = float(parts[0])
                length = int(parts[1])
            except ValueError:
                raise RecordingError(f"{where}: E: time or length is not a number") from None
            check_time(t, where)
            data = _hex_bytes(parts[2:], where)
            if len(data) != length:
                raise RecordingError(f"{where}: E: says {length} bytes but carries {len(data)}")
            events.append(Event(t, data))
        # other tags (P: physical path, S: ...) carry nothing needed here
    if descriptor is None:
        raise RecordingError(f"{source}: no R: line (report descriptor) found")
    return Recording(name, bus, vid, pid, descriptor, events, source)


def load_recording(path: str | Path) -> Recording:
    p = Path(path)
    return parse_recording(read_text(p), str(p))


def format_recording(rec: Recording) -> Iterator[str]:
    """The lines of a hid-recorder file for `rec` (used to write synthetic recordings)."""
    yield f"N: {rec.name}"
    yield f"I: {rec.bus:x} {rec.vid:04x} {rec.pid:04x}"
    yield f"R: {len(rec.descriptor)} {rec.descriptor.hex(' ')}"
    for ev in rec.events:
        yield format_event(ev)


def format_event(ev: Event) -> str:
    """One `E: <sec>.<usec> <length> <hex bytes>` line."""
    sec = int(ev.t)
    usec = round((ev.t - sec) * 1e6)
    if usec == 1_000_000:
        sec, usec = sec + 1, 0
    return f"E: {sec:06d}.{usec:06d} {len(ev.data)} {ev.data.hex(' ')}"

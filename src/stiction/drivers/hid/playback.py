"""Replay of hid-recorder files: a recorded device, report by report."""

from __future__ import annotations

from pathlib import Path

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.devices import lookup
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.report_source import ReportSource
from stiction.drivers.hid.stream import ReportStream


def open_replay(
    path: str | Path,
    realtime: bool = False,
    size_m: tuple[float, float] | None = None,
) -> ReportSource:
    """A SampleSource over the E: lines of `path`, with its own descriptor and device table entry.

    The device table's entry applies as it does live: its replacement
    descriptor (a vendor report family's generated one, say) and its size.
    """
    rec = load_recording(path)
    entry = lookup(rec.vid, rec.pid, None, rec.name or None, descriptor=rec.descriptor)
    label = f"{rec.name or Path(path).name} ({rec.vid:04x}:{rec.pid:04x}, {path})"
    stream = ReportStream(parse_descriptor(rec.descriptor), label, size_m, entry)
    events = [(ev.t, ev.data) for ev in rec.events]
    return ReportSource(f"replay-{Path(path).stem}", stream, events, realtime, compress_gaps=True)

"""Record a live hidraw device in the hid-recorder text format.

So that a user can send in, or replay, exactly what their tablet sends:
the file is what `stiction hid decode`, `replay:` specs and the tests read,
and what hid-tools' own hid-recorder writes (N:, I:, R:, E: lines; times
from the first report).
"""

from __future__ import annotations

import time
from typing import TextIO

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.hidraw_backend import (
    HidrawReader,
    bus_of,
    open_handle,
    read_descriptor,
    resolve,
)
from stiction.drivers.hid.recording import Event, Recording, format_event, format_recording
from stiction.errors import DescriptorError

MAX_REPORT = 16384


def record(
    path_or_vidpid: str,
    out: TextIO,
    count: int = 0,
    seconds: float = 0.0,
) -> int:
    """Write the device header, then one E: line per report until `count`/`seconds`/unplug.

    Returns the number of reports written. Stops cleanly on Ctrl-C.
    """
    path, vid, pid, product = resolve(path_or_vidpid)
    dev = open_handle(path)
    label = f"{product or 'hid device'} ({vid:04x}:{pid:04x})"
    try:
        descriptor = read_descriptor(dev, path)
    except BaseException:
        dev.close()
        raise
    rec = Recording(product, bus_of(path), vid, pid, descriptor)
    # hidraw returns one report per read, truncated to the size asked: ask for
    # the largest input report the descriptor declares (all of it if unparsable).
    try:
        sizes = [r.byte_size for r in parse_descriptor(descriptor).input_reports.values()]
        max_len = min(max(sizes, default=MAX_REPORT), MAX_REPORT)
    except DescriptorError:
        max_len = MAX_REPORT
    header = list(format_recording(rec))
    out.write(f"# recorded by stiction hid record from {path.decode(errors='replace')}\n")
    out.write("\n".join(header) + "\n")
    out.flush()
    reader = HidrawReader(dev, label, max_len)
    reports = iter(reader)
    n = 0
    start = time.monotonic()
    first: float | None = None
    try:
        for t, data in reports:
            if seconds and t - start >= seconds:
                break
            if data is None:
                continue
            if first is None:
                first = t
            out.write(format_event(Event(t - first, data)) + "\n")
            out.flush()
            n += 1
            if count and n >= count:
                break
    except KeyboardInterrupt:
        pass
    finally:
        reader.request_close()
        reports.close()  # type: ignore[attr-defined]  # runs the reader's finally: closes the handle
    return n

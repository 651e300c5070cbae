"""One function per parser of user-supplied input, for the fuzzer and the regression test.

Each takes raw bytes and feeds them to a parser exactly as a file or a
request would arrive. A target may raise only `StictionError` (the one error
type a user sees); anything else is a bug, which the fuzzer saves under
tests/regressions/<target>/ and tests/test_regressions.py then replays.
"""

from __future__ import annotations

import contextlib
import io
from collections.abc import Callable
from pathlib import Path


def _text(data: bytes) -> str:
    return data.decode("utf-8", errors="replace")


def hid_descriptor(data: bytes) -> None:
    """A descriptor (first bytes) and one report (the rest) through the daemon's HID path."""
    from stiction.drivers.hid.decoder import ReportDecoder
    from stiction.drivers.hid.descriptor import parse_descriptor
    from stiction.drivers.hid.stream import ReportStream

    cut = data[0] if data else 0
    raw, report = data[1 : 1 + cut], data[1 + cut :]
    desc = parse_descriptor(raw)
    for r in desc.input_reports.values():
        dec = ReportDecoder(r)
        dec.decode(bytes(dec.byte_size))
    from stiction.errors import StictionError

    try:
        stream = ReportStream(desc, "fuzz", (0.1, 0.1))
    except StictionError:
        return  # no pen in it: an answer
    stream.feed(0.0, report)


def hid_recording(data: bytes) -> None:
    from stiction.drivers.hid.recording import parse_recording

    parse_recording(_text(data), "fuzz.hid")


def evemu(data: bytes) -> None:
    from stiction.drivers.evdev import evemu as parser

    parser.parse(Path("fuzz.evemu"), _text(data))


def libinput_record(data: bytes) -> None:
    from stiction.drivers.evdev import libinput_record as parser

    parser.parse(Path("fuzz.yml"), text=_text(data))


def scene(data: bytes) -> None:
    from stiction.scene.load import parse_scene

    parse_scene(_text(data), "fuzz.toml")


def trace(data: bytes) -> None:
    from stiction.sim.trace import iter_trace

    for _ in iter_trace(io.StringIO(_text(data)), "fuzz.csv"):
        pass


def control_request(data: bytes) -> None:
    from stiction import protocol

    protocol.parse_request(data)


TARGETS: dict[str, Callable[[bytes], None]] = {
    "hid_descriptor": hid_descriptor,
    "hid_recording": hid_recording,
    "evemu": evemu,
    "libinput_record": libinput_record,
    "scene": scene,
    "trace": trace,
    "control_request": control_request,
}


def run_one(name: str, data: bytes) -> None:
    """Run a target; a StictionError is an answer, anything else propagates."""
    from stiction.errors import StictionError

    with contextlib.suppress(StictionError):
        TARGETS[name](data)

"""The synthetic tablet: scripted strokes sent as real reports of a real descriptor.

The descriptor is the UGEE M708 v2's (28bd:0907, interface 1, 245 bytes),
copied from shared/data/hid/ugee-m708-v2.hid, whose source is DIGImend/tablets
"Ugee_M708_v2/rd/original1.txt" at commit
358a148199ec598a574a603e57618e5760c6a66d (raw hardware data, usbhid-dump).
Its pen report 7 declares an active area of 253.97 x 152.37 mm (9.999 x
5.999 in at 5080 lines per inch), 8192 pressure levels and +-127 tilt, so
every sample takes the same route through the decoder as a real pen's.
"""

from __future__ import annotations

from collections.abc import Iterator

from stiction.drivers.fake.encoder import ReportEncoder
from stiction.drivers.fake.strokes import SCRIPTS, PenState, render
from stiction.drivers.hid.descriptor import ReportDescriptor, parse_descriptor
from stiction.drivers.hid.pen import (
    BARREL,
    GD_X,
    GD_Y,
    IN_RANGE,
    TIP_PRESSURE,
    TIP_SWITCH,
    X_TILT,
    Y_TILT,
)
from stiction.drivers.hid.report_source import ReportSource
from stiction.drivers.hid.stream import ReportStream
from stiction.errors import DeviceError

UGEE_M708_V2_DESCRIPTOR = bytes.fromhex(
    "05 0d 09 02 a1 01 85 07 09 20 a1 00 09 42 09 44 09 45 15 00 25 01 75 01 "
    "95 03 81 02 95 02 81 03 09 32 95 01 81 02 95 02 81 03 75 10 95 01 35 00 "
    "a4 05 01 09 30 65 13 55 0d 46 0f 27 27 6a c6 00 00 81 02 09 31 46 6f 17 "
    "27 0a 77 00 00 81 02 b4 09 30 45 00 26 ff 1f 81 42 09 3d 15 81 25 7f 75 "
    "08 95 01 81 02 09 3e 15 81 25 7f 81 02 c0 c0 05 0d 09 02 a1 01 85 08 09 "
    "20 a1 00 09 42 09 44 09 45 15 00 25 01 75 01 95 03 81 02 95 02 81 03 09 "
    "32 95 01 81 02 95 02 81 03 75 10 95 01 35 00 a4 05 01 09 30 65 13 55 0d "
    "46 0f 27 27 6a c6 00 00 81 02 09 31 46 6f 17 27 0a 77 00 00 81 02 b4 09 "
    "30 45 00 26 ff 1f 81 42 09 3d 15 81 25 7f 75 08 95 01 81 02 09 3e 15 81 "
    "25 7f 81 02 c0 c0 06 03 ff 09 00 a1 01 85 0b 15 00 26 ff 00 09 00 75 08 "
    "95 3f 81 02 c0 "
)
UGEE_M708_V2_NAME = "10 inch PenTablet"
UGEE_M708_V2_VID_PID = (0x28BD, 0x0907)
PEN_REPORT_ID = 7
LOOP_GAP_S = 0.5


def descriptor() -> ReportDescriptor:
    return parse_descriptor(UGEE_M708_V2_DESCRIPTOR)


class SyntheticTablet:
    """Encodes PenStates into report 7 of the UGEE M708 v2."""

    def __init__(self) -> None:
        self.descriptor = descriptor()
        report = self.descriptor.input_reports[PEN_REPORT_ID]
        self.encoder = ReportEncoder(report)
        x = next(f for f in report.fields if f.usage == GD_X)
        y = next(f for f in report.fields if f.usage == GD_Y)
        # 0.0254 m/in * 10^-3 * physical max
        self.size_m = (x.physical_max * 0.0254e-3, y.physical_max * 0.0254e-3)
        self.x_range = (x.logical_min, x.logical_max)
        self.y_range = (y.logical_min, y.logical_max)

    def encode(self, s: PenState) -> bytes:
        w, h = self.size_m
        (x0, x1), (y0, y1) = self.x_range, self.y_range
        p0, p1 = self.encoder.logical_range(TIP_PRESSURE)
        return self.encoder.encode(
            {
                TIP_SWITCH: int(s.tip and s.in_range),
                BARREL: 0,
                IN_RANGE: int(s.in_range),
                GD_X: x0 + round(s.x / w * (x1 - x0)),
                GD_Y: y0 + round(s.y / h * (y1 - y0)),
                TIP_PRESSURE: p0 + round(s.pressure * (p1 - p0)),
                X_TILT: round(s.tilt_x),
                Y_TILT: round(s.tilt_y),
            }
        )

    def reports(self, name: str, loop: bool) -> Iterator[tuple[float, bytes]]:
        try:
            script = SCRIPTS[name]
        except KeyError:
            known = ", ".join(sorted(SCRIPTS))
            raise DeviceError(f"unknown synthetic stroke {name!r}; known: {known}") from None
        states = render(script(*self.size_m))
        encoded = [(s.t, self.encode(s)) for s in states]
        period = (states[-1].t - states[0].t) + LOOP_GAP_S if states else LOOP_GAP_S
        offset = 0.0
        while True:
            for t, data in encoded:
                yield t + offset, data
            if not loop:
                return
            offset += period


STDIN = "stdin"
"""The name of the steered pen: states read from the daemon's standard input (feed.py)."""


def synthetic(name: str = "demo", realtime: bool = True, loop: bool = False) -> ReportSource:
    """A SampleSource playing the named script ("stroke", "circles", "demo"), or
    "stdin": pen states written by another program (stiction.drivers.fake.feed)."""
    if name == STDIN:
        return _steered(realtime)
    if name not in SCRIPTS:
        known = ", ".join(sorted(SCRIPTS))
        raise DeviceError(
            f"unknown synthetic stroke {name!r}; known: {known} (or {STDIN}: a steered pen)"
        )
    tablet = SyntheticTablet()
    stream = ReportStream(tablet.descriptor, f"synthetic {name}")
    return ReportSource(f"synthetic-{name}", stream, tablet.reports(name, loop), realtime)


def _steered(realtime: bool) -> ReportSource:
    """The pen steered through stdin. Under the real clock its samples are released
    at their time stamps' spacing from the first one, as a scripted stroke's are: the
    daemon maps a live device's times by when samples arrive, so a writer that writes
    ahead must be paced here. Under the virtual clock the time stamps are the clock."""
    import sys
    import threading

    from stiction.drivers.fake.feed import read_states

    tablet = SyntheticTablet()
    stream = ReportStream(tablet.descriptor, "synthetic stdin")
    stop = threading.Event()
    reports = ((s.t, tablet.encode(s)) for s in read_states(sys.stdin.buffer, stop))
    return ReportSource("synthetic-stdin", stream, reports, realtime=realtime, on_close=stop.set)

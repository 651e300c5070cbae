"""A vendor family's direct path against its bytes path, for every family.

ReportStream's generated feed takes a family reader's PenState straight into
the contact code (families.normal_values, report_code._family_lines). The
oracle is the path it replaced: the family's fix-up packs the PenState into
the normalised report (`families.normalise`) and that report is decoded
again, either by the generated feed (`ReportStream.use_bytes_path`) or by
ContactTracker (`ReportStream.use_tracker`, the readable statement). All
three must give the same samples (field for field, floats bit for bit),
the same counters and the same tracker state after every report, on the
real recordings that go through a family and on generated reports,
including the stateful families (wacom-intuos, wacom-bpt, wacom-pl) and
those without an in-range bit, whose contact ends in `idle`.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.devices import lookup
from stiction.drivers.hid.families import FAMILIES, NO_IN_RANGE, Geometry, descriptor, fixup
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.stream import ReportStream
from stiction.drivers.sample import PenSample

WIDE = Geometry(50800, 30480, 8191, 254.0, 152.4)
"""An XP-Pen's ranges (the catalogue's Star 03)."""
NARROW = Geometry(3250, 2320, 255, 65.0, 46.4)
"""A PenStation's: small enough that random coordinates and pressures get clamped."""
HUGE = Geometry(0x1FFFFF, 0x1FFFFF, 0x1FFFF, 300.0, 200.0)
"""Ranges beyond 16 bits (the pressure beyond the normalised report's 16)."""


def _streams(
    family: str, geom: Geometry, size_m: tuple[float, float] | None = None
) -> tuple[ReportStream, ReportStream, ReportStream]:
    """The direct path, and the two oracles on the normalised bytes (each its own reader:
    some families keep state)."""
    desc = parse_descriptor(descriptor(geom))
    direct, generated, tracker = (
        ReportStream(desc, family, size_m, None, fixup(family, geom)) for _ in range(3)
    )
    generated.use_bytes_path()  # fix-up to bytes, then the generated feed decodes them
    tracker.use_tracker()  # fix-up to bytes, then ContactTracker
    assert "pen = read(d)" in getattr(direct.feed, "source", ""), "the direct path is not used"
    return direct, generated, tracker


def _same_samples(a: list[PenSample], b: list[PenSample]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert type(x) is PenSample and x == y
        for f in ("t", "x", "y", "pressure", "tilt_x", "tilt_y", "tip", "in_range", "buttons"):
            assert type(getattr(x, f)) is type(getattr(y, f)), f


def _same_state(a: ReportStream, b: ReportStream) -> None:
    assert a.stats == b.stats
    assert a.tracker.active == b.tracker.active
    assert a.tracker.last == b.tracker.last


def _run(
    streams: tuple[ReportStream, ReportStream, ReportStream],
    reports: list[tuple[float, bytes]],
    idle_every: int = 0,
) -> int:
    """Feed all three; `idle_every` > 0 also calls `idle` after every so many reports.

    Returns how many samples the direct path made."""
    direct, *oracles = streams
    made = 0
    for k, (t, data) in enumerate(reports):
        got = direct.feed(t, data)
        made += len(got)
        for o in oracles:
            _same_samples(got, o.feed(t, data))
            _same_state(direct, o)
        if idle_every and k % idle_every == idle_every - 1:
            late = t + 0.5
            gone = direct.idle(late)
            for o in oracles:
                _same_samples(gone, o.idle(late))
                _same_state(direct, o)
    return made


def _family_recordings(hid_data: Path) -> list[str]:
    """The recordings with reports whose catalogue entry names a family."""
    names = []
    for p in sorted(hid_data.glob("*.hid")):
        rec = load_recording(p)
        entry = lookup(rec.vid, rec.pid)
        if rec.events and entry is not None and entry.family:
            names.append(p.stem)
    return names


def test_the_recordings_that_go_through_a_family_are_there(hid_data: Path) -> None:
    assert _family_recordings(hid_data) == ["ugee-m708-v2", "wacom-penpartner", "xp-pen-deco-03"]


@pytest.mark.parametrize("name", ["ugee-m708-v2", "wacom-penpartner", "xp-pen-deco-03"])
def test_a_recording_through_its_catalogue_family(name: str, hid_data: Path) -> None:
    """Streams built from the entry of the recording's id, as ReportStream builds them.

    The daemon looks the entry up with the descriptor too, and keeps the
    xp-pen families off the firmware interfaces these two XP-Pen recordings
    come from; their reports are read by the family all the same (the UGEE's
    have the XP-Pen layout's bits, the Deco 03's are refused)."""
    rec = load_recording(hid_data / f"{name}.hid")
    entry = lookup(rec.vid, rec.pid)
    assert entry is not None and entry.family and entry.geometry
    desc = parse_descriptor(rec.descriptor)
    direct, generated, tracker = (ReportStream(desc, name, (0.2, 0.1), entry) for _ in range(3))
    assert "pen = read(d)" in getattr(direct.feed, "source", "")
    generated.use_bytes_path()
    tracker.use_tracker()
    made = _run((direct, generated, tracker), [(ev.t, ev.data) for ev in rec.events])
    # deco-03 was recorded in its firmware mode: the 8-byte family reads none of it
    assert made > 500 or name == "xp-pen-deco-03"
    assert direct.stats["ignored"] > 0 or made > 500


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_family_on_the_recorded_reports(family: str, hid_data: Path) -> None:
    """Real reports of every recording through every family: most are not its
    layout, which is the point (ignored, refused or read as it happens)."""
    reports = []
    for p in sorted(hid_data.glob("*.hid")):
        reports += [(ev.t, ev.data) for ev in load_recording(p).events[:300]]
    for geom in (WIDE, NARROW):
        _run(_streams(family, geom), reports, idle_every=97)


IDS = (0x01, 0x02, 0x07, 0x08, 0x09, 0x10, 0x12)
"""The report IDs the families read (0x12: wacom-pl reads the low nibble)."""
BODIES = (bytes(range(0x31, 0x3F)), b"\xff" * 14)
"""Bytes 2-15: small coordinates, and all ones (coordinates and pressure past any
range, negative signed bytes)."""


def _sweep() -> list[tuple[float, bytes]]:
    """Every value of each byte a family keeps its flags in, for each ID it reads.

    Byte 1 (most families), byte 2 behind a VEIKK pen sub-type, byte 5
    (Waltop); full-length and 8-byte reports. In order, so stateful families
    see their enter and exit packets among the rest.
    """
    out = []
    for rid in IDS:
        for body in BODIES:
            for b in range(256):
                out.append(bytes([rid, b]) + body)
                out.append(bytes([rid, b]) + body[:6])
                out.append(bytes([rid, 0x41, b]) + body[1:])
                out.append(bytes([rid]) + body[:4] + bytes([b]) + body[4:])
    return [(k * 0.004, data) for k, data in enumerate(out)]


SWEEP = _sweep()


@pytest.mark.parametrize("family", sorted(FAMILIES))
def test_every_family_on_every_flag_byte(family: str) -> None:
    for geom in (WIDE, NARROW):
        _run(_streams(family, geom), SWEEP, idle_every=61 if family in NO_IN_RANGE else 0)


_IDS = st.sampled_from(IDS)
_FLAGS = st.one_of(
    st.sampled_from([0x41, 0x80, 0x81, 0x82, 0xA0, 0xA1, 0xA9, 0xC0, 0xC2, 0xE0, 0xF0, 0x20, 0x21]),
    st.integers(0, 255),
)
_PEN_SHAPED = st.builds(
    lambda i, f, rest: bytes([i, f]) + rest, _IDS, _FLAGS, st.binary(min_size=5, max_size=14)
)
_REPORT = st.one_of(_PEN_SHAPED, _PEN_SHAPED, st.binary(max_size=16))
"""Mostly reports shaped like the families' (an ID they read, flag bytes they test)."""


@pytest.mark.parametrize("family", sorted(FAMILIES))
@settings(max_examples=25)  # three streams built per example; the sweep above is exhaustive
@given(
    reports=st.lists(_REPORT, min_size=8, max_size=40),
    geom=st.sampled_from([WIDE, NARROW, HUGE]),
    sized=st.booleans(),
)
def test_every_family_on_generated_reports(
    family: str, reports: list[bytes], geom: Geometry, sized: bool
) -> None:
    """Sequences, so stateful families move through their states; `sized`: a user's
    surface size, smaller than the tablet's, so positions are clamped on the surface."""
    streams = _streams(family, geom, (0.05, 0.03) if sized else None)
    timed = [(k * 0.004, data) for k, data in enumerate(reports)]
    _run(streams, timed, idle_every=7 if family in NO_IN_RANGE else 0)


def test_a_proximity_timeout_family_ends_its_contact_on_both_paths() -> None:
    """uclogic-v2 has no in-range bit: the pen is gone 100 ms after its last report."""
    streams = _streams("uclogic-v2", WIDE)
    pen = bytes([0x08, 0x01, 0x10, 0x27, 0x10, 0x27, 0x00, 0x10, 0, 0, 0, 0])
    assert _run(streams, [(0.0, pen), (0.004, pen)]) == 2
    for s in streams:
        assert s.idle(0.1) == []
        (gone,) = s.idle(0.2)
        assert not gone.in_range and not gone.tip

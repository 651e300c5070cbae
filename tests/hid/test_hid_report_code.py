"""The generated per-report path (report_code.py) against ContactTracker, on every recording.

ReportStream.feed runs a generated function per contact report ID; the
readable ContactTracker is the statement of what a report means. Both are
run over every recorded report of shared/data/hid (and over reports with
every bit flipped, for the branches recordings rarely reach): the samples
must be equal field for field, floats bit for bit, and so must the
counters and the tracker's state after each report.
"""

from __future__ import annotations

import math
import random
from pathlib import Path

import pytest

from stiction.drivers.hid.descriptor import parse_descriptor
from stiction.drivers.hid.devices import lookup
from stiction.drivers.hid.recording import load_recording
from stiction.drivers.hid.report_code import covered
from stiction.drivers.hid.stream import ReportStream
from stiction.drivers.sample import PenSample
from stiction.errors import DeviceError

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "hid"
SIZE = (0.2, 0.1)


def _maps(name: str) -> bool:
    """Whether a recording's descriptor has a contact report (the README's mouse
    and keyboard are refused by design, with a DeviceError)."""
    rec = load_recording(DATA / f"{name}.hid")
    try:
        ReportStream(parse_descriptor(rec.descriptor), name, SIZE, lookup(rec.vid, rec.pid))
    except DeviceError:
        return False
    return True


ALL = sorted(p.stem for p in DATA.glob("*.hid"))
FILES = [n for n in ALL if _maps(n)]
REFUSED = [n for n in ALL if n not in FILES]


def test_the_recordings_are_there_and_only_the_negatives_are_refused() -> None:
    assert len(FILES) >= 20, f"shared/data/hid not found at {DATA}, or it lost recordings"
    assert REFUSED == ["contour-rollermouse-red", "microsoft-keyboard-045e-0773"]


def _streams(
    name: str, per_report: bool = False
) -> tuple[ReportStream, ReportStream, list[tuple[float, bytes]]]:
    """The generated stream feed (or, with `per_report`, the feed method calling
    each report ID's generated function) and the ContactTracker reference."""
    rec = load_recording(DATA / f"{name}.hid")
    desc = parse_descriptor(rec.descriptor)
    entry = lookup(rec.vid, rec.pid)
    fast = ReportStream(desc, name, SIZE, entry)
    slow = ReportStream(desc, name, SIZE, entry)
    if per_report:
        fast.feed = fast._feed
    slow.use_tracker()  # the reference: ContactTracker for every report
    return fast, slow, [(ev.t, ev.data) for ev in rec.events]


def _same(a: list[PenSample], b: list[PenSample]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert type(x) is PenSample and x == y
        for f in ("t", "x", "y", "pressure", "tilt_x", "tilt_y"):
            u, v = getattr(x, f), getattr(y, f)
            assert type(u) is type(v) and (u == v or (u != u and v != v)), f
        assert type(x.tip) is bool and type(x.in_range) is bool


def _run(fast: ReportStream, slow: ReportStream, reports: list[tuple[float, bytes]]) -> None:
    for t, data in reports:
        _same(fast.feed(t, data), slow.feed(t, data))
        assert fast.tracker.active == slow.tracker.active
    assert fast.stats == slow.stats
    assert fast.tracker.last == slow.tracker.last
    _same(fast.idle(math.inf), slow.idle(math.inf))


@pytest.mark.parametrize("per_report", [False, True], ids=["stream-feed", "report-fn"])
@pytest.mark.parametrize("name", FILES)
def test_generated_path_matches_the_tracker(name: str, per_report: bool) -> None:
    fast, slow, reports = _streams(name, per_report)
    _run(fast, slow, reports)
    if reports and any(covered(m) for m in fast.mappings.values()):
        assert fast._compiled, "a covered report ID got no generated path"
        assert fast.stats["samples"] > 0 or fast.stats["ignored"] > 0


@pytest.mark.parametrize("per_report", [False, True], ids=["stream-feed", "report-fn"])
@pytest.mark.parametrize("name", FILES)
def test_generated_path_matches_on_flipped_bits(name: str, per_report: bool) -> None:
    """Every report with one bit flipped (and some with random bytes): all branches."""
    fast, slow, reports = _streams(name, per_report)
    rng = random.Random(name)
    mutated: list[tuple[float, bytes]] = []
    for i, (t, data) in enumerate(reports[:400]):
        if not data:
            continue
        b = bytearray(data)
        bit = i % (8 * len(b) - (8 if fast.numbered else 0)) + (8 if fast.numbered else 0)
        b[bit // 8] ^= 1 << (bit % 8)
        mutated.append((t, bytes(b)))
        if i % 7 == 0:
            head = data[:1] if fast.numbered else b""
            mutated.append((t, head + rng.randbytes(len(data) - len(head))))
    _run(fast, slow, mutated)


def test_finger_reports_with_contact_count_stay_with_the_tracker() -> None:
    rec = load_recording(DATA / "elan-04f3-3140-touchpad.hid")
    stream = ReportStream(parse_descriptor(rec.descriptor), rec.name, SIZE)
    counted = [rid for rid, m in stream.mappings.items() if m.contact_count is not None]
    assert counted and not any(rid in stream._compiled for rid in counted)


def test_generated_samples_are_ordinary_frozen_pen_samples() -> None:
    import dataclasses

    rec = load_recording(DATA / "xp-pen-artist-10s.hid")
    stream = ReportStream(parse_descriptor(rec.descriptor), rec.name, SIZE)
    samples = [s for ev in rec.events for s in stream.feed(ev.t, ev.data)]
    assert samples and all(type(s) is PenSample for s in samples)
    s = samples[-1]
    with pytest.raises(dataclasses.FrozenInstanceError):
        s.x = 1.0  # type: ignore[misc]
    assert hash(s) == hash(dataclasses.replace(s)) and s == dataclasses.replace(s)
    assert dataclasses.asdict(s)["t"] == s.t


def test_generated_feed_keeps_report_times_for_the_proximity_timeout() -> None:
    """With a proximity timeout, idle() ends the pen after the last report, as before."""
    rec = load_recording(DATA / "xp-pen-artist-10s.hid")
    desc = parse_descriptor(rec.descriptor)
    fast = ReportStream(desc, rec.name, SIZE, proximity_timeout=0.05)
    slow = ReportStream(desc, rec.name, SIZE, proximity_timeout=0.05)
    slow.use_tracker()
    ended = 0
    for ev in rec.events[:1500]:
        _same(fast.feed(ev.t, ev.data), slow.feed(ev.t, ev.data))
        a, b = fast.idle(ev.t + 0.03), slow.idle(ev.t + 0.03)  # within the timeout
        _same(a, b)
        assert a == []
        a, b = fast.idle(ev.t + 0.2), slow.idle(ev.t + 0.2)  # beyond it
        _same(a, b)
        ended += len(a)
    assert ended > 0 and fast.stats == slow.stats

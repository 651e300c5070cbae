"""The compiled path (columns.py) against the frame assembler: same samples, same state.

columns.samples() turns a read()'s bytes into PenSamples in one compiled
pass and leaves the FrameAssembler as feed_many would; DeviceSource.samples()
(long reads) and a fast replay use it. Here it eats the same events as the reference --
FrameAssembler.feed_many + frame_samples, batch by batch -- and must give
the same samples (compared by repr, so -0.0 against 0.0 would show), the
same counters and the same final finish(): on every recording the benchmark
times, cut into batches at many points, with SYN_DROPPED put in (the array
path refuses such batches and the assembler takes over, so the hand-over
is tested too), and on random streams from hypothesis, garbage included.
The replay source is compared with the frame-by-frame replay it replaced,
pause compression included. The last tests break the path on purpose, six
ways, and check that the comparison notices.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from evdev import ecodes as e
from hypothesis import given, settings
from hypothesis import strategies as st
from test_evdev_fast_paths import DESCS, _codes, _values, _with_drops

from stiction.bench.evdev import RECORDINGS  # the recordings the benchmark times
from stiction.drivers.evdev import columns, playback, sizes
from stiction.drivers.evdev.description import DeviceDescription
from stiction.drivers.evdev.device import read_samples
from stiction.drivers.evdev.frames import INPUT_EVENT, FrameAssembler
from stiction.drivers.evdev.recording import Recording, load
from stiction.drivers.evdev.source import frame_samples
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.limits import GapCompressor
from stiction.drivers.sample import PenSample

Event = tuple[int, int, int, int, int]

pytestmark = pytest.mark.skipif(not columns.AVAILABLE, reason="input_event is not 24 bytes here")


def _desc(name: str, rec: Recording) -> DeviceDescription:
    return sizes.apply(rec.description, (100.0, 60.0) if "synaptics" in name else None)


def _batches(events: list[Event], cuts: list[int]) -> list[list[Event]]:
    bounds = [0, *sorted(c for c in cuts if 0 < c < len(events)), len(events)]
    return [events[a:b] for a, b in itertools.pairwise(bounds)]


def _outcome(asm: FrameAssembler, units: SurfaceUnits, out: list[PenSample]) -> object:
    assert all(type(s) is PenSample for s in out)
    stats = dict(asm.stats)
    end = asm.finish(99, 0)
    return [repr(s) for s in out], stats, end, asm.needs_resync, asm._dropping


def reference(desc: DeviceDescription, batches: list[list[Event]]) -> object:
    asm, units = FrameAssembler(desc), SurfaceUnits(desc)
    out: list[PenSample] = []
    for b in batches:
        for f in asm.feed_many_general(b):
            out += frame_samples(units, f)
    return _outcome(asm, units, out)


def columnar(desc: DeviceDescription, batches: list[list[Event]]) -> tuple[object, int]:
    """The compiled path wherever it accepts a batch; the number of batches it took."""
    asm, units = FrameAssembler(desc), SurfaceUnits(desc)
    out: list[PenSample] = []
    taken = 0
    for b in batches:
        made = columns.samples(asm, units, b"".join(INPUT_EVENT.pack(*ev) for ev in b))
        if made is None:
            for f in asm.feed_many(b):
                out += frame_samples(units, f)
        else:
            taken += 1
            out += made
    return _outcome(asm, units, out), taken


def same_both_ways(desc: DeviceDescription, events: list[Event], cuts: list[int]) -> int:
    batches = _batches(events, cuts)
    got, taken = columnar(desc, batches)
    assert got == reference(desc, batches)
    return taken


@pytest.mark.parametrize("name", RECORDINGS)
def test_compiled_path_equals_the_assembler_on_recordings(evdev_data: Path, name: str) -> None:
    rec = load(evdev_data / name)
    desc = _desc(name, rec)
    events = list(rec.events)
    assert same_both_ways(desc, events, []) == 1  # the whole recording at once
    frame_ends = [i + 1 for i, ev in enumerate(events) if ev[2] == e.EV_SYN and ev[3] == 0]
    # batches of whole frames, of every length (the compiled path takes each)
    cuts = [frame_ends[k * (k + 1) // 2] for k in range(60) if k * (k + 1) // 2 < len(frame_ends)]
    assert same_both_ways(desc, events, cuts) == len(_batches(events, cuts))
    # batches cut mid-frame, and SYN_DROPPED: declined batches go through the assembler
    same_both_ways(desc, events, list(range(5, len(events), 37)))
    same_both_ways(desc, _with_drops(events), frame_ends[::7])


@pytest.mark.parametrize("desc", list(DESCS.values()), ids=list(DESCS))
@settings(max_examples=200, deadline=None)
@given(
    events=st.lists(st.tuples(_codes, _values), max_size=200),
    cuts=st.lists(st.integers(0, 200), max_size=6),
    drops=st.booleans(),
)
def test_compiled_path_equals_the_assembler_on_random_streams(
    desc: DeviceDescription,
    events: list[tuple[tuple[int, int], int]],
    cuts: list[int],
    drops: bool,
) -> None:
    # input_event's fields: u16 type and code, s32 value (what a read() can hold)
    stream = [(0, i, t, c, v) for i, ((t, c), v) in enumerate(events)]
    if not drops:  # most streams without SYN_DROPPED, so that the compiled path runs
        stream = [ev for ev in stream if not (ev[2] == e.EV_SYN and ev[3] == e.SYN_DROPPED)]
    same_both_ways(desc, stream, cuts)


#: multi-touch events mostly: slot switches and tracking ids that collide
_mt_codes = st.sampled_from(
    [
        (e.EV_ABS, e.ABS_MT_SLOT),
        (e.EV_ABS, e.ABS_MT_SLOT),
        (e.EV_ABS, e.ABS_MT_TRACKING_ID),
        (e.EV_ABS, e.ABS_MT_TRACKING_ID),
        (e.EV_ABS, e.ABS_MT_TRACKING_ID),
        (e.EV_ABS, e.ABS_MT_POSITION_X),
        (e.EV_ABS, e.ABS_MT_PRESSURE),
        (e.EV_ABS, e.ABS_MT_TOOL_TYPE),
        (e.EV_ABS, e.ABS_MT_DISTANCE),
        (e.EV_KEY, e.BTN_LEFT),
        (e.EV_SYN, e.SYN_REPORT),
        (e.EV_SYN, e.SYN_REPORT),
    ]
)


@settings(max_examples=200, deadline=None)
@given(
    events=st.lists(
        st.tuples(st.one_of(_codes, _mt_codes), st.integers(-1, 3)), min_size=40, max_size=300
    ),
    cuts=st.lists(st.integers(0, 300), max_size=4),
)
def test_compiled_path_equals_the_assembler_on_small_values(
    events: list[tuple[tuple[int, int], int]], cuts: list[int]
) -> None:
    """Values in -1..3, slot numbers in range: tracking ids that collide (reused,
    replaced), palms, hover, bad key values -- the multi-touch rules, in the loop."""
    slot = (e.EV_ABS, e.ABS_MT_SLOT)
    stream = [(0, i, t, c, v % 3 if (t, c) == slot else v) for i, ((t, c), v) in enumerate(events)]
    stream = [ev for ev in stream if not (ev[2] == e.EV_SYN and ev[3] == e.SYN_DROPPED)]
    for desc in DESCS.values():
        same_both_ways(desc, stream, cuts)


def test_colliding_tracking_ids_in_the_loop() -> None:
    """Two slots given one id (the second is dropped), a new id without -1 first."""
    pad = DESCS["touchpad"]
    slot, tid, x = e.ABS_MT_SLOT, e.ABS_MT_TRACKING_ID, e.ABS_MT_POSITION_X
    frames = [
        [(slot, 0), (tid, 1), (x, 5), (slot, 1), (tid, 1), (x, 7)],  # 1 reused in slot 1
        [(slot, 0), (tid, 2), (x, 6)],  # 1 replaced by 2 without -1: 1 ends
        [(slot, 1), (tid, 3), (x, 9)],
        [(slot, 0), (tid, -1), (slot, 1), (tid, -1)],
    ]
    stream = [
        ev
        for n, frame in enumerate(frames)
        for ev in [*((0, n, e.EV_ABS, c, v) for c, v in frame), (0, n, e.EV_SYN, 0, 0)]
    ]
    assert same_both_ways(pad, stream, []) == 1
    asm = FrameAssembler(pad)
    columns.samples(asm, SurfaceUnits(pad), b"".join(INPUT_EVENT.pack(*ev) for ev in stream))
    assert asm.stats["tracking_id_reused"] == 1
    assert asm.stats["tracking_id_replaced"] == 1


def test_random_streams_reach_the_compiled_path() -> None:
    """The property above is not vacuous: a plain pen stroke is taken whole."""
    pen = DESCS["pen"]
    stroke: list[Event] = [(0, 0, e.EV_KEY, e.BTN_TOOL_PEN, 1)]
    for i in range(50):
        stroke += [
            (0, i, e.EV_ABS, e.ABS_X, 200 + i),
            (0, i, e.EV_ABS, e.ABS_PRESSURE, 5 * i),
            (0, i, e.EV_KEY, e.BTN_TOUCH, int(10 < i < 40)),
            (0, i, e.EV_SYN, e.SYN_REPORT, 0),
        ]
    stroke += [(0, 60, e.EV_KEY, e.BTN_TOOL_PEN, 0), (0, 60, e.EV_SYN, e.SYN_REPORT, 0)]
    assert same_both_ways(pen, stroke, []) == 1


def test_read_samples_takes_either_path(evdev_data: Path) -> None:
    """DeviceSource's per-read function: long reads by array, short ones by frames."""
    rec = load(evdev_data / "wacom-intuos4-6x9.desc")
    events = list(rec.events)
    frame_ends = [i + 1 for i, ev in enumerate(events) if ev[2] == e.EV_SYN and ev[3] == 0]
    columns.warm()
    for cuts in ([], frame_ends, frame_ends[::40]):
        batches = _batches(events, cuts)
        asm, units = FrameAssembler(rec.description), SurfaceUnits(rec.description)
        out: list[PenSample] = []
        for b in batches:
            out += read_samples(asm, units, b"".join(INPUT_EVENT.pack(*ev) for ev in b))
        assert _outcome(asm, units, out) == reference(rec.description, batches)


def _old_replay(src: playback.ReplaySource) -> list[str]:
    """The frame-by-frame replay the compiled path replaced (its pause compression)."""
    asm = FrameAssembler(src.description)
    compress = GapCompressor(src.name)
    out = []
    for frame in src._frames(asm):
        out += frame_samples(src._units, playback._retimed(frame, compress))
    return [repr(s) for s in out]


def _paused(events: list[Event]) -> list[Event]:
    """Pauses of 3 s and more (compressed on replay) every 50 frames."""
    out: list[Event] = []
    shift = 0
    n = 0
    for sec, usec, t, c, v in events:
        out.append((sec + shift, usec, t, c, v))
        if t == e.EV_SYN and c == e.SYN_REPORT:
            n += 1
            if n % 50 == 0:
                shift += 3 + n // 50
    return out


@pytest.mark.parametrize("pauses", [False, True], ids=["as-recorded", "with-pauses"])
@pytest.mark.parametrize("name", RECORDINGS)
def test_fast_replay_equals_frame_by_frame_replay(
    evdev_data: Path, name: str, pauses: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    rec = load(evdev_data / name)
    if pauses:
        rec = Recording(rec.description, _paused(list(rec.events)), rec.path, rec.events_path)
    monkeypatch.setattr(playback, "_CHUNK", 300)  # several chunks, each cut at a SYN_REPORT
    src = playback.ReplaySource(rec, size_mm=(100.0, 60.0) if "synaptics" in name else None)
    got = [repr(s) for s in src.samples()]
    stats = src.stats()
    want = _old_replay(src)
    assert got == want
    assert stats["samples"] == len(want)
    assert stats["events"] == len(rec.events)


def test_compressed_times_match_the_compressor_call_by_call() -> None:
    times = np.array([0.0, 0.01, 5.0, 5.013, 5.02, 40.5, 40.51, 41.0, 100.123457])
    one = GapCompressor("x", max_gap=0.5)
    want = []
    for t in times.tolist():
        c = one(t)
        if c != t:
            sec = int(np.floor(c))
            c = sec + min(round((c - sec) * 1e6), 999_999) / 1_000_000
        want.append(c)
    many = GapCompressor("x", max_gap=0.5)
    got = np.concatenate(
        [playback._compress_many(many, times[:4]), playback._compress_many(many, times[4:])]
    )
    assert got.tolist() == want
    assert (many.prev, many.shift, many.logged) == (one.prev, one.shift, one.logged)


def _no_tool(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every tool key names no tool: the pen never comes into range."""
    monkeypatch.setattr(columns, "_TOOL_OF", np.zeros_like(columns._TOOL_OF))


def _ended_in_range(monkeypatch: pytest.MonkeyPatch) -> None:
    """Ended contacts keep in_range=True."""
    real = columns._build

    def build(times: list[float], out_i: np.ndarray, *rest: Any) -> list[PenSample]:
        out_i[columns.k.O_IN, :] = 1
        return real(times, out_i, *rest)

    monkeypatch.setattr(columns, "_build", build)


def _tail_lost(monkeypatch: pytest.MonkeyPatch) -> None:
    """The events after the batch's last SYN_REPORT are not handed to the assembler."""
    real = columns._finish

    def finish(
        asm: FrameAssembler, down: np.ndarray, counts: np.ndarray, res: np.ndarray, q: np.ndarray
    ) -> None:
        real(asm, down, counts, res, q[: int(res[1])])

    monkeypatch.setattr(columns, "_finish", finish)


def _buttons_shifted(monkeypatch: pytest.MonkeyPatch) -> None:
    """Every button one bit too high (right reported as middle)."""
    monkeypatch.setattr(columns, "_BUTTON_BITS", columns._BUTTON_BITS * 2)


@pytest.mark.parametrize(
    ("name", "breaks", "cut"),
    [
        ("wacom-intuos4-6x9.desc", _no_tool, False),
        ("wacom-cintiq-12wx.evemu", _ended_in_range, False),
        ("synaptics-touchpad.hp8470p.desc", _ended_in_range, False),
        ("uc-logic-wp5540u-pen.evemu", _tail_lost, True),
        ("elantech-touchpad.samsung-700z3a.evemu", _tail_lost, True),
        ("cypress-trackpad.two-finger-press.evemu", _buttons_shifted, False),
    ],
    ids=[
        "pen-tool-lost",
        "pen-ended-in-range",
        "touchpad-ended-in-range",
        "pen-tail-lost",
        "touchpad-tail-lost",
        "touchpad-buttons-shifted",
    ],
)
def test_the_comparison_catches_a_broken_compiled_path(
    evdev_data: Path,
    monkeypatch: pytest.MonkeyPatch,
    name: str,
    breaks: Callable[[pytest.MonkeyPatch], None],
    cut: bool,
) -> None:
    """The compiled path, broken on purpose, must disagree with the assembler."""
    rec = load(evdev_data / name)
    desc = _desc(name, rec)
    events = list(rec.events)
    # cut=True: batches that end mid-frame (their tails go to the assembler)
    cuts = [k for k in range(100, len(events), 100)] if cut else []
    same_both_ways(desc, events, cuts)
    breaks(monkeypatch)
    with pytest.raises(AssertionError):
        same_both_ways(desc, events, cuts)


def test_live_reads_take_the_loop_only_once_compiled(monkeypatch: pytest.MonkeyPatch) -> None:
    """compile=False (DeviceSource's reads) never compiles: a reader must not stall."""
    pen = DESCS["pen"]
    stroke = [(0, i, e.EV_ABS, e.ABS_X, 200 + i) for i in range(60)]
    stroke = [ev for x in stroke for ev in (x, (0, x[1], e.EV_SYN, e.SYN_REPORT, 0))]
    data = b"".join(INPUT_EVENT.pack(*ev) for ev in stroke)
    units = SurfaceUnits(pen)
    monkeypatch.setattr(columns, "compiled", lambda kind=None: False)
    assert columns.samples(FrameAssembler(pen), units, data, compile=False) is None
    monkeypatch.undo()
    columns.warm()
    assert columns.compiled()
    assert columns.samples(FrameAssembler(pen), units, data, compile=False) is not None


def test_a_failing_compiler_falls_back_to_the_assembler(
    evdev_data: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    """numba failing on some machine costs speed, never samples: the loop is
    switched off for the process and the replay goes frame by frame."""

    def broken(*args: object) -> int:
        raise RuntimeError("no LLVM here")

    monkeypatch.setattr(columns, "kernels", lambda: {"single": broken, "multitouch": broken})
    monkeypatch.setattr(columns, "AVAILABLE", True)
    rec = load(evdev_data / "wacom-intuos4-6x9.desc")
    src = playback.ReplaySource(rec)
    got = [repr(s) for s in src.samples()]
    assert columns.AVAILABLE is False
    assert "failed; reading event by event" in caplog.text
    assert got == _old_replay(src)

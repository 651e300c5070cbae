"""The synthetic tablet: scripted strokes encoded into UGEE M708 v2 reports and decoded back."""

from __future__ import annotations

import itertools
import threading

import pytest

from stiction.drivers.fake import SCRIPTS, synthetic
from stiction.drivers.fake.strokes import DT, render
from stiction.drivers.fake.tablet import SyntheticTablet
from stiction.drivers.sample import PenSample
from stiction.drivers.source import SampleSource
from stiction.errors import DeviceError

W, H = 0.2539746, 0.1523746
LOGICAL_M = W / 50794  # one device unit in metres (5 um)


def _all(name: str) -> list[PenSample]:
    src = synthetic(name, realtime=False, loop=False)
    out = list(src.samples())
    src.close()
    return out


def _contacts(samples: list[PenSample]) -> list[list[PenSample]]:
    """Runs of consecutive touching samples."""
    return [list(g) for tip, g in itertools.groupby(samples, key=lambda s: s.tip) if tip]


@pytest.mark.parametrize("name", sorted(SCRIPTS))
def test_every_script_is_a_sample_source_on_the_surface(name: str) -> None:
    src = synthetic(name, realtime=False, loop=False)
    assert isinstance(src, SampleSource)
    assert src.kind == "pen"
    assert src.surface_size == pytest.approx((W, H))
    samples = list(src.samples())
    assert len(samples) > 100
    assert all(0 <= s.x <= W and 0 <= s.y <= H for s in samples)
    times = [s.t for s in samples]
    assert times == sorted(times)
    assert all(b - a == pytest.approx(DT, abs=1e-9) for a, b in itertools.pairwise(times))
    assert samples[-1].in_range is False  # the pen leaves at the end
    stats = src.stats()
    assert stats["reports"] >= stats["samples"] == len(samples)
    src.close()
    src.close()  # idempotent


def test_decoded_positions_match_the_script_to_one_device_unit() -> None:
    tablet = SyntheticTablet()
    states = render(SCRIPTS["stroke"](*tablet.size_m))
    decoded = _all("stroke")
    in_range = [s for s in states if s.in_range]
    assert len(decoded) == len(in_range) + 1  # plus the single out-of-range sample
    for st, d in zip(in_range, decoded, strict=False):
        assert d.x == pytest.approx(st.x, abs=LOGICAL_M)
        assert d.y == pytest.approx(st.y, abs=LOGICAL_M)
        assert d.tip == st.tip
        assert d.pressure == pytest.approx(st.pressure, abs=1 / 8191)
        assert d.tilt_x == round(st.tilt_x)


def test_stroke_is_the_papers_task() -> None:
    samples = _all("stroke")
    (contact,) = _contacts(samples)
    start = contact[0]
    # stays still briefly after touch-down
    still = [s for s in contact if s.t - start.t < 0.35]
    assert max(abs(s.x - start.x) for s in still) <= LOGICAL_M
    # then drags left to right, about 25 mm, never backwards
    xs = [s.x for s in contact]
    assert xs[-1] - xs[0] == pytest.approx(0.025, abs=2 * LOGICAL_M)
    assert all(b >= a - LOGICAL_M for a, b in itertools.pairwise(xs))
    assert max(abs(s.y - start.y) for s in contact) <= LOGICAL_M
    # at a moderate speed: peak under 0.1 m/s
    speeds = [(b.x - a.x) / (b.t - a.t) for a, b in itertools.pairwise(contact)]
    assert 0.03 < max(speeds) < 0.1
    assert samples[0].tip is False and samples[0].in_range  # comes in hovering


def test_circles_go_round() -> None:
    (contact,) = _contacts(_all("circles"))
    cx = (max(s.x for s in contact) + min(s.x for s in contact)) / 2
    cy = (max(s.y for s in contact) + min(s.y for s in contact)) / 2
    assert (cx, cy) == pytest.approx((W / 2, H / 2), abs=2 * LOGICAL_M)
    radii = [((s.x - cx) ** 2 + (s.y - cy) ** 2) ** 0.5 for s in contact]
    assert min(radii) == pytest.approx(0.02, abs=3 * LOGICAL_M)
    assert max(radii) == pytest.approx(0.02, abs=3 * LOGICAL_M)


def test_demo_sweeps_the_whole_surface_with_pauses_and_reversals() -> None:
    samples = _all("demo")
    contacts = _contacts(samples)
    assert len(contacts) == 4
    heights = sorted(round(c[0].y / H, 2) for c in contacts)
    assert heights == [0.2, 0.4, 0.6, 0.8]
    for c in contacts:
        xs = [s.x for s in c]
        assert max(xs) - min(xs) > 0.85 * W
        steps = [b - a for a, b in itertools.pairwise(xs)]
        moving = [d for d in steps if abs(d) > LOGICAL_M]
        signs = [d > 0 for d in moving]
        assert sum(1 for a, b in itertools.pairwise(signs) if a != b) == 2
        assert sum(1 for d in steps if abs(d) <= LOGICAL_M) > 100  # pauses


def test_loop_repeats_forever_with_increasing_time() -> None:
    once = _all("stroke")
    src = synthetic("stroke", realtime=False, loop=True)
    looped = list(itertools.islice(src.samples(), 3 * len(once)))
    src.close()
    times = [s.t for s in looped]
    assert times == sorted(times) and len(set(times)) == len(times)
    period = looped[len(once)].t - looped[0].t
    for a, b in zip(once, looped[len(once) : 2 * len(once)], strict=True):
        assert (b.x, b.y, b.tip) == (a.x, a.y, a.tip)
        assert b.t == pytest.approx(a.t + period)


def test_close_wakes_a_realtime_source() -> None:
    src = synthetic("demo", realtime=True, loop=True)
    first = threading.Event()
    finished = threading.Event()

    def consume() -> None:
        for _ in src.samples():
            first.set()
        finished.set()

    t = threading.Thread(target=consume, daemon=True)
    t.start()
    assert first.wait(10.0)
    src.close()
    assert finished.wait(10.0)


def test_unknown_script_is_a_clear_error() -> None:
    with pytest.raises(DeviceError, match="unknown synthetic stroke 'zigzag'; known: circles"):
        synthetic("zigzag", realtime=False, loop=False)

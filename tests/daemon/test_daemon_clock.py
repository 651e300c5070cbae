"""The schedule: absolute deadlines, late ticks counted, no cascade, no drift."""

from __future__ import annotations

import pytest

from stiction.daemon.clock import Schedule, VirtualClock


def test_deadlines_are_absolute_and_do_not_drift() -> None:
    s = Schedule(100.0, start=1000.0)
    s.index = 10_000_000
    # Summing 1e7 periods would be off by far more than this; n/rate is exact-ish.
    assert s.deadline == pytest.approx(1000.0 + 100_000.0, abs=1e-9)


def test_on_time_ticks_are_not_late_and_keep_the_grid() -> None:
    s = Schedule(100.0, start=0.0)
    for n in range(1000):
        assert s.deadline == pytest.approx(n / 100.0)
        s.begin(s.deadline + 0.0001)
        s.finish(s.deadline + 0.0002)
    assert (s.ticks, s.late, s.skipped) == (1000, 0, 0)


def test_a_late_tick_is_counted_once_and_later_ticks_are_not_late() -> None:
    s = Schedule(100.0, start=0.0)
    s.begin(0.0)
    s.finish(0.0)
    # Tick 1 (deadline 0.01) starts 35 ms late and takes 1 ms.
    assert s.begin(0.045) == pytest.approx(0.035)
    s.finish(0.046)
    # Deadlines 0.02, 0.03, 0.04 have passed: they are skipped, not run back to back.
    assert s.skipped == 3
    assert s.deadline == pytest.approx(0.05)
    for _ in range(10):
        s.begin(s.deadline)
        s.finish(s.deadline)
    assert s.late == 1
    assert s.ticks == 12  # the wire tick counter stays consecutive


def test_late_threshold_defaults_to_half_a_period() -> None:
    s = Schedule(100.0, start=0.0)
    s.begin(0.0049)
    assert s.late == 0
    s.finish(0.005)
    s.begin(0.01 + 0.0051)
    assert s.late == 1


def test_virtual_clock_jumps_to_deadlines() -> None:
    c = VirtualClock(5.0)
    c.sleep_until(7.5)
    assert c.now() == 7.5
    c.sleep_until(6.0)
    assert c.now() == 7.5


def test_bad_rate_is_refused() -> None:
    with pytest.raises(ValueError):
        Schedule(0.0, 0.0)

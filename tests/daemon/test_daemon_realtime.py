"""`realtime`: the loop thread under SCHED_FIFO, everything it starts ordinary,
and a clear log line (never an error) where the kernel refuses."""

from __future__ import annotations

import logging
import os
import threading
from typing import Any

import pytest
from daemon_support import ListSource, Runner, make_daemon, stroke

from stiction.daemon import clock
from stiction.daemon.clock import set_realtime


def _policy() -> int:
    return os.sched_getscheduler(0) & ~os.SCHED_RESET_ON_FORK


def _watch(d: Any) -> tuple[threading.Event, dict[str, Any]]:
    """On the third tick, record the loop thread's policy and a new thread's."""
    seen: dict[str, Any] = {}
    done = threading.Event()

    def on_tick(n: int) -> None:
        if n == 2 and not done.is_set():
            seen["loop"] = _policy()
            child: dict[str, int] = {}
            t = threading.Thread(target=lambda: child.update(policy=_policy()))
            t.start()
            t.join()
            seen["child"] = child["policy"]
            seen["stats"] = d.stats()["realtime"]
            done.set()

    d.on_tick = on_tick
    return done, seen


def test_the_loop_runs_real_time_and_the_threads_it_starts_do_not(
    endpoints: tuple[str, str], caplog: pytest.LogCaptureFixture
) -> None:
    # May this process have SCHED_FIFO at all? Ask in a throwaway thread.
    probe: dict[str, str | None] = {}
    t = threading.Thread(target=lambda: probe.update(refused=set_realtime(5)))
    t.start()
    t.join()
    d = make_daemon(endpoints, {"pen": ListSource(stroke(n=5))}, realtime=5, keepalive=0)
    done, seen = _watch(d)
    with caplog.at_level(logging.INFO, logger="stiction.daemon"), Runner(d):
        assert done.wait(10)
    assert seen["child"] == os.SCHED_OTHER  # readers, hot-plug: ordinary either way
    if probe["refused"] is None:  # root or CAP_SYS_NICE, as in CI
        assert seen["loop"] == os.SCHED_FIFO and seen["stats"] == 5
        assert "realtime priority=5" in caplog.text
    else:
        assert seen["loop"] == os.SCHED_OTHER and seen["stats"] == 0
        assert "realtime_refused priority=5" in caplog.text


def test_a_refusal_is_logged_and_the_daemon_runs_as_usual(
    endpoints: tuple[str, str], caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    def refuse(pid: int, policy: int, param: Any) -> None:
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(clock.os, "sched_setscheduler", refuse)
    d = make_daemon(endpoints, {"pen": ListSource(stroke(n=5))}, realtime=50, keepalive=0)
    done, seen = _watch(d)
    with caplog.at_level(logging.INFO, logger="stiction.daemon"), Runner(d):
        assert done.wait(10)
    assert seen["loop"] == os.SCHED_OTHER and seen["stats"] == 0
    line = next(r.getMessage() for r in caplog.records if "realtime_refused" in r.getMessage())
    assert "priority=50" in line and "CAP_SYS_NICE" in line and "Operation not permitted" in line

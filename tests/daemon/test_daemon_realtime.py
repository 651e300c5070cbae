"""`realtime`: the loop thread under SCHED_FIFO, its device readers one priority
below, everything else it starts ordinary, and a clear log line (never an
error) where the kernel refuses.

Issue 15: a reader at ordinary priority that holds the GIL can be preempted
by any other process while the real-time loop waits for the interpreter,
so the readers run just below the loop: above every ordinary process, never
ahead of the loop. The last test checks it on a real stictiond through /proc.
"""

from __future__ import annotations

import contextlib
import logging
import os
import subprocess
import sys
import threading
from pathlib import Path
from typing import Any

import pytest
from daemon_support import ListSource, Runner, make_daemon, stroke

from stiction.clients import control
from stiction.daemon import clock
from stiction.daemon.clock import set_realtime

STICTIOND = Path(sys.executable).with_name("stictiond")


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


def _policies(pid: int) -> dict[int, tuple[int, int]]:
    out = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        with contextlib.suppress(OSError):  # a thread that ended meanwhile
            out[int(tid)] = (os.sched_getscheduler(int(tid)) & ~os.SCHED_RESET_ON_FORK,
                             os.sched_getparam(int(tid)).sched_priority)  # fmt: skip
    return out


@pytest.mark.skipif(os.geteuid() != 0, reason="SCHED_FIFO needs root (CAP_SYS_NICE); CI is root")
def test_the_readers_run_one_priority_below_the_loop(tmp_path: Path) -> None:
    pub, ctl = f"ipc://{tmp_path}/pub", f"ipc://{tmp_path}/ctl"
    log = (tmp_path / "stictiond.log").open("wb")
    proc = subprocess.Popen(
        [str(STICTIOND), "--realtime", "10", "--device", "synthetic:demo", "--no-hotplug",
         "--seconds", "30", "--pub", pub, "--control", ctl],
        stdout=subprocess.DEVNULL, stderr=log,
    )  # fmt: skip
    try:
        for _ in range(120):  # ready once it ticks: the scheduling is set before the first tick
            try:
                if control.request(ctl, "stats", timeout=0.5)["stats"]["ticks"] > 0:
                    break
            except control.ControlUnavailable:
                assert proc.poll() is None, (tmp_path / "stictiond.log").read_text()
        stats = control.request(ctl, "stats", timeout=2)["stats"]
        assert stats["realtime"] == 10, (tmp_path / "stictiond.log").read_text()
        policies = _policies(proc.pid)
    finally:
        proc.terminate()
        proc.wait(30)
        log.close()
    fifo = sorted(p for p in policies.values() if p[0] == os.SCHED_FIFO)
    assert policies[proc.pid] == (os.SCHED_FIFO, 10)  # the loop: stictiond's main thread
    assert fifo == [(os.SCHED_FIFO, 9), (os.SCHED_FIFO, 10)], policies  # one device, one reader
    ordinary = [t for t, p in policies.items() if p[0] == os.SCHED_OTHER]
    assert ordinary, policies  # control, reload and ZeroMQ's threads stay ordinary
    assert "reader_realtime_refused" not in (tmp_path / "stictiond.log").read_text()

"""Under `--realtime P` the loop runs SCHED_FIFO at P and each device reader at P-1.

Issue 15: a reader at ordinary priority that holds the GIL can be preempted
by any other process while the real-time loop waits for the interpreter.
The readers therefore run just below the loop: above every ordinary
process, never ahead of the loop. Everything else the daemon starts stays
ordinary (SCHED_RESET_ON_FORK). Checked on a real stictiond through /proc.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.clients import control

STICTIOND = Path(sys.executable).with_name("stictiond")


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

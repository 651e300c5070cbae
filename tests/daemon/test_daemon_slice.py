"""stiction.daemon.clock.request_slice: an ordinary thread's slice request reaches Linux.

The request is an experiment the daemon benchmark offers (--slice-ms); this
checks the system call on the running kernel through /proc, where the
scheduler shows each thread's slice."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from stiction.daemon.clock import request_slice


def _slice_ns() -> int | None:
    """The calling thread's fair-scheduler slice (ns), where the kernel shows it."""
    try:
        text = Path("/proc/thread-self/sched").read_text()
    except OSError:
        return None
    for line in text.splitlines():
        if line.startswith("se.slice"):
            return int(line.split(":")[1])
    return None


def test_a_slice_request_reaches_the_kernel_and_zero_restores_the_default() -> None:
    got: dict[str, object] = {}

    def probe() -> None:  # a thread of its own: the test runner's stays untouched
        got["before"] = _slice_ns()
        got["refused"] = request_slice(0.0005)
        got["during"] = _slice_ns()
        got["reset"] = request_slice(0.0)
        got["after"] = _slice_ns()

    t = threading.Thread(target=probe)
    t.start()
    t.join()
    if got["refused"] is not None or got["before"] is None:
        pytest.skip(f"no slice request here: {got['refused'] or 'no se.slice in /proc'}")
    assert got["during"] == 500_000
    assert got["reset"] is None and got["after"] == got["before"]


def test_a_slice_outside_what_linux_takes_is_refused_before_the_call() -> None:
    with pytest.raises(ValueError, match="between 0 and 100 ms"):
        request_slice(0.5)
    with pytest.raises(ValueError, match="between 0 and 100 ms"):
        request_slice(float("nan"))

"""docs/protocol.md's own Python client, extracted from the page and run as
written against the real daemon: the page is a contract, so its example must work."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

pytest_plugins = ["clients_fixtures"]

PAGE = Path(__file__).resolve().parents[2] / "docs" / "protocol.md"
ENDPOINTS = 'PUB, CONTROL = "tcp://127.0.0.1:5556", "tcp://127.0.0.1:5557"'


def _example() -> str:
    text = PAGE.read_text(encoding="utf-8")
    section = text[text.index("## A minimal client") :]
    m = re.search(r"```python\n(.*?)```", section, re.S)
    assert m is not None, "no Python example in docs/protocol.md"
    return m.group(1)


def test_the_example_sets_both_timeouts_and_retakes_the_snapshot() -> None:
    code = _example()
    assert ENDPOINTS in code  # the test below swaps these for the real daemon's
    for needle in ("zmq.SNDTIMEO", "zmq.RCVTIMEO", "zmq.LINGER", "prev_tick"):
        assert needle in code, needle
    assert code.count("snapshot()") >= 2  # taken, and retaken when ticks were missed


def test_the_pages_python_example_runs_against_the_daemon(stictiond: tuple[str, str]) -> None:
    """Run as a user would, in a process of its own: it must end by itself.

    (Run with exec() in the test process, its context outlived it and, once
    collected, waited in zmq_ctx_term for a socket the example never closed:
    300 s, every CI run, until pytest-timeout cut it. The page now closes both.)
    """
    pub, ctl = stictiond
    code = _example().replace(ENDPOINTS, f"PUB, CONTROL = {pub!r}, {ctl!r}")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.splitlines()
    assert lines, "the example printed nothing"
    for line in lines:
        device, cid, phase, _ = line.split(" ", 3)
        assert device.startswith("synthetic") and cid.isdigit()
        assert phase in ("stick", "slip", "hover", "up")

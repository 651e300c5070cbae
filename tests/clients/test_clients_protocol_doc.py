"""docs/protocol.md's own Python client, extracted from the page and run as
written against the real daemon: the page is a contract, so its example must work."""

from __future__ import annotations

import contextlib
import io
import re
import threading
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
    pub, ctl = stictiond
    code = _example().replace(ENDPOINTS, f"PUB, CONTROL = {pub!r}, {ctl!r}")
    out = io.StringIO()
    failure: list[BaseException] = []

    def run() -> None:
        try:
            with contextlib.redirect_stdout(out):
                exec(compile(code, str(PAGE), "exec"), {"__name__": "protocol_example"})
        except BaseException as exc:
            failure.append(exc)

    t = threading.Thread(target=run, daemon=True)
    t.start()
    t.join(30)
    assert not t.is_alive(), "the example did not print 20 frames' contacts within 30 s"
    assert not failure, failure
    lines = out.getvalue().splitlines()
    assert lines, "the example printed nothing"
    for line in lines:
        device, cid, phase, _ = line.split(" ", 3)
        assert device.startswith("synthetic") and cid.isdigit()
        assert phase in ("stick", "slip", "hover", "up")

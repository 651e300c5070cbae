"""A Ctrl-C or SIGTERM that comes as stictiond announces itself stops it cleanly.

The daemon logs "started" while it opens; a user (or a test harness) that
presses Ctrl-C on seeing that line used to meet a KeyboardInterrupt
traceback, because the handlers went in after the opening. The signal is
raised here from inside the opening, so the race is hit every time.
"""

from __future__ import annotations

import os
import signal
from pathlib import Path

import pytest

from stiction.daemon import main as daemon_main
from stiction.daemon.service import Daemon


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_stop_signal_during_the_start_stops_the_daemon_cleanly(
    sig: signal.Signals, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real_open = Daemon.open
    ran: list[int] = []

    def open_then_signal(self: Daemon) -> None:
        real_open(self)
        os.kill(os.getpid(), sig)  # delivered before open() returns

    real_run = Daemon.run

    def run(self: Daemon) -> int:
        result = real_run(self)
        ran.append(self.last_tick)
        return result

    monkeypatch.setattr(Daemon, "open", open_then_signal)
    monkeypatch.setattr(Daemon, "run", run)
    before = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    code = daemon_main.main(
        [
            *("--device", "synthetic:demo", "--no-hotplug", "--seconds", "30"),
            *("--pub", f"ipc://{tmp_path}/pub", "--control", f"ipc://{tmp_path}/ctl"),
        ]
    )
    assert code == 0
    assert ran and ran[0] < 100  # stopped at once, not after its 30 s
    assert {s: signal.getsignal(s) for s in before} == before  # handlers put back

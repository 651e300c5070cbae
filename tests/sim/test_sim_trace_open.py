"""open_trace checks the file it reads, not a name that may point elsewhere a moment later.

It used to stat the path and then open it by name: a FIFO put in the file's
place between the two (a trace directory shared with another user, a
symlink swapped) was then opened blocking and read for ever. The check now
runs on the open descriptor (userfiles.open_regular_text).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from stiction import userfiles
from stiction.errors import RecordingError
from stiction.sim.trace import open_trace, read_trace

TRACE = "t,x,y,contact\n0.00,0.010,0.020,1\n0.01,0.011,0.020,1\n"


def test_a_fifo_swapped_in_as_the_trace_is_opened_is_refused_unread(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "pen.csv"
    path.write_text(TRACE)
    real_open = os.open
    swapped: list[str] = []

    def swap_then_open(name: object, *args: object, **kw: object) -> int:
        # the race, made deterministic: the regular file is replaced by a FIFO
        # with no writer just as the trace is opened
        if str(name) == str(path) and not swapped:
            path.unlink()
            os.mkfifo(path)
            swapped.append(str(name))
        return real_open(name, *args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(userfiles.os, "open", swap_then_open)
    with pytest.raises(RecordingError, match="not a regular file"), open_trace(path):
        pass
    assert swapped, "the trace was not opened through the checked open"


def test_a_regular_trace_still_streams(tmp_path: Path) -> None:
    path = tmp_path / "pen.csv"
    path.write_text(TRACE)
    assert [(s.t, s.x, s.tip) for s in read_trace(path)] == [(0.0, 0.01, True), (0.01, 0.011, True)]


@pytest.mark.parametrize("kind", ["missing", "directory", "nul"])
def test_what_cannot_be_a_trace_is_one_error_naming_it(tmp_path: Path, kind: str) -> None:
    path = {
        "missing": str(tmp_path / "nope.csv"),
        "directory": str(tmp_path),
        "nul": str(tmp_path / "a\0b.csv"),
    }[kind]
    with pytest.raises(RecordingError) as info, open_trace(path):
        pass
    assert len(str(info.value).splitlines()) == 1

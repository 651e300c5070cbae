"""Pipeline.warm_up waits for numba's cache to load, never for a first compilation.

What the daemon's first frame depends on (`stiction bench daemon` prints it):
the wait is decided before the background thread starts, from whether
numba's cache holds the tick. The thread and the cache are replaced here, so
nothing compiles and nothing is timed: the test sees only the wait chosen.
"""

from __future__ import annotations

import threading
from typing import Any

import pytest

from stiction.scene import pipeline as pl
from stiction.scene.backend import SimulatorBackend
from stiction.scene.load import default_scene


class _Recorder(threading.Event):
    """An Event that is never set and remembers how long it was asked to wait."""

    def __init__(self) -> None:
        super().__init__()
        self.waits: list[float | None] = []

    def wait(self, timeout: float | None = None) -> bool:
        self.waits.append(timeout)
        return False


def _pipeline(monkeypatch: pytest.MonkeyPatch, cached: bool | None) -> tuple[Any, _Recorder]:
    backend = SimulatorBackend()
    pipe = pl.Pipeline(default_scene(), backend, backend.defaults(), compiled=False)
    stepper, _, _ = pipe._ready()
    fresh = pl._Compiled(object())  # a tick nobody compiled yet
    fresh.ready = _Recorder()
    pipe._tick = fresh
    monkeypatch.setattr(stepper, "is_cached", lambda fn: cached, raising=False)
    monkeypatch.setattr(pipe, "_compile", lambda compiled: None)  # no real compilation
    return pipe, fresh.ready


@pytest.mark.parametrize(
    ("cached", "wait"), [(True, pl.WARM_UP_WAIT_S), (None, pl.WARM_UP_WAIT_S), (False, 0.0)]
)
def test_the_wait_follows_the_cache(
    monkeypatch: pytest.MonkeyPatch, cached: bool | None, wait: float
) -> None:
    pipe, ready = _pipeline(monkeypatch, cached)
    assert pipe.warm_up() is False
    assert ready.waits == [wait]


def test_an_explicit_wait_wins(monkeypatch: pytest.MonkeyPatch) -> None:
    pipe, ready = _pipeline(monkeypatch, False)
    assert pipe.warm_up(wait=600.0) is False
    assert ready.waits == [600.0]

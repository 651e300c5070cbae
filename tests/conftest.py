"""Shared test set-up.

Hypothesis runs derandomized so that `make test` is deterministic: the same
examples every run. Set HYPOTHESIS_PROFILE=explore for a random, longer search.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

settings.register_profile(
    "ci",
    derandomize=True,
    deadline=None,
    max_examples=200,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile("explore", deadline=None, max_examples=5000)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
HID_DATA = SHARED / "data" / "hid"
EVDEV_DATA = SHARED / "data" / "evdev"
COVERAGE_DATA = SHARED / "data" / "coverage"


@pytest.fixture(scope="session")
def hid_data() -> Path:
    if not HID_DATA.is_dir():
        pytest.fail(f"shared HID data not found at {HID_DATA}: clone shared/ beside the repo")
    return HID_DATA


@pytest.fixture(scope="session")
def evdev_data() -> Path:
    if not EVDEV_DATA.is_dir():
        pytest.fail(f"shared evdev data not found at {EVDEV_DATA}: clone shared/ beside the repo")
    return EVDEV_DATA


@pytest.fixture(scope="session")
def coverage_data() -> Path:
    if not COVERAGE_DATA.is_dir():
        pytest.fail(
            f"shared coverage data not found at {COVERAGE_DATA}: clone shared/ beside the repo"
        )
    return COVERAGE_DATA


def pytest_sessionstart(session: pytest.Session) -> None:
    """Compile the daemon's numba tick once, before any test starts a daemon.

    A daemon on a cold numba cache compiles for seconds on a background thread
    while its loop runs the interpreted tick and answers control requests
    slowly; tests with one-second client timeouts would then depend on which
    test happened to start the first daemon. Compiled here, in-process, the
    cache is written and every daemon the tests start loads it.
    """
    from stiction.scene.backend import SimulatorBackend
    from stiction.scene.load import default_scene
    from stiction.scene.pipeline import Pipeline

    backend = SimulatorBackend("default", 1)
    pipeline = Pipeline(default_scene(), backend, {**backend.defaults(), "rate": 100.0})
    if not pipeline.warm_up(wait=600.0):
        raise pytest.UsageError("the numba tick did not compile within 10 minutes")

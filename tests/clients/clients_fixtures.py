"""Fixtures of the client tests, loaded by the test modules with
``pytest_plugins = ["clients_fixtures"]``.

Not a conftest.py on purpose: other test directories import their helpers
with ``from conftest import ...``, and one more module named ``conftest``
would shadow theirs (pytest keeps one ``conftest`` in sys.modules).
"""

from __future__ import annotations

import contextlib
import shutil
import subprocess
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from clients_support import (
    CHROMIUM,
    CHROMIUM_ARGS,
    DEMO_SCENE,
    STICTIOND,
    WAITED_FOR,
    FakeDaemon,
)


@pytest.fixture
def short_dir() -> Iterator[Path]:
    """ipc:// paths must stay under ~100 bytes; pytest's tmp_path can be longer."""
    d = Path(tempfile.mkdtemp(prefix="stc-", dir="/tmp"))
    yield d
    shutil.rmtree(d, ignore_errors=True)


@pytest.fixture
def endpoints(short_dir: Path) -> tuple[str, str]:
    return f"ipc://{short_dir}/pub", f"ipc://{short_dir}/ctl"


@pytest.fixture
def daemon(endpoints: tuple[str, str]) -> Iterator[FakeDaemon]:
    d = FakeDaemon(*endpoints)
    yield d
    d.close()


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    """Per module: playwright's sync API holds an event loop while it runs, which
    would stop later tests from calling asyncio.run()."""
    if not Path(CHROMIUM).exists():
        pytest.fail(f"{CHROMIUM} not found: install Debian's chromium (make sysdeps)")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
        yield b
        b.close()


@contextlib.contextmanager
def running_stictiond(short_dir: Path, *device_args: str) -> Iterator[tuple[str, str]]:
    """The real daemon for 20 s at most, yielded once it answers ping."""
    pub, ctl = f"ipc://{short_dir}/d-pub", f"ipc://{short_dir}/d-ctl"
    log = (short_dir / "stictiond.log").open("wb")  # a file: a full pipe would stall it
    proc = subprocess.Popen(
        [
            *(str(STICTIOND), "--clock", "real", "--seconds", "20", "--no-hotplug"),
            *device_args,
            *("--pub", pub, "--control", ctl),
        ],
        stdout=subprocess.DEVNULL,
        stderr=log,
    )
    try:
        # Ready when it answers: before its first tick it loads the compiled
        # tick, which a loaded machine can stretch past a client's 1 s timeout.
        from stiction.clients import control

        for _ in range(120):
            try:
                control.request(ctl, "ping", timeout=0.5)
                break
            except control.ControlUnavailable:
                assert proc.poll() is None, "stictiond exited before it answered"
        else:
            raise AssertionError("stictiond never answered ping")
        yield pub, ctl
    finally:
        proc.terminate()
        proc.wait(30)
        log.close()


@pytest.fixture
def stictiond(short_dir: Path) -> Iterator[tuple[str, str]]:
    """The real daemon on the synthetic pen with the demo scene."""
    with running_stictiond(
        short_dir, "--device", "synthetic:demo", "--scene", str(DEMO_SCENE)
    ) as eps:
        yield eps


@pytest.fixture
def stictiond_without_device(short_dir: Path) -> Iterator[tuple[str, str]]:
    """The real daemon waiting for a tablet that never comes: it publishes nothing."""
    with running_stictiond(short_dir, "--device", WAITED_FOR) as eps:
        yield eps

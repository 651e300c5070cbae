"""Fixtures of the daemon tests; the helpers live in daemon_support.py.

Helpers are imported as ``daemon_support``, not ``conftest``: every test
folder has its own conftest.py, and ``from conftest import`` picks whichever
one was imported first.
"""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture
def endpoints(tmp_path: Path) -> tuple[str, str]:
    return f"ipc://{tmp_path}/pub", f"ipc://{tmp_path}/ctl"

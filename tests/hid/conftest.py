"""HID tests run with an empty user device table, whatever the machine has in ~/.config."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def _no_user_device_table(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STICTION_HID_DEVICES", str(tmp_path / "no-user-table.toml"))

"""The XDG base directory rule, kept in stiction/xdg.py for every per-user path."""

from __future__ import annotations

from pathlib import Path

import pytest

from stiction.bench._support import default_results
from stiction.drivers.catalogue.load import user_table_path
from stiction.setup.service import config_path
from stiction.sim.numba_cache import user_cache_dir


@pytest.mark.parametrize("value", ["relative/dir", "", "./here"])
def test_a_relative_or_empty_value_is_ignored(
    value: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A relative $XDG_CONFIG_HOME was used as-is by the device table, putting it
    under whatever folder the command ran in; the spec says to ignore it."""
    monkeypatch.setenv("HOME", str(tmp_path))
    monkeypatch.setenv("XDG_CONFIG_HOME", value)
    monkeypatch.setenv("XDG_CACHE_HOME", value)
    monkeypatch.delenv("STICTION_HID_DEVICES", raising=False)
    monkeypatch.delenv("STICTION_BENCH_RESULTS", raising=False)
    assert user_table_path() == tmp_path / ".config" / "stiction" / "hid-devices.toml"
    assert config_path() == tmp_path / ".config" / "stiction" / "stictiond.toml"
    assert user_cache_dir() == tmp_path / ".cache" / "stiction" / "numba"
    assert default_results() == tmp_path / ".cache" / "stiction" / "bench"


def test_an_absolute_value_is_used(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("XDG_CONFIG_HOME", str(tmp_path / "conf"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.delenv("STICTION_HID_DEVICES", raising=False)
    monkeypatch.delenv("STICTION_BENCH_RESULTS", raising=False)
    assert user_table_path() == tmp_path / "conf" / "stiction" / "hid-devices.toml"
    assert user_cache_dir() == tmp_path / "cache" / "stiction" / "numba"
    assert default_results() == tmp_path / "cache" / "stiction" / "bench"

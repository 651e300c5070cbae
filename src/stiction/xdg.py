"""Where per-user files go: the XDG base directories, read by their own rule.

The XDG Base Directory specification says a relative `$XDG_CONFIG_HOME` or
`$XDG_CACHE_HOME` is invalid and must be ignored; taken as-is it would put
the device table, the numba cache or benchmark results somewhere relative to
whatever folder a command happens to run in. Every place that reads these
variables goes through here, so the rule is kept in one place.
"""

from __future__ import annotations

import os
from pathlib import Path


def _home(variable: str, default: str) -> Path:
    value = os.environ.get(variable, "")
    return Path(value) if value and os.path.isabs(value) else Path.home() / default


def config_home() -> Path:
    """$XDG_CONFIG_HOME, or ~/.config when it is unset, empty or not absolute."""
    return _home("XDG_CONFIG_HOME", ".config")


def cache_home() -> Path:
    """$XDG_CACHE_HOME, or ~/.cache when it is unset, empty or not absolute."""
    return _home("XDG_CACHE_HOME", ".cache")

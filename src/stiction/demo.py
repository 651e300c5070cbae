"""`stiction demo`: the main job on any machine (placeholder until the daemon lands)."""

from __future__ import annotations

import argparse
from typing import Any


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add the demo sub-command (none yet)."""

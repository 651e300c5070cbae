"""Command-line sub-commands of this package (see stiction.cli)."""

from __future__ import annotations

import argparse
from typing import Any


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add this package's sub-commands (none yet)."""

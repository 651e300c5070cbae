"""Errors of the web renderer that callers may want to act on."""

from __future__ import annotations

from stiction.errors import StictionError


class PortInUse(StictionError):
    """The HTTP port is taken (another renderer, another program)."""

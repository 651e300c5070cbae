"""Synthetic input: scripted strokes sent through a real tablet's HID descriptor.

``synthetic(name, realtime, loop)`` is the factory the daemon calls (see
stiction.drivers.source); it needs no hardware.
"""

from stiction.drivers.fake.strokes import SCRIPTS
from stiction.drivers.fake.tablet import synthetic

__all__ = ["SCRIPTS", "synthetic"]

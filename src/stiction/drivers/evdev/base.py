"""What the live and the replayed evdev SampleSource share: identity and counters.

Both know a DeviceDescription and its SurfaceUnits, count in ``_stats`` and
frame through a FrameAssembler; name, kind, surface size and stats() follow
from those the same way for both.
"""

from __future__ import annotations

from collections import Counter

from stiction.drivers.evdev.description import DeviceDescription
from stiction.drivers.evdev.frames import FrameAssembler
from stiction.drivers.evdev.source import kind_of, slug
from stiction.drivers.evdev.units import SurfaceUnits


class EvdevSourceBase:
    """Subclasses set ``description`` and ``_units``, and ``_assembler`` once framing."""

    description: DeviceDescription
    _units: SurfaceUnits
    _stats: Counter[str]
    _assembler: FrameAssembler | None

    @property
    def name(self) -> str:
        return slug(self.description.name)

    @property
    def surface_size(self) -> tuple[float, float] | None:
        return self._units.surface_size

    @property
    def kind(self) -> str:
        return kind_of(self.description)

    def stats(self) -> dict[str, int]:
        out = dict(self._stats)
        if self._assembler is not None:
            out.update(self._assembler.stats)
        return out

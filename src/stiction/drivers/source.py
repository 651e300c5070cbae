"""What the daemon reads: a stream of PenSamples from one device.

CONTRACT between the drivers and the daemon (keep it stable, extend freely).

Every driver offers factories returning an object that satisfies
`SampleSource`:

- ``stiction.drivers.hid.open_hidraw(path_or_vidpid: str) -> SampleSource``
  (hidapi's hidraw backend; vendor initialisation from the device table)
- ``stiction.drivers.hid.replay(path, realtime: bool) -> SampleSource``
  (a hid-recorder ``.hid`` file)
- ``stiction.drivers.fake.synthetic(name, realtime: bool, loop: bool) -> SampleSource``
  (a scripted stroke encoded through a real HID descriptor and decoded back)
- ``stiction.drivers.evdev.open_device(path, grab: bool) -> SampleSource``
- ``stiction.drivers.evdev.replay(path, events_path=None, realtime: bool) -> SampleSource``
  (an evemu recording, or a ``libinput record`` YAML file)
- each backend package also offers ``discover() -> list[DeviceInfo]``.

``samples()`` blocks and yields samples in time order as they arrive; it
returns when a finite stream (a replay without loop) ends, and raises
`stiction.errors.DeviceError` when the device goes away (unplug). With
``realtime=False`` a replay yields as fast as possible; sample times are the
recorded ones either way, so the daemon's virtual clock can schedule ticks
from them. ``close()`` is idempotent and makes a blocked ``samples()`` return
soon. ``stats()`` returns counters (reports/events read, skipped malformed
reports, SYN_DROPPED, ...) for the daemon's stats reply.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Protocol, runtime_checkable

from stiction.drivers.sample import PenSample


@runtime_checkable
class SampleSource(Protocol):
    @property
    def name(self) -> str:
        """A short stable name, used as the frame topic's device part."""
        ...

    @property
    def surface_size(self) -> tuple[float, float] | None:
        """Width and height of the active surface in metres, None if unknown."""
        ...

    @property
    def kind(self) -> str:
        """ "pen", "touchpad" or "touchscreen": decides the default mapping."""
        ...

    def samples(self) -> Iterator[PenSample]: ...

    def close(self) -> None: ...

    def stats(self) -> dict[str, int]: ...

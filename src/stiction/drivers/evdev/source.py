"""Frames -> PenSamples: the part every evdev SampleSource shares.

One sample per active contact per frame; a contact that ended in the frame
gets a last sample with tip=False, in_range=False at its last position, so
the daemon sees every contact end even when the kernel only said "-1".
"""

from __future__ import annotations

import re

from stiction.drivers.evdev.description import DeviceDescription
from stiction.drivers.evdev.frames import Frame
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.sample import PenSample


def slug(name: str) -> str:
    """A stable topic-safe name from the kernel's device name."""
    s = re.sub(r"[^a-z0-9]+", "-", name.lower()).strip("-")
    return s or "evdev"


def frame_samples(units: SurfaceUnits, frame: Frame) -> list[PenSample]:
    """The frame's samples, ended contacts first; a list, not a generator: one
    frame holds a contact or two, and a generator's set-up and resumption cost
    more than the list."""
    sec, usec, contacts, ended = frame
    t = sec + usec / 1_000_000  # Frame.time without the property call
    sample = units.sample
    if ended:
        return [sample(c, t) for c in (*ended, *contacts)]
    if len(contacts) == 1:
        return [sample(contacts[0], t)]
    return [sample(c, t) for c in contacts]


def kind_of(desc: DeviceDescription) -> str:
    """The SampleSource kind; anything unclassified is read like a pen (absolute)."""
    k = desc.kind
    return k if k in ("pen", "touchpad", "touchscreen") else "pen"

"""SurfaceUnits.sample builds PenSamples through BlankSample: the same samples as by keyword.

units.sample fills a stiction.drivers.blank_sample.BlankSample and turns it
into a PenSample (a fifth of the frozen dataclass's __init__ cost). Here every
contact of every recording is converted both ways -- the fast path, and the
conversion written out with PenSample's own constructor -- and the samples
must be equal, of type PenSample, and as immutable as any other.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

from stiction.drivers.evdev import sizes
from stiction.drivers.evdev.frames import Contact, FrameAssembler
from stiction.drivers.evdev.recording import load
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.sample import PenSample

DATA = Path(__file__).resolve().parents[3] / "shared" / "data" / "evdev"
NAMES = sorted(
    p.name for p in DATA.iterdir() if p.suffix in (".evemu", ".desc") and p.stem[-7:] != ".events"
)


def _by_keyword(u: SurfaceUnits, c: Contact, t: float) -> PenSample:
    """The conversion as units.sample documents it, through PenSample's constructor."""
    x0, x1, y0, y1 = u.x_axis.minimum, u.x_axis.maximum, u.y_axis.minimum, u.y_axis.maximum
    x = min(max(c.x, x0), x1)
    y = min(max(c.y, y0), y1)
    scale = u._pressure
    pressure = None
    if c.pressure is not None and scale is not None:
        p = (c.pressure - scale.offset) * scale.scale
        pressure = 0.0 if p < 0.0 else 1.0 if p > 1.0 else p
    tx, ty = u._tilt_x, u._tilt_y
    tilt_x = tilt_y = None
    if tx is not None and c.tilt_x is not None:
        tilt_x = min(max((c.tilt_x - tx.offset) * tx.scale, tx.lo), tx.hi)
    if ty is not None and c.tilt_y is not None:
        tilt_y = min(max((c.tilt_y - ty.offset) * ty.scale, ty.lo), ty.hi)
    return PenSample(
        t=t,
        x=(x - x0) / u._rx / 1000,
        y=(y - y0) / u._ry / 1000,
        tip=c.tip,
        in_range=c.in_range,
        contact=c.id,
        pressure=pressure,
        tool=c.tool,
        tilt_x=tilt_x,
        tilt_y=tilt_y,
        buttons=c.buttons,
    )


@pytest.mark.parametrize("name", NAMES)
def test_fast_samples_equal_keyword_samples(name: str) -> None:
    rec = load(DATA / name)
    desc = sizes.apply(rec.description, (100.0, 60.0))
    units = SurfaceUnits(desc)
    frames = FrameAssembler(desc).feed_many(rec.events)
    n = 0
    for f in frames:
        for c in (*f.ended, *f.contacts):
            fast, ref = units.sample(c, f.time), _by_keyword(units, c, f.time)
            assert type(fast) is PenSample and fast == ref and hash(fast) == hash(ref)
            n += 1
    assert n > 0 or not frames
    if n:
        with pytest.raises(dataclasses.FrozenInstanceError):
            fast.x = 0.0  # type: ignore[misc]

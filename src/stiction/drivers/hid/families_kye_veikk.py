"""KYE (Genius) and VEIKK report families: 16-bit pen reports in a vendor report ID.

- ``kye`` (Genius EasyPen i405X, MousePen i608X, EasyPen M610X): once
  enabled by feature report 5 (Linux drivers/hid/hid-kye.c does so, and
  OpenTabletDriver's configurations send the same report), the pen
  reports as report ID 0x10, which the tablet's own descriptor does not
  describe; hid-kye.c replaces the descriptor with one that does. From
  that descriptor (GPL-2.0; the layout only): byte 1 bit 0 tip, bit 1
  barrel, bit 2 "tablet pick" (the second button), bits 3-6 constant,
  bit 7 in range; X, Y and pressure little-endian 16-bit at bytes 2-7.
- ``veikk`` (VEIKK S640, A50 and others in their first firmware): report
  ID 1 or 2, byte 1 bit 0 tip, bit 1 and 2 the two barrel buttons, X, Y,
  pressure little-endian 16-bit at bytes 2-7 (jlam55555/veikk-linux-driver
  ``struct veikk_pen_report``, GPL); the in-range bit is bit 6 of byte 1,
  as the S640's own descriptor declares it (linuxwacom/wacom-hid-descriptors
  'Veikk S640', ../shared/data/hid/veikk-s640.hid). This is the report the
  S640's firmware mode sends on its pen interface, for a hand-written
  entry; OpenTabletDriver's VeikkV1 parser reads the 9-byte vendor report
  of another interface instead: ``veikk-v1`` in families_veikk.py.
"""

from __future__ import annotations

from stiction.drivers.hid.family_types import Geometry, PenState, Reader, away, new_state, u16x3

KYE_PEN_ID = 0x10
VEIKK_PEN_IDS = (0x01, 0x02)


def _flags_reader(ids: tuple[int, ...], in_range_bit: int) -> Reader:
    def read(d: bytes) -> PenState | None:
        if len(d) < 8 or d[0] not in ids:
            return None
        b = d[1]
        x, y, p = u16x3(d, 2)
        if not b & in_range_bit:
            return away(x, y)
        return new_state(PenState, (x, y, p, b & 1 != 0, True, b & 2 != 0, b & 4 != 0, False, 0, 0))

    return read


def kye(geom: Geometry) -> Reader:
    return _flags_reader((KYE_PEN_ID,), 0x80)


def veikk(geom: Geometry) -> Reader:
    return _flags_reader(VEIKK_PEN_IDS, 0x40)

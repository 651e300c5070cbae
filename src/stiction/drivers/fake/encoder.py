"""Values -> report bytes, through a real report descriptor.

The synthetic tablet writes what a real tablet would send, so that everything
downstream of the bytes (the decoder, the unit conversion, the contact
tracker) runs exactly as it does for hardware.
"""

from __future__ import annotations

from stiction.drivers.hid.descriptor import Report


class ReportEncoder:
    """Packs {usage: value} into one report; missing usages are 0, values are clamped."""

    def __init__(self, report: Report) -> None:
        self.report = report
        self.slots: dict[int, tuple[int, int, int, int]] = {}
        for f in report.fields:
            if f.constant or not f.variable or f.usage in self.slots:
                continue
            self.slots[f.usage] = (f.bit_offset, f.bit_size, f.logical_min, f.logical_max)

    def logical_range(self, usage: int) -> tuple[int, int]:
        _, _, lo, hi = self.slots[usage]
        return lo, hi

    def encode(self, values: dict[int, int]) -> bytes:
        acc = 0
        for usage, value in values.items():
            slot = self.slots.get(usage)
            if slot is None:
                continue
            offset, size, lo, hi = slot
            v = min(max(int(value), lo), hi) if hi > lo else int(value)
            acc |= (v & ((1 << size) - 1)) << offset
        if self.report.report_id:
            acc |= self.report.report_id
        return acc.to_bytes(self.report.byte_size, "little")

"""Split a HID report descriptor into items (HID 1.11, section 6.2.2.2).

Kept apart from the parser so that the byte-level rules (short items of 0, 1,
2 or 4 data bytes, long items, the trailing zero some firmwares append) are
in one place and every bad byte sequence is reported with its offset.
"""

from __future__ import annotations

from dataclasses import dataclass

from stiction.errors import DescriptorError

# Item types (bits 3..2 of the prefix byte).
MAIN, GLOBAL, LOCAL, RESERVED = 0, 1, 2, 3
LONG_ITEM_PREFIX = 0xFE

# The kernel refuses descriptors above this size (HID_MAX_DESCRIPTOR_SIZE).
MAX_DESCRIPTOR_SIZE = 4096


@dataclass(frozen=True, slots=True)
class Item:
    """One short item: its byte offset, type, tag and data (little endian)."""

    offset: int
    type: int
    tag: int
    size: int  # data bytes: 0, 1, 2 or 4
    udata: int

    @property
    def sdata(self) -> int:
        """The data read as a two's-complement number of its own size."""
        if self.size == 0:
            return 0
        bits = 8 * self.size
        return self.udata - (1 << bits) if self.udata >> (bits - 1) else self.udata


def iter_items(desc: bytes) -> list[Item]:
    """All short items of `desc`, in order; long items are skipped (none are defined)."""
    if len(desc) == 0:
        raise DescriptorError("empty report descriptor")
    if len(desc) > MAX_DESCRIPTOR_SIZE:
        raise DescriptorError(
            f"report descriptor of {len(desc)} bytes exceeds the {MAX_DESCRIPTOR_SIZE}-byte "
            "limit of the HID specification and the kernel"
        )
    items: list[Item] = []
    i = 0
    n = len(desc)
    while i < n:
        prefix = desc[i]
        if prefix == 0 and i == n - 1 and items:
            break  # a trailing zero byte, seen on several real devices
        if prefix == LONG_ITEM_PREFIX:
            if i + 2 >= n:
                raise DescriptorError(f"long item at byte {i} is truncated")
            size = desc[i + 1]
            if i + 3 + size > n:
                raise DescriptorError(f"long item at byte {i} runs past the end of the descriptor")
            i += 3 + size
            continue
        size = (0, 1, 2, 4)[prefix & 0x3]
        if i + 1 + size > n:
            raise DescriptorError(
                f"item 0x{prefix:02x} at byte {i} needs {size} data bytes, "
                f"only {n - i - 1} left: the descriptor is truncated"
            )
        udata = int.from_bytes(desc[i + 1 : i + 1 + size], "little")
        items.append(Item(i, (prefix >> 2) & 0x3, prefix >> 4, size, udata))
        i += 1 + size
    return items

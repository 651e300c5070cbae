"""HID report descriptor -> the fields of every input, output and feature report.

The model follows hid-tools (bentiss/hid-tools, `hidtools.hid`) so that the
two can be compared field by field: bit offsets count the report-ID byte of
numbered reports, a variable main item becomes one field per usage (count 1,
the last usage repeating when the count exceeds the usages), a constant item
without usages is one padding field, and an array item is one field with its
count and its list of usages. Where hid-tools deviates from HID 1.11 -- Push
loses Unit/Unit Exponent in hid-tools 0.12 -- this parser follows the
specification, as the corrected oracle files in shared/data/hid do.

Limits follow the Linux kernel (drivers/hid/hid-core.c), so that a descriptor
that the kernel refuses is refused here with the reason in words.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field, replace

from stiction.drivers.hid.items import GLOBAL, LOCAL, MAIN, Item, iter_items
from stiction.errors import DescriptorError

MAX_REPORT_SIZE_BITS = 256  # per element; the kernel's limit
MAX_REPORT_COUNT = 12288  # HID_MAX_USAGES
MAX_REPORT_BYTES = 16384  # HID_MAX_BUFFER_SIZE
MAX_GLOBAL_STACK = 16
MAX_COLLECTION_DEPTH = 64
MAX_FIELDS = 65536


class ReportType(enum.Enum):
    INPUT = "input"
    OUTPUT = "output"
    FEATURE = "feature"


# Main item flag bits (HID 1.11, 6.2.2.5).
CONSTANT = 0x01
VARIABLE = 0x02
RELATIVE = 0x04
NULL_STATE = 0x40

# Digitizer collections that hold one contact each: Stylus, Puck, Finger.
CONTACT_COLLECTIONS = frozenset({0x000D0020, 0x000D0021, 0x000D0022})

# Collection types.
PHYSICAL, APPLICATION, LOGICAL = 0, 1, 2


@dataclass(frozen=True, slots=True)
class Field:
    """One field of a report: where its bits are and what they mean.

    `usage` is the full 32-bit usage (page << 16 | id); an array field has
    the list of usages its values index in `usages`. `collection` numbers the
    innermost collection instance the field sits in (descriptor order), so
    that the fields of one finger of a multi-touch report can be grouped;
    `logical` and `physical` are the usages of the innermost logical and
    physical collections (0 when none). `group` numbers the innermost
    Stylus, Puck or Finger collection (else the application collection): the
    fields of one contact share it, however the device nests its collections.
    """

    report_id: int  # 0 for the unnumbered report
    usage: int
    bit_offset: int
    bit_size: int
    count: int
    logical_min: int
    logical_max: int
    physical_min: int
    physical_max: int
    unit: int
    unit_exponent: int
    flags: int
    application: int
    collection: int = 0
    logical: int = 0
    physical: int = 0
    usages: tuple[int, ...] = ()
    group: int = 0

    @property
    def constant(self) -> bool:
        return bool(self.flags & CONSTANT)

    @property
    def variable(self) -> bool:
        return bool(self.flags & VARIABLE)

    @property
    def relative(self) -> bool:
        return bool(self.flags & RELATIVE)

    @property
    def array(self) -> bool:
        return not self.flags & (CONSTANT | VARIABLE)

    @property
    def signed(self) -> bool:
        """Two's complement when the logical minimum is negative (the kernel's reading)."""
        return self.logical_min < 0 and self.bit_size > 1


@dataclass(slots=True)
class Report:
    """All fields of one report ID of one type, in bit order."""

    report_id: int  # 0 when the device does not number its reports
    type: ReportType
    application: int
    bit_size: int = 0
    fields: list[Field] = field(default_factory=list)

    @property
    def numbered(self) -> bool:
        return self.report_id != 0

    @property
    def byte_size(self) -> int:
        return (self.bit_size + 7) // 8


@dataclass(slots=True)
class ReportDescriptor:
    """A parsed descriptor: the reports of each type, keyed by report ID (0: unnumbered)."""

    raw: bytes
    input_reports: dict[int, Report] = field(default_factory=dict)
    output_reports: dict[int, Report] = field(default_factory=dict)
    feature_reports: dict[int, Report] = field(default_factory=dict)

    @property
    def numbered(self) -> bool:
        return any(
            rid != 0
            for reports in (self.input_reports, self.output_reports, self.feature_reports)
            for rid in reports
        )

    def reports(self, kind: ReportType) -> dict[int, Report]:
        return {
            ReportType.INPUT: self.input_reports,
            ReportType.OUTPUT: self.output_reports,
            ReportType.FEATURE: self.feature_reports,
        }[kind]


@dataclass(slots=True)
class _Globals:
    usage_page: int = 0
    logical_min: int = 0
    logical_max_raw: int = 0  # the sign of a maximum depends on its minimum: read at use
    logical_max_size: int = 0
    physical_min: int = 0
    physical_max_raw: int = 0
    physical_max_size: int = 0
    unit: int = 0
    unit_exponent: int = 0
    report_size: int = 0
    report_count: int = 0
    report_id: int = 0


@dataclass(slots=True)
class _Locals:
    # (usage, declared with a short (<= 2 byte) item) pairs, in order
    usages: list[tuple[int, bool]] = field(default_factory=list)
    usage_min: int = 0
    usage_max: int = 0
    usage_min_short: bool = True
    usage_max_short: bool = True
    have_min: bool = False
    have_max: bool = False


def _signed_max(raw: int, size: int, minimum: int) -> int:
    """A maximum is read as signed when its minimum is negative (the kernel's rule)."""
    if minimum < 0 and size > 0 and raw >> (8 * size - 1):
        return raw - (1 << (8 * size))
    return raw


def _unit_exponent(item: Item) -> int:
    """Unit Exponent is a 4-bit signed nibble (HID 1.11 table 6.2.2.7); wider values are signed."""
    if item.udata < 16:
        return item.udata - 16 if item.udata > 7 else item.udata
    return item.sdata


class _Parser:
    def __init__(self, raw: bytes) -> None:
        self.desc = ReportDescriptor(raw=raw)
        self.g = _Globals()
        self.stack: list[_Globals] = []
        self.loc = _Locals()
        # open collections: (type, usage, instance number)
        self.collections: list[tuple[int, int, int]] = []
        self.n_collections = 0
        self.application = 0
        self.n_fields = 0
        self.saw_unnumbered_main = False

    def run(self) -> ReportDescriptor:
        for item in iter_items(self.desc.raw):
            if item.type == MAIN:
                self._main(item)
            elif item.type == GLOBAL:
                self._global(item)
            elif item.type == LOCAL:
                self._local(item)
            else:
                raise DescriptorError(
                    f"reserved item type at byte {item.offset} (prefix with type 3)"
                )
        if self.collections:
            raise DescriptorError(
                f"{len(self.collections)} collection(s) never closed: unbalanced collections"
            )
        if self.saw_unnumbered_main and self.desc.numbered:
            raise DescriptorError(
                "the descriptor mixes a report without report ID and numbered reports"
            )
        return self.desc

    # -- globals -----------------------------------------------------------
    def _global(self, item: Item) -> None:
        g = self.g
        tag = item.tag
        if tag == 0x0:
            g.usage_page = item.udata & 0xFFFF
        elif tag == 0x1:
            g.logical_min = item.sdata
        elif tag == 0x2:
            g.logical_max_raw, g.logical_max_size = item.udata, item.size
        elif tag == 0x3:
            g.physical_min = item.sdata
        elif tag == 0x4:
            g.physical_max_raw, g.physical_max_size = item.udata, item.size
        elif tag == 0x5:
            g.unit_exponent = _unit_exponent(item)
        elif tag == 0x6:
            g.unit = item.udata
        elif tag == 0x7:
            if item.udata > MAX_REPORT_SIZE_BITS:
                raise DescriptorError(
                    f"Report Size {item.udata} at byte {item.offset} is above "
                    f"{MAX_REPORT_SIZE_BITS} bits"
                )
            g.report_size = item.udata
        elif tag == 0x8:
            if not 0 < item.udata <= 255:
                raise DescriptorError(
                    f"Report ID {item.udata} at byte {item.offset} is outside 1..255"
                )
            g.report_id = item.udata
        elif tag == 0x9:
            if item.udata > MAX_REPORT_COUNT:
                raise DescriptorError(
                    f"Report Count {item.udata} at byte {item.offset} exceeds {MAX_REPORT_COUNT}"
                )
            g.report_count = item.udata
        elif tag == 0xA:
            if len(self.stack) >= MAX_GLOBAL_STACK:
                raise DescriptorError(f"Push at byte {item.offset}: global stack overflow")
            self.stack.append(replace(g))
        elif tag == 0xB:
            if not self.stack:
                raise DescriptorError(f"Pop at byte {item.offset} without a matching Push")
            self.g = self.stack.pop()
        else:
            raise DescriptorError(f"reserved global item tag 0x{tag:x} at byte {item.offset}")

    # -- locals ------------------------------------------------------------
    def _local(self, item: Item) -> None:
        loc = self.loc
        page = self.g.usage_page << 16
        short = item.size <= 2
        value = (item.udata | page) if short else item.udata
        if item.tag == 0x0:
            loc.usages.append((value, short))
        elif item.tag == 0x1:
            loc.usage_min, loc.usage_min_short, loc.have_min = value, short, True
        elif item.tag == 0x2:
            loc.usage_max, loc.usage_max_short, loc.have_max = value, short, True
        # Designator, string and delimiter items (tags 3..10) carry nothing
        # a decoder needs; reserved local tags are ignored as the kernel does.

    def _resolved_usages(self) -> tuple[list[int], int, int]:
        """Usages with the last Usage Page applied, as the kernel does at a main item.

        A short usage declared before a later Usage Page change takes the
        page in force at the main item (hid-core.c, hid_concatenate_last_usage_page).
        """
        page = self.g.usage_page << 16
        loc = self.loc
        usages = [u for u, _ in loc.usages]
        for i in range(len(loc.usages) - 1, -1, -1):
            u, short = loc.usages[i]
            if not short:
                continue
            if u & 0xFFFF0000 == page:
                break
            usages[i] = (u & 0xFFFF) | page
        umin, umax = loc.usage_min, loc.usage_max
        if loc.have_max and loc.usage_max_short and umax & 0xFFFF0000 != page:
            umax = (umax & 0xFFFF) | page
            if loc.usage_min_short:
                umin = (umin & 0xFFFF) | page
        return usages, umin, umax

    # -- main items --------------------------------------------------------
    def _main(self, item: Item) -> None:
        tag = item.tag
        if tag == 0xA:
            self._open_collection(item)
        elif tag == 0xC:
            if not self.collections:
                raise DescriptorError(
                    f"End Collection at byte {item.offset} without an open collection: "
                    "unbalanced collections"
                )
            self.collections.pop()
            self.application = next(
                (u for t, u, _ in reversed(self.collections) if t == APPLICATION), 0
            )
        elif tag in (0x8, 0x9, 0xB):
            kind = {0x8: ReportType.INPUT, 0x9: ReportType.OUTPUT, 0xB: ReportType.FEATURE}[tag]
            self._data_item(item, kind)
        else:
            raise DescriptorError(f"reserved main item tag 0x{tag:x} at byte {item.offset}")
        self.loc = _Locals()  # locals end at every main item (HID 1.11, 6.2.2.8)

    def _open_collection(self, item: Item) -> None:
        if len(self.collections) >= MAX_COLLECTION_DEPTH:
            raise DescriptorError(
                f"collections nested deeper than {MAX_COLLECTION_DEPTH} at byte {item.offset}"
            )
        usages, umin, _ = self._resolved_usages()
        usage = usages[-1] if usages else (umin if self.loc.have_min else 0)
        kind = item.udata & 0xFF
        self.n_collections += 1
        self.collections.append((kind, usage, self.n_collections))
        if kind == APPLICATION:
            self.application = usage

    def _data_item(self, item: Item, kind: ReportType) -> None:
        g = self.g
        reports = self.desc.reports(kind)
        rid = g.report_id
        report = reports.get(rid)
        if report is None:
            report = Report(rid, kind, self.application, bit_size=8 if rid else 0)
            reports[rid] = report
        if rid == 0:
            self.saw_unnumbered_main = True
        # Zero-size or zero-count items are kept as hid-tools keeps them (they
        # decode to nothing useful, but the field list stays comparable).
        size, count = g.report_size, g.report_count
        start = report.bit_size
        report.bit_size += size * count
        if report.bit_size > 8 * MAX_REPORT_BYTES:
            raise DescriptorError(
                f"{kind.value} report {rid} grows beyond {MAX_REPORT_BYTES} bytes "
                f"at byte {item.offset}"
            )
        flags = item.udata
        usages, umin, umax = self._resolved_usages()
        # As in hid-tools: a range needs non-zero ends (a lone Usage Maximum
        # whose page differs from the current one gets a minimum of page:0);
        # a reversed range gives every element the minimum, an array no usages.
        have_range = umin != 0 and umax != 0
        logical = next((u for t, u, _ in reversed(self.collections) if t == LOGICAL), 0)
        physical = next((u for t, u, _ in reversed(self.collections) if t == PHYSICAL), 0)
        instance = self.collections[-1][2] if self.collections else 0
        group = next(
            (n for _, u, n in reversed(self.collections) if u in CONTACT_COLLECTIONS),
            next((n for t, _, n in reversed(self.collections) if t == APPLICATION), 0),
        )
        base = Field(
            report_id=rid,
            usage=0,
            bit_offset=start,
            bit_size=size,
            count=1,
            logical_min=g.logical_min,
            logical_max=_signed_max(g.logical_max_raw, g.logical_max_size, g.logical_min),
            physical_min=g.physical_min,
            physical_max=_signed_max(g.physical_max_raw, g.physical_max_size, g.physical_min),
            unit=g.unit,
            unit_exponent=g.unit_exponent,
            flags=flags,
            application=self.application,
            collection=instance,
            logical=logical,
            physical=physical,
            group=group,
        )
        new: list[Field] = []
        if flags & (CONSTANT | VARIABLE):
            if have_range:
                usage = umin  # counts up to the maximum, then repeats it
                for i in range(count):
                    new.append(_at(base, usage, start + i * size))
                    if usage < umax:
                        usage += 1
            elif usages:
                for i in range(count):
                    u = usages[i] if i < len(usages) else usages[-1]
                    new.append(_at(base, u, start + i * size))
            else:
                # padding: one field; a lone Usage Minimum still names it (hid-tools does)
                usage = umin if self.loc.have_min else 0
                new.append(replace(base, usage=usage, bit_size=size * count))
        else:
            # The kernel clamps a usage range to HID_MAX_USAGES (hid_parser_local);
            # so do we, or a 10-byte range of 2^32 usages exhausts memory.
            if have_range and umax - umin >= MAX_REPORT_COUNT:
                umax = umin + MAX_REPORT_COUNT - 1
            arr_usages = tuple(range(umin, umax + 1)) if have_range else tuple(usages)
            usage = logical or self.application
            new.append(replace(base, usage=usage, count=count, usages=arr_usages))
        self.n_fields += len(new)
        if self.n_fields > MAX_FIELDS:
            raise DescriptorError(f"more than {MAX_FIELDS} fields: not a plausible descriptor")
        report.fields.extend(new)


def _at(base: Field, usage: int, bit_offset: int) -> Field:
    """`base` for one usage at one offset: `dataclasses.replace` without its per-call cost.

    A variable item becomes one field per usage, so a 64-byte vendor report
    is 64 fields; replace() took half of the parse time of the shared
    descriptors (the coverage benchmark parses hundreds).
    """
    b = base
    return Field(
        b.report_id,
        usage,
        bit_offset,
        b.bit_size,
        b.count,
        b.logical_min,
        b.logical_max,
        b.physical_min,
        b.physical_max,
        b.unit,
        b.unit_exponent,
        b.flags,
        b.application,
        b.collection,
        b.logical,
        b.physical,
        b.usages,
        b.group,
    )


def parse_descriptor(raw: bytes) -> ReportDescriptor:
    """Parse a report descriptor; any defect raises `DescriptorError` naming the byte."""
    return _Parser(bytes(raw)).run()

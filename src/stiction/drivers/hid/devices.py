"""What the HID path takes from the device catalogue (stiction.drivers.catalogue).

The catalogue holds the facts; this module turns what applies to one
device into a `DeviceEntry`, the form ReportStream, the hidraw backend and
`hid describe` use. The user's overlay (``hid-devices.toml``) is part of the
catalogue, with today's format (a top-level ``id``) still accepted.
"""

from __future__ import annotations

import logging
from collections.abc import Mapping
from dataclasses import dataclass, field
from functools import cache

from stiction.drivers.catalogue import load
from stiction.drivers.catalogue.load import USER_TABLE_ENV, user_table_path
from stiction.drivers.catalogue.resolve import Resolved, merge
from stiction.drivers.catalogue.resolve import lookup as catalogue_lookup
from stiction.drivers.catalogue.schema import INIT_KINDS, REPORT_FIXUPS, Entry
from stiction.drivers.hid.families import Geometry
from stiction.drivers.hid.families import descriptor as family_descriptor

__all__ = [
    "INIT_KINDS",
    "REPORT_FIXUPS",
    "USER_TABLE_ENV",
    "DeviceEntry",
    "builtin_table",
    "from_resolved",
    "lookup",
    "parse_table",
    "pick_variant",
    "user_table",
    "user_table_path",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class DeviceEntry:
    vid: int
    pid: int
    name: str
    source: str
    init: str | None = None
    size_m: tuple[float, float] | None = None
    pen_reports: frozenset[int] = frozenset()
    usage_aliases: dict[int, int] = field(default_factory=dict)
    descriptor: bytes | None = None
    report_fixup: str | None = None
    family: str | None = None
    """A vendor report family (families.py): its reports are read by that family's
    fix-up into the normalised report that `descriptor` (generated) describes."""
    geometry: Geometry | None = None
    size_layer: str | None = None
    """Which catalogue layer gave `size_m`: "user", "builtin" or "generated".
    A generated (OpenTabletDriver) size only fills in for a descriptor without
    one; a hand-written or user size wins over the descriptor (docs/devices.md)."""
    init_reports: tuple[tuple[str, bytes], ...] = ()
    """("feature" | "output", bytes) sent when opened live, after `init`."""
    parser: str | None = None
    """OpenTabletDriver's report parser for this device (a fact, not used to decode)."""
    init_layer: str | None = None
    """Which catalogue layer asked for `init`: a generated one is tried, and if
    it fails the device is read as its descriptor describes it."""

    @property
    def size_over_descriptor(self) -> bool:
        return self.size_layer in ("user", "builtin")


def _pair_m(v: object) -> tuple[float, float]:
    assert isinstance(v, list)
    return float(v[0]) / 1000.0, float(v[1]) / 1000.0


@dataclass(frozen=True, slots=True)
class Interface:
    """What a catalogue entry's reader choices look at in the interface's own descriptor."""

    lengths: frozenset[int]
    """The byte sizes (report ID included, as hidraw delivers reports) of the input
    reports it declares but does not describe as a pen."""
    any_pen: bool
    """It describes a pen report (which it is then read by)."""

    @staticmethod
    def of(own: bytes) -> Interface | None:
        """None if the descriptor does not parse."""
        from stiction.drivers.hid.descriptor import parse_descriptor
        from stiction.drivers.hid.pen import build_mappings
        from stiction.errors import DescriptorError, DeviceError

        try:
            desc = parse_descriptor(own)
        except DescriptorError:
            return None
        try:
            readable = build_mappings(desc, "family check", (1.0, 1.0))
        except DeviceError:
            readable = {}
        lengths = frozenset(
            rep.byte_size for rid, rep in desc.input_reports.items() if rid not in readable
        )
        return Interface(lengths, bool(readable))


def family_fits(eff: Mapping[str, object], interface: Interface | None) -> bool:
    """True if a family with this `report_length` is about the interface.

    A tablet's pen and touch interfaces share its vid:pid; OpenTabletDriver
    tells them apart by input report length, so a family goes only where the
    device's own descriptor declares an input report that long, and one it
    does not already describe as a pen: an XP-Pen's firmware pen interface
    declares its 10-byte pen report in full, and is read by it, while the
    vendor-mode report the family reads comes on another interface. Without
    a length (the models sharing the id disagree on it) the family goes only
    where the descriptor describes no pen at all. An unparsable descriptor
    (`interface` None) keeps the family (it may be why the entry exists).
    """
    if "family" not in eff or interface is None:
        return True
    length = eff.get("report_length")
    if not isinstance(length, int):  # models of this id disagree on it
        return not interface.any_pen
    return length in interface.lengths


def pick_variant(
    variants: object, interface: Interface | None
) -> tuple[str, Mapping[str, object]] | None:
    """The `by_report_length` variant for this interface: the one whose length is that
    of an input report its descriptor declares and does not read as a pen.

    None where no variant fits, where the descriptor does not parse (nothing
    tells the models apart then), and where more than one fits: two models'
    reports on one interface is not something either model sends, so
    neither is chosen (as with two catalogue entries matching equally well).
    """
    if not isinstance(variants, dict) or interface is None:
        return None
    fits = [(k, v) for k, v in variants.items() if int(k) in interface.lengths]
    if len(fits) != 1:
        if fits:
            log.info("report lengths %s all fit this interface: none is used",
                     ", ".join(k for k, _ in fits))  # fmt: skip
        return None
    return fits[0]


def from_resolved(r: Resolved, own: bytes | None = None) -> DeviceEntry:
    """The HID view of what the catalogue says about one device.

    `own`: the interface's own report descriptor, where known; a family whose
    report length it does not declare is left out (see `family_fits`).
    """
    eff = dict(r.effects)
    origin = dict(r.origin)
    variants = eff.pop("by_report_length", None)
    if own is not None and ("family" in eff or variants is not None):
        interface = Interface.of(own)  # parsed once, for both choices
        chosen = pick_variant(variants, interface)
        if chosen is not None:
            eff.update(chosen[1])
            eff["report_length"] = int(chosen[0])
            origin.update(dict.fromkeys(chosen[1], r.origin["by_report_length"]))
        if not family_fits(eff, interface):
            eff.pop("family", None)
    if "report_fixup" in eff and "family" in eff and origin["family"].layer == "generated":
        # A hand-written fix-up reads the device's own descriptor; a generated
        # family would swap that descriptor for its own. The hand-written entry
        # wins, as everywhere (the Yiynova MVP20U+RH, 5543:004d, has both).
        eff.pop("family")
    size_m = _pair_m(eff["size_mm"]) if "size_mm" in eff else None
    size_layer = origin["size_mm"].layer if "size_mm" in eff else None
    family = eff.get("family")
    geometry = None
    descriptor = bytes.fromhex(str(eff["descriptor"])) if "descriptor" in eff else None
    if isinstance(family, str) and size_m is not None:
        geometry = Geometry(
            int(eff["max_x"]),  # type: ignore[call-overload]
            int(eff["max_y"]),  # type: ignore[call-overload]
            int(eff["max_pressure"]),  # type: ignore[call-overload]
            size_m[0] * 1000.0,
            size_m[1] * 1000.0,
            origin["family"].source,
        )
        descriptor = family_descriptor(geometry)
        size_layer = origin["family"].layer
    pen_reports = eff.get("pen_reports", [])
    aliases = eff.get("usage_aliases", {})
    assert isinstance(pen_reports, list) and isinstance(aliases, dict)
    init_reports: list[tuple[str, bytes]] = []
    # Init reports switch a tablet into a vendor mode; stiction sends them only
    # where it reads that mode (a family) or where a hand-written entry says so.
    if geometry is not None:
        for kind in ("feature", "output"):
            reports = eff.get(f"{kind}_init", [])
            assert isinstance(reports, list)
            init_reports += [(kind, bytes.fromhex(h)) for h in reports]
    init = eff.get("init")
    fixup = eff.get("report_fixup")
    parser = eff.get("parser")
    return DeviceEntry(
        r.entry.match.vid,
        r.entry.match.pid,
        r.entry.name,
        r.source,
        init if isinstance(init, str) else None,
        size_m,
        frozenset(int(x) for x in pen_reports),
        {int(str(k), 16): int(str(v), 16) for k, v in aliases.items()},
        descriptor,
        fixup if isinstance(fixup, str) else None,
        family if isinstance(family, str) else None,
        geometry,
        size_layer,
        tuple(init_reports),
        parser if isinstance(parser, str) else None,
        origin["init"].layer if "init" in eff else None,
    )


def _table(entries: tuple[Entry, ...]) -> dict[tuple[int, int], DeviceEntry]:
    """Entries matched by vid:pid alone, keyed by it (what a udev rule can name)."""
    out = {}
    for e in entries:
        if e.match.specificity == 0:
            r = merge([e], e.match.vid, e.match.pid)
            assert r is not None
            out[(e.match.vid, e.match.pid)] = from_resolved(r)
    return out


def parse_table(text: str, where: str = "devices.toml") -> dict[tuple[int, int], DeviceEntry]:
    """A table in the catalogue's schema, validated; its vid:pid entries by id."""
    return _table(load.parse_toml(text, where, "user"))


@cache
def builtin_table() -> dict[tuple[int, int], DeviceEntry]:
    """The hand-written vid:pid entries stiction ships (the udev rules list these ids)."""
    return _table(load.builtin())


def user_table() -> dict[tuple[int, int], DeviceEntry]:
    """The user's vid:pid entries, read on every call so edits apply at once."""
    return _table(load.user())


def lookup(
    vid: int,
    pid: int,
    strings: Mapping[int, str] | None = None,
    name: str | None = None,
    *,
    descriptor: bytes | None = None,
) -> DeviceEntry | None:
    """What the catalogue says about a device (the user's overlay first); None if nothing.

    `strings` are the USB string descriptors read from a live device (index
    -> text); without them only entries that need none apply. `descriptor`,
    the interface's own report descriptor, keeps a pen family off the
    tablet's other interfaces.
    """
    r = catalogue_lookup(vid, pid, strings, name)
    return from_resolved(r, descriptor) if r is not None else None

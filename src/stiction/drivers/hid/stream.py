"""Raw reports of one device -> PenSamples, with every bad report counted, never raised.

This is the part shared by the hidraw backend, the replay of recordings
and the synthetic tablet: they differ only in where the bytes come from.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Callable

from stiction.drivers.hid.descriptor import ReportDescriptor
from stiction.drivers.hid.devices import DeviceEntry
from stiction.drivers.hid.families import NO_IN_RANGE, FamilyFixup
from stiction.drivers.hid.pen import ContactTracker, build_mappings, device_kind
from stiction.drivers.hid.report_code import ReportFn, compile_feed, compile_report
from stiction.drivers.sample import PenSample
from stiction.errors import DeviceError

log = logging.getLogger(__name__)


class ReportStream:
    """Decodes one device's input reports; `stats` counts what happened to each.

    Counters: `reports` (all reports fed), `samples`, `ignored` (valid
    reports that carry no contact, e.g. vendor or mouse reports),
    `short_reports`, `unknown_report_id`, `empty_reports`, `bad_values`, and
    `clamped_positions` (coordinates outside the declared range, kept on the surface).
    The first few malformed reports are logged, the rest only counted, so a
    misbehaving device cannot flood the log.
    """

    LOG_FIRST = 5

    def __init__(
        self,
        desc: ReportDescriptor,
        device: str,
        size_m: tuple[float, float] | None = None,
        entry: DeviceEntry | None = None,
        fixup: Callable[[bytes], bytes | None] | None = None,
        proximity_timeout: float | None = None,
    ) -> None:
        """`size_m` (the user's) wins over the catalogue's and the descriptor's size.

        A hand-written catalogue size wins over the descriptor's (such an entry
        exists because the descriptor is wrong); a generated one is used only
        where the descriptor gives no physical size (docs/devices.md).

        `fixup` rewrites each raw report before decoding (vendor formats the
        descriptor cannot express); returning None drops the report as ignored.
        A vendor family's (families.FamilyFixup, also made here from an
        `entry` naming a family) is not called on the generated path: its
        reader's values go straight into the contact code (report_code.py).
        `proximity_timeout`: for tablets that report no in-range state, the
        pen counts as gone this many seconds after its last report (see `idle`);
        fixed here (the generated feed keeps report times only when it is set).
        """
        if fixup is None and entry is not None and entry.descriptor is not None:
            # The device table's descriptor replaces the device's own on every
            # path (live, replay, `hid decode`), not only when opened live.
            from stiction.drivers.hid.descriptor import parse_descriptor

            desc = parse_descriptor(entry.descriptor)
        self.desc = desc
        if fixup is None and entry is not None and entry.report_fixup is not None:
            from stiction.drivers.hid.uclogic import FIXUPS

            fixup = FIXUPS[entry.report_fixup]
        if fixup is None and entry is not None and entry.family and entry.geometry:
            fixup = FamilyFixup(entry.family, entry.geometry)
        if isinstance(fixup, FamilyFixup) and fixup.family in NO_IN_RANGE:
            from stiction.drivers.hid.uclogic import PROXIMITY_TIMEOUT_S

            if proximity_timeout is None:
                proximity_timeout = PROXIMITY_TIMEOUT_S  # no in-range bit: see `idle`
        self.fixup = fixup
        self.proximity_timeout = proximity_timeout
        self._last_report_t: float | None = None
        self.device = device
        pen_reports = entry.pen_reports if entry else frozenset()
        aliases = entry.usage_aliases if entry else None
        kind = device_kind(desc, pen_reports)
        self.size_from = "given" if size_m is not None else "descriptor"
        """Where the surface size came from: "given" (the caller's), "catalogue", "descriptor"."""
        if size_m is None and entry is not None and entry.geometry is not None:
            self.size_from = "catalogue"  # the family's generated descriptor declares it
        if size_m is None and entry is not None and entry.size_m is not None:
            if entry.size_over_descriptor:
                size_m, self.size_from = entry.size_m, "catalogue"
            elif kind == "pen":
                # A generated (OpenTabletDriver) size only fills in for a
                # descriptor that gives none: the descriptor is this unit's own
                # statement, the catalogue a model's that may share its id. It
                # is a pen area, so a touch interface of the same id (a Wacom
                # Intuos Pro's) does not take it, as on the evdev path.
                try:
                    build_mappings(desc, device, None, pen_reports, aliases)
                except DeviceError:
                    size_m, self.size_from = entry.size_m, "catalogue"
        self.mappings = build_mappings(desc, device, size_m, pen_reports, aliases)
        if not self.mappings:
            apps = sorted({f"0x{r.application:08x}" for r in desc.input_reports.values()})
            raise DeviceError(
                f"{device}: no pen, touch screen or touchpad report in its descriptor "
                f"(input report applications: {', '.join(apps) or 'none'}); if it is a "
                "tablet whose pen sits in other reports, its device table entry can name "
                "them (pen_reports, usage_aliases)"
            )
        self.numbered = desc.numbered
        self.known_ids = set(desc.input_reports)
        self.kind = kind
        self._counts: Counter[str] = Counter()
        self._fed = 0
        self._made = 0
        self._sampled = False
        """`reports` and `samples` as plain ints on the hot path (see `stats`)."""
        self.tracker = ContactTracker(self._counts)
        self._compiled: dict[int, tuple[ReportFn, int]] = {}
        """Report ID -> its generated path (report_code.py) and the bytes it needs."""
        active, last = self.tracker.active, self.tracker.last
        for rid, m in self.mappings.items():
            fn = compile_report(m, active, last, self._counts)
            if fn is not None:
                self._compiled[rid] = (fn, m.decoder.byte_size)
        self.family = self.fixup if isinstance(self.fixup, FamilyFixup) else None
        """The vendor family whose reader the generated feed calls, None for other devices."""
        self.feed: ReportFn = self._compile(direct=True)
        """The samples of one report received at `t`; a bad report is counted, never raised.

        One generated function per device (report_code.compile_feed): the
        counting, the fix-up and each contact report ID's path (ContactTracker's
        work with the layout's answers written in) in one call; for a vendor
        family, its reader's values without a normalised report in between.
        Everything else, and finger reports with a Contact Count, goes
        through `_rest` and ContactTracker; `_feed` is the same as a method.
        """
        # The surface is that of the device's kind: a node with a pen and a
        # touch screen is a pen (device_kind), so its size is the pen's, even
        # where the touch report comes first in the descriptor.
        self.surface_size: tuple[float, float] | None = None
        layouts = [c for m in self.mappings.values() for c in m.contacts]
        own = [c for c in layouts if c.finger == (self.kind != "pen")] or layouts
        if own:
            self.surface_size = (own[0].width_m, own[0].height_m)

    @property
    def stats(self) -> Counter[str]:
        """The counters (see the class doc).

        Two counters move at every report; a Counter's `+=` is a lookup and
        a store on a dict subclass, so feed keeps them as ints, written into
        the Counter here. Only the feeding thread changes the ints; a reader
        copies them, so no count is lost to a reader on another thread.
        """
        c = self._counts
        if self._fed:
            c["reports"] = self._fed
        if self._sampled or self._made:
            c["samples"] = self._made
        return c

    def _bad(self, what: str, message: str) -> list[PenSample]:
        self._counts[what] += 1
        if self._counts[what] <= self.LOG_FIRST:
            log.warning("%s: %s (skipped)", self.device, message)
        return []

    def _compile(self, direct: bool) -> ReportFn:
        """This stream's generated feed; `direct`: a family's reader values without its bytes."""
        return compile_feed(
            self,
            self.mappings,
            self.numbered,
            self.fixup,
            self.tracker.active,
            self.tracker.last,
            self._counts,
            frozenset(self.known_ids - set(self.mappings)),
            timed=self.proximity_timeout is not None,
            family=self.family if direct else None,
        )

    def use_bytes_path(self) -> None:
        """A vendor family's reports through its fix-up's normalised bytes, then the generated feed.

        The family path before the generated feed took the reader's values
        directly: the oracle of tests/hid/test_hid_family_path.py and the
        comparison `stiction bench hid` prints. Other devices keep their feed.
        """
        self.feed = self._compile(direct=False)

    def use_tracker(self) -> None:
        """Send every report through ContactTracker, as before report_code.py.

        The reference the generated paths are tested and benchmarked against
        (tests/hid/test_hid_report_code.py, `stiction bench hid`)."""
        self._compiled.clear()
        self.feed = self._feed

    def _feed(self, t: float, data: bytes) -> list[PenSample]:
        """`feed` as a method: what the generated feed does, and the statement of it."""
        self._fed += 1
        self._last_report_t = t
        if self.fixup is not None and data:
            fixed = self.fixup(data)
            if fixed is None:
                self._counts["ignored"] += 1
                return []
            data = fixed
        return self._rest(t, data)

    def _rest(self, t: float, data: bytes) -> list[PenSample]:
        """A report after counting and fix-up: empty, unknown, short, or decoded."""
        if not data:
            return self._bad("empty_reports", "empty report")
        rid = data[0] if self.numbered else 0
        compiled = self._compiled.get(rid)
        if compiled is not None and len(data) >= compiled[1]:
            try:
                samples = compiled[0](t, data)
            except (ValueError, IndexError, OverflowError) as exc:  # pragma: no cover
                return self._bad("bad_values", f"report {rid} could not be decoded: {exc}")
            self._made += len(samples)
            self._sampled = True
            return samples
        m = self.mappings.get(rid)
        if m is None:
            if rid in self.known_ids:
                self._counts["ignored"] += 1
                return []
            return self._bad("unknown_report_id", f"report ID {rid} is not in the descriptor")
        if len(data) < m.decoder.byte_size:
            return self._bad(
                "short_reports",
                f"report {rid} has {len(data)} bytes, the descriptor says {m.decoder.byte_size}",
            )
        try:
            values = m.decoder.decode(data)
            samples = self.tracker.samples(t, m, values)
        except (ValueError, IndexError, OverflowError) as exc:  # pragma: no cover - defensive
            return self._bad("bad_values", f"report {rid} could not be decoded: {exc}")
        self._made += len(samples)
        self._sampled = True
        return samples

    def idle(self, t: float) -> list[PenSample]:
        """No report arrived up to time `t`: end contacts of a tablet without in-range bit.

        Such a tablet simply stops sending when the pen is lifted away; the
        kernel's hid-uclogic ends the contact 100 ms after the last report,
        and so does this, so the pen does not hover forever.
        """
        if (
            self.proximity_timeout is None
            or self._last_report_t is None
            or t - self._last_report_t < self.proximity_timeout
        ):
            return []
        samples = self.tracker.leave_all(t)
        self._made += len(samples)
        self._sampled = True
        return samples

"""Which catalogue entries apply to one device, and what their effects add up to.

Rules (docs/devices.md, "The device catalogue"):

- An entry applies when its vid:pid equals the device's and every other
  match key holds (each string regex found in that USB string, the name
  regex found in the device's name). Keys the caller cannot give (no USB
  strings from a recording) make such entries not apply.
- If any entry of the user's overlay applies, only the user's entries are
  used: an overlay entry replaces what stiction ships for that device.
- Otherwise the applying built-in and generated entries are merged from the
  least to the most specific, so a more specific entry overrides single
  effects of a general one (libinput's quirks add up the same way); at
  equal specificity a hand-written entry overrides a generated one.
- Two applying entries of one layer with equal specificity are ambiguous
  (two models' string patterns both match): neither is used, the device
  gets only what the less specific entries say.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from functools import cache

from stiction.drivers.catalogue import load
from stiction.drivers.catalogue.schema import LAYERS, Entry

log = logging.getLogger(__name__)


@dataclass(frozen=True, slots=True)
class Resolved:
    entry: Entry
    """The most specific entry used: its name is what `hid describe` reports."""
    effects: Mapping[str, object]
    origin: Mapping[str, Entry]
    """Effect key -> the entry it came from (sources and precedence follow it)."""
    used: tuple[Entry, ...]

    @property
    def source(self) -> str:
        return "; ".join(dict.fromkeys(e.source for e in self.used))


def _rank(e: Entry) -> tuple[int, int]:
    return e.match.specificity, LAYERS.index(e.layer)


def merge(
    entries: Iterable[Entry],
    vid: int,
    pid: int,
    strings: Mapping[int, str] | None = None,
    name: str | None = None,
) -> Resolved | None:
    """The entries of `entries` that apply to this device, merged; None if none applies."""
    applying = [
        e
        for e in entries
        if (e.match.vid, e.match.pid) == (vid, pid) and e.match.applies(strings, name)
    ]
    if any(e.layer == "user" for e in applying):
        applying = [e for e in applying if e.layer == "user"]
    by_rank: dict[tuple[int, int], list[Entry]] = {}
    for e in applying:
        by_rank.setdefault(_rank(e), []).append(e)
    used: list[Entry] = []
    for rank in sorted(by_rank):
        group = by_rank[rank]
        if len(group) > 1:
            log.info(
                "%04x:%04x: %s match equally well; none of them is used",
                vid,
                pid,
                ", ".join(repr(e.name) for e in group),
            )
            continue
        used.append(group[0])
    if not used:
        return None
    effects: dict[str, object] = {}
    origin: dict[str, Entry] = {}
    for e in used:
        for k, v in e.effects.items():
            effects[k] = v
            origin[k] = e
    return Resolved(used[-1], effects, origin, tuple(used))


def catalogue() -> tuple[Entry, ...]:
    """Every entry stiction ships and the user added, lowest layer first."""
    return load.generated() + load.builtin() + load.user()


@cache
def _shipped() -> dict[tuple[int, int], tuple[Entry, ...]]:
    """The generated and built-in entries by vid:pid (the user's file is read each time)."""
    out: dict[tuple[int, int], list[Entry]] = {}
    for e in load.generated() + load.builtin():
        out.setdefault((e.match.vid, e.match.pid), []).append(e)
    return {k: tuple(v) for k, v in out.items()}


def for_id(vid: int, pid: int) -> tuple[Entry, ...]:
    """The entries (any layer) whose id is vid:pid."""
    user = tuple(e for e in load.user() if (e.match.vid, e.match.pid) == (vid, pid))
    return _shipped().get((vid, pid), ()) + user


def lookup(
    vid: int, pid: int, strings: Mapping[int, str] | None = None, name: str | None = None
) -> Resolved | None:
    """What the catalogue says about a device; None if nothing."""
    return merge(for_id(vid, pid), vid, pid, strings, name)


def string_indices(vid: int, pid: int) -> tuple[int, ...]:
    """The USB string indices some entry for this id matches on (what a live open reads)."""
    return tuple(sorted({i for e in for_id(vid, pid) for i, _ in e.match.strings}))

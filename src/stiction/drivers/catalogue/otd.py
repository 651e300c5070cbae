"""OpenTabletDriver's tablet facts -> catalogue entries (what tools/gen_catalogue.py writes).

Input: ``../shared/data/tablets/otd-tablets.json``, device facts extracted
from OpenTabletDriver's configuration files (LGPL-3.0; facts only, no code;
its README names the commit). Every entry written here names the
configuration file(s) and commit it comes from.

Truthfulness rules, because one USB id is often shared by many models
(Huion's 256c:006d by 64 in OpenTabletDriver's files):

- Each distinct match -- vid:pid plus OpenTabletDriver's DeviceStrings
  (string descriptor index -> regex) -- becomes one entry. Several models
  claiming the same match (or one model listing it twice) give one entry
  with only the effects they all agree on.
- Every vid:pid also gets an entry with no string keys: the one that
  applies when the strings are unknown (recordings, evdev). It carries the
  effects common to every identifier OpenTabletDriver lists for that id,
  and the surface effects (size, ranges, family) only when no identifier
  of that id needs strings to be recognised: a model that must be told
  apart by its strings is not known to be the only one with that id.
- The Huion initialisation (read string descriptor 200, or 100 on older
  firmware, whose answer gives the tablet's ranges) is set where
  OpenTabletDriver reads string 200 or 100 when opening a tablet with
  Huion's (256c) or UC-Logic's (5543) vendor id; those are the vendors
  whose parameter block Linux's hid-uclogic parses from that answer.
- A report family (families.py) is set only where `family_for` knows one
  for OpenTabletDriver's parser; the parser's name is kept as a fact, and
  so is the input report length OpenTabletDriver matches the interface by
  (`report_length`): the HID path uses a family only on the interface whose
  own descriptor has an input report that long, not on a touch interface
  sharing the id. Where the models of one entry disagree on that length
  (VEIKK's S640 sends 13-byte reports, the S640 V2 9-byte ones, under one
  id), each length with a family gets its own effects under
  `by_report_length`, applied on the interface that declares that length.
  Identifiers for Wacom's Windows driver are left out (`_linux_identifiers`),
  and so are `aux_identifiers` (a tablet's buttons interface, no pen).
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Mapping
from typing import Any

from stiction.drivers.catalogue.schema import SIZE_KEYS
from stiction.drivers.hid.families import family_for

HUION_INIT_VIDS = (0x256C, 0x5543)
HUION_INIT_STRINGS = (100, 200)
_FAMILY_NEEDS = ("max_x", "max_y", "max_pressure", "size_mm")

Record = tuple[dict[str, Any], dict[str, Any]]  # (tablet, identifier)


def _effects(tablet: Mapping[str, Any], ident: Mapping[str, Any]) -> dict[str, object]:
    """Everything one OpenTabletDriver identifier says about a device."""
    vid, pid = int(ident["vid"], 16), int(ident["pid"], 16)
    eff: dict[str, object] = {
        "size_mm": [tablet["width_mm"], tablet["height_mm"]],
        "max_x": tablet["max_x"],
        "max_y": tablet["max_y"],
        "max_pressure": tablet["max_pressure"],
        "parser": ident["report_parser"],
        "report_length": ident["input_report_length"],
        "init_strings": list(ident["init_strings"]),
        "feature_init": list(ident["feature_init_reports"]),
        "output_init": list(ident["output_init_reports"]),
    }
    if vid in HUION_INIT_VIDS and set(ident["init_strings"]) & set(HUION_INIT_STRINGS):
        eff["init"] = "huion-string-descriptor"
    family = family_for(
        ident["report_parser"], tablet["name"], vid, pid, ident["input_report_length"]
    )
    if family is not None:
        eff["family"] = family
    return {k: v for k, v in eff.items() if v not in ([], None)}


def _common(records: list[Record], surface: bool) -> dict[str, object]:
    """The effects every record agrees on (the surface ones only if `surface`)."""
    each = [_effects(t, i) for t, i in records]
    out = {k: v for k, v in each[0].items() if all(e.get(k) == v for e in each[1:])}
    if not surface:
        out = {k: v for k, v in out.items() if k not in SIZE_KEYS}
    if "family" in out and not all(k in out for k in _FAMILY_NEEDS):
        del out["family"]
    return out


def _by_length(records: list[Record], surface: bool, common: Mapping[str, object]) -> dict:  # type: ignore[type-arg]
    """Where the records disagree on the report length, and so `common` has no family:
    the effects each length's records agree on, for each length that has a family
    (hid/devices.py applies one on an interface whose descriptor declares that
    length), without what `common` already says."""
    lengths = sorted({i["input_report_length"] for _, i in records})
    if "family" in common or len(lengths) < 2:
        return {}
    out = {}
    for length in lengths:
        eff = _common([r for r in records if r[1]["input_report_length"] == length], surface)
        if "family" in eff:
            out[str(length)] = {k: v for k, v in eff.items() if common.get(k) != v}
    return out


def _with_variants(records: list[Record], surface: bool) -> dict[str, object]:
    common = _common(records, surface)
    variants = _by_length(records, surface, common)
    return {**common, "by_report_length": variants} if variants else common


def _source(records: list[Record], origin: Mapping[str, str]) -> str:
    files = sorted({t["file"] for t, _ in records})
    where = f"{origin['repo']}@{origin['commit']} {origin['path']}"
    return f"{where}{files[0]}" if len(files) == 1 else f"{where}{{{', '.join(files)}}}"


def _names(records: list[Record]) -> list[str]:
    return sorted({t["name"] for t, _ in records})


def _entry(
    vid: int,
    pid: int,
    strings: tuple[tuple[str, str], ...],
    records: list[Record],
    effects: dict[str, object],
    origin: Mapping[str, str],
    unsure: bool = False,
) -> dict[str, object]:
    """One entry; `unsure`: an id-only entry of an id whose models need strings to
    be told apart, so its name must not claim the model."""
    names = _names(records)
    ident = f"{vid:04x}:{pid:04x}"
    if len(names) > 3:
        name = f"{ident}: one of {len(names)} models"
    elif unsure:
        name = f"{ident}: {' or '.join(names)}, or another model with this id"
    else:
        name = " / ".join(names)
    match: dict[str, object] = {"id": ident}
    if strings:
        match["strings"] = dict(strings)
    out: dict[str, object] = {"name": name, "source": _source(records, origin), "match": match}
    if len(names) > 1:
        out["models"] = names
    out.update(effects)
    return out


def _match_key(ident: Mapping[str, Any]) -> tuple[str, str, tuple[tuple[str, str], ...]]:
    strings = tuple(sorted(ident["device_strings"].items(), key=lambda kv: int(kv[0])))
    return ident["vid"], ident["pid"], strings


def _linux_identifiers(idents: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One model's identifiers without those for Wacom's Windows driver.

    OpenTabletDriver lists many Wacom models twice on one id, told apart by
    input report length: once with the tablet's own protocol parser
    (Intuos3ReportParser, ...) and once with a ``WacomDriver...`` parser for
    the reports as Wacom's own (Windows) driver passes them on. A Linux
    hidraw node carries the tablet's own reports, so the second identifier
    is dropped where the first exists; otherwise their parsers would
    disagree and the model would lose its report family.
    """
    own = {_match_key(i) for i in idents if not i["report_parser"].startswith("WacomDriver")}
    return [
        i
        for i in idents
        if not (i["report_parser"].startswith("WacomDriver") and _match_key(i) in own)
    ]


def generate(data: Mapping[str, Any]) -> dict[str, object]:
    """The generated catalogue file's content (deterministic: same input, same output)."""
    origin = data["source"]
    by_id: dict[tuple[int, int], list[Record]] = defaultdict(list)
    for tablet in data["tablets"]:
        for ident in _linux_identifiers(tablet["identifiers"]):
            by_id[(int(ident["vid"], 16), int(ident["pid"], 16))].append((tablet, ident))
    entries = []
    for (vid, pid), records in sorted(by_id.items()):
        by_strings: dict[tuple[tuple[str, str], ...], list[Record]] = defaultdict(list)
        for t, i in records:
            by_strings[_match_key(i)[2]].append((t, i))
        needs_strings = any(by_strings.keys() - {()})
        common = _with_variants(records, surface=not needs_strings)
        entries.append(_entry(vid, pid, (), records, common, origin, needs_strings))
        for strings, group in sorted(by_strings.items()):
            if strings:
                effects = _with_variants(group, True)
                entries.append(_entry(vid, pid, strings, group, effects, origin))
    return {
        "about": (
            "Generated by tools/gen_catalogue.py from OpenTabletDriver's tablet configurations "
            f"({origin['repo']} at {origin['commit']}, {origin['path']}; LGPL-3.0, device facts "
            "only). Do not edit: change the generator or add a hand-written entry to devices.toml."
        ),
        "device": entries,
    }

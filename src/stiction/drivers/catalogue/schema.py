"""One catalogue entry: match keys (which devices) kept apart from effects (what to do).

The split follows libinput's quirks files (``[section]`` with ``Match*``
keys, then ``Attr*``/``Model*`` keys) and OpenTabletDriver's configurations
(``DigitizerIdentifiers`` with ``DeviceStrings`` beside the specifications):
a device is recognised by its match keys only, so one reading of the
catalogue can say why an entry applied, and the effects never influence it.

Every entry is validated when its file is read, so a typo is a clear error
naming the file and the entry, not a device that silently misbehaves.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass

from stiction.errors import DeviceError

INIT_KINDS = ("huion-string-descriptor", "feature:", "output:")
REPORT_FIXUPS = ("uclogic-v1", "uclogic-v2")
SIZE_KEYS = ("size_mm", "resolution_mm", "max_x", "max_y", "max_pressure", "family")
"""Effects that describe one model's surface: never put on an id several models share."""

EFFECT_KEYS = frozenset(
    {
        "init",
        "init_strings",
        "feature_init",
        "output_init",
        "parser",
        "report_length",
        "models",
        "pen_reports",
        "usage_aliases",
        "descriptor",
        "report_fixup",
        "by_report_length",
        *SIZE_KEYS,
    }
)
_NOT_IN_VARIANT = frozenset({"by_report_length", "models"})
"""Keys a by_report_length variant may not set: it is about one interface of the
entry's device, not another entry."""
LAYERS = ("generated", "builtin", "user")
"""Where an entry was read, lowest first: OpenTabletDriver's facts, the
hand-written table shipped with stiction, the user's overlay."""


@dataclass(frozen=True, slots=True)
class Match:
    """Which devices an entry is about. More keys = more specific."""

    vid: int
    pid: int
    strings: tuple[tuple[int, str], ...] = ()
    """USB string descriptor index -> regular expression (searched, as
    OpenTabletDriver's DeviceStrings are), sorted by index."""
    name: str | None = None
    """A regular expression searched in the device's name (evdev or HID product)."""

    @property
    def specificity(self) -> int:
        return len(self.strings) + (1 if self.name is not None else 0)

    @property
    def id(self) -> str:
        return f"{self.vid:04x}:{self.pid:04x}"

    def describe(self) -> str:
        parts = [self.id]
        parts += [f"string {i} ~ {rx!r}" for i, rx in self.strings]
        if self.name is not None:
            parts.append(f"name ~ {self.name!r}")
        return ", ".join(parts)

    def applies(self, strings: Mapping[int, str] | None, name: str | None) -> bool:
        """True if a device with these USB strings and name is one this entry is about.

        Without strings (a recording, an evdev node) an entry that needs one
        cannot be told to apply, so it does not.
        """
        for index, rx in self.strings:
            if strings is None or index not in strings or not re.search(rx, strings[index]):
                return False
        return self.name is None or (name is not None and re.search(self.name, name) is not None)


@dataclass(frozen=True, slots=True)
class Entry:
    match: Match
    name: str
    source: str
    layer: str
    effects: Mapping[str, object]
    """Validated effect keys as read (see EFFECT_KEYS and docs/devices.md)."""


def _hex(text: object, where: str) -> int:
    if not isinstance(text, str):
        raise DeviceError(f"{where}: {text!r} is not a hex string")
    try:
        return int(text, 16)
    except ValueError:
        raise DeviceError(f"{where}: {text!r} is not a hex number") from None


def _regex(rx: object, where: str) -> str:
    if not isinstance(rx, str):
        raise DeviceError(f"{where}: a match pattern must be a string, got {rx!r}")
    try:
        re.compile(rx)
    except re.error as exc:
        raise DeviceError(f"{where}: bad regular expression {rx!r}: {exc}") from None
    return rx


def parse_match(raw: Mapping[str, object], where: str) -> Match:
    """The match keys: `match = {id, strings, name}`, or a top-level `id` (today's overlay)."""
    m = raw.get("match")
    if m is None:
        m = {"id": raw.get("id")}
    elif "id" in raw:
        raise DeviceError(f"{where}: give 'id' inside 'match' or at the top, not both")
    if not isinstance(m, dict):
        raise DeviceError(f"{where}: 'match' must be a table")
    unknown = set(m) - {"id", "strings", "name"}
    if unknown:
        raise DeviceError(f"{where}: unknown match key(s) {', '.join(sorted(unknown))}")
    ident = m.get("id")
    if not isinstance(ident, str) or ident.count(":") != 1:
        raise DeviceError(f"{where}: 'id' must be \"vvvv:pppp\"")
    vid_s, pid_s = ident.split(":")
    vid, pid = _hex(vid_s, where), _hex(pid_s, where)
    if not (0 <= vid <= 0xFFFF and 0 <= pid <= 0xFFFF):
        raise DeviceError(f"{where}: 'id' {ident!r} is out of range")
    strings_raw = m.get("strings", {})
    if not isinstance(strings_raw, dict):
        raise DeviceError(f"{where}: 'strings' must be a table of index = regex")
    strings = []
    for k, rx in strings_raw.items():
        try:
            index = int(k)
        except ValueError:
            raise DeviceError(f"{where}: string index {k!r} is not a number") from None
        if not 0 <= index <= 255:
            raise DeviceError(f"{where}: string index {index} is not 0..255")
        strings.append((index, _regex(rx, where)))
    name = m.get("name")
    return Match(vid, pid, tuple(sorted(strings)), None if name is None else _regex(name, where))


def _pair(v: object, key: str, where: str) -> None:
    if (
        not isinstance(v, list)
        or len(v) != 2
        or not all(isinstance(x, int | float) and not isinstance(x, bool) and x > 0 for x in v)
    ):
        raise DeviceError(f"{where}: '{key}' must be [width, height], both > 0")


def _hex_list(v: object, key: str, where: str) -> None:
    if not isinstance(v, list):
        raise DeviceError(f"{where}: '{key}' must be a list of hex strings")
    for item in v:
        if not isinstance(item, str):
            raise DeviceError(f"{where}: '{key}' must be a list of hex strings")
        try:
            bytes.fromhex(item)
        except ValueError:
            raise DeviceError(f"{where}: '{key}' item {item!r} is not hex") from None


def _positive_int(v: object, key: str, where: str) -> None:
    if not isinstance(v, int) or isinstance(v, bool) or not 0 < v < 1 << 31:
        raise DeviceError(f"{where}: '{key}' must be a positive integer")


def check_effects(eff: Mapping[str, object], where: str) -> None:
    """Raise DeviceError naming the first effect key whose value is unusable."""
    unknown = set(eff) - EFFECT_KEYS
    if unknown:
        raise DeviceError(
            f"{where}: unknown key(s) {', '.join(sorted(unknown))}; "
            "see docs/devices.md for the catalogue's keys"
        )
    init = eff.get("init")
    if init is not None and (
        not isinstance(init, str) or not any(init.startswith(k) for k in INIT_KINDS)
    ):
        raise DeviceError(f"{where}: unknown init {init!r}; known: {', '.join(INIT_KINDS)}")
    if isinstance(init, str) and ":" in init:
        _hex_list([init.partition(":")[2]], "init", where)
    for key in ("size_mm", "resolution_mm"):
        if key in eff:
            _pair(eff[key], key, where)
    for key in ("max_x", "max_y", "max_pressure", "report_length"):
        if key in eff:
            _positive_int(eff[key], key, where)
    for key in ("feature_init", "output_init"):
        if key in eff:
            _hex_list(eff[key], key, where)
    for key in ("init_strings", "pen_reports"):
        v = eff.get(key, [])
        if not isinstance(v, list) or not all(
            isinstance(r, int) and not isinstance(r, bool) and 0 <= r <= 255 for r in v
        ):
            raise DeviceError(f"{where}: '{key}' must be a list of numbers 0..255")
    for key in ("parser", "descriptor"):
        if key in eff and not isinstance(eff[key], str):
            raise DeviceError(f"{where}: '{key}' must be a string")
    if "descriptor" in eff:
        _hex_list([eff["descriptor"]], "descriptor", where)
    models = eff.get("models", [])
    if not isinstance(models, list) or not all(isinstance(m, str) for m in models):
        raise DeviceError(f"{where}: 'models' must be a list of names")
    aliases = eff.get("usage_aliases", {})
    if not isinstance(aliases, dict):
        raise DeviceError(f"{where}: 'usage_aliases' must be a table")
    for k, v in aliases.items():
        _hex(str(k), where)
        _hex(v, where)
    fixup = eff.get("report_fixup")
    if fixup is not None and fixup not in REPORT_FIXUPS:
        raise DeviceError(
            f"{where}: unknown report_fixup {fixup!r}; known: {', '.join(REPORT_FIXUPS)}"
        )
    _check_family(eff, where)
    if "by_report_length" in eff:
        _check_variants(eff, where)


def _check_variants(eff: Mapping[str, object], where: str) -> None:
    """`by_report_length = { "13" = {...}, "9" = {...} }`: effects for the interface whose
    descriptor declares an input report of that many bytes (see hid/devices.py).

    Models that share an id but send reports of different lengths (VEIKK's
    S640 and S640 V2) can then each get their family, since the interface's
    own descriptor tells them apart, as OpenTabletDriver tells them apart by
    the length. Each variant is checked as the entry it completes.
    """
    variants = eff["by_report_length"]
    if not isinstance(variants, dict) or not variants:
        raise DeviceError(
            f"{where}: 'by_report_length' must be a table of report length = {{ effects }}"
        )
    base = {k: v for k, v in eff.items() if k != "by_report_length"}
    for key, sub in variants.items():
        here = f"{where} by_report_length.{key}"
        try:
            length = int(key)
        except ValueError:
            raise DeviceError(f"{here}: {key!r} is not a report length in bytes") from None
        if not 0 < length < 1 << 16:
            raise DeviceError(f"{here}: a report length is 1..65535 bytes")
        if not isinstance(sub, dict):
            raise DeviceError(f"{here}: must be a table of effects")
        bad = set(sub) & _NOT_IN_VARIANT
        if bad:
            raise DeviceError(f"{here}: {', '.join(sorted(bad))} cannot be set per report length")
        if sub.get("report_length", length) != length:
            raise DeviceError(f"{here}: its 'report_length' must be {length}")
        check_effects({**base, **sub}, here)


def _check_family(eff: Mapping[str, object], where: str) -> None:
    """A family reads reports its descriptor does not describe: it needs their ranges and size."""
    from stiction.drivers.hid.families import FAMILIES

    family = eff.get("family")
    if family is None:
        return
    if not isinstance(family, str) or family not in FAMILIES:
        raise DeviceError(f"{where}: unknown family {family!r}; known: {', '.join(FAMILIES)}")
    for key in ("max_x", "max_y", "max_pressure"):
        if key not in eff:
            raise DeviceError(f"{where}: family {family!r} needs '{key}', a positive integer")
    if "size_mm" not in eff:
        raise DeviceError(f"{where}: family {family!r} needs 'size_mm' = [width, height]")


def parse_entry(raw: object, where: str, layer: str) -> Entry:
    """One [[device]] table (or JSON object) -> Entry; DeviceError naming `where` if bad."""
    if not isinstance(raw, dict):
        raise DeviceError(f"{where}: not a table")
    match = parse_match(raw, where)
    where = f"{where} ({match.id})"
    name, source = raw.get("name", match.id), raw.get("source")
    if not isinstance(name, str) or not isinstance(source, str) or not source:
        raise DeviceError(f"{where}: 'name' and a non-empty 'source' are required")
    effects = {k: v for k, v in raw.items() if k not in ("match", "id", "name", "source")}
    check_effects(effects, where)
    return Entry(match, name, source, layer, effects)

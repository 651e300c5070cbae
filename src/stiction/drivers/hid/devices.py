"""The device table (devices.toml beside this file): quirks as data, like libinput's.

Adding a device means adding a [[device]] table with its source; no code
changes. The file is validated as a whole on load, so a typo in it is a
clear error naming the entry, not a device that silently misbehaves.
"""

from __future__ import annotations

import os
import tomllib
from dataclasses import dataclass, field
from functools import cache
from importlib import resources
from pathlib import Path

from stiction.drivers.hid.families import FAMILIES, Geometry
from stiction.drivers.hid.families import descriptor as family_descriptor
from stiction.errors import DeviceError

INIT_KINDS = ("huion-string-descriptor", "feature:", "output:")
REPORT_FIXUPS = ("uclogic-v1", "uclogic-v2")


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


def _int(text: str, where: str) -> int:
    try:
        return int(text, 16)
    except ValueError:
        raise DeviceError(f"{where}: {text!r} is not a hex number") from None


def _entry(raw: dict[str, object], where: str) -> DeviceEntry:
    ident = raw.get("id")
    if not isinstance(ident, str) or ident.count(":") != 1:
        raise DeviceError(f"{where}: 'id' must be \"vvvv:pppp\"")
    vid_s, pid_s = ident.split(":")
    vid, pid = _int(vid_s, where), _int(pid_s, where)
    where = f"{where} ({ident})"
    name, source = raw.get("name", ident), raw.get("source")
    if not isinstance(name, str) or not isinstance(source, str) or not source:
        raise DeviceError(f"{where}: 'name' and a non-empty 'source' are required")
    init = raw.get("init")
    if init is not None and (
        not isinstance(init, str) or not any(init.startswith(k) for k in INIT_KINDS)
    ):
        raise DeviceError(f"{where}: unknown init {init!r}; known: {', '.join(INIT_KINDS)}")
    size_m = None
    if "size_mm" in raw:
        size = raw["size_mm"]
        if (
            not isinstance(size, list)
            or len(size) != 2
            or not all(isinstance(v, int | float) and v > 0 for v in size)
        ):
            raise DeviceError(f"{where}: 'size_mm' must be [width, height], both > 0")
        size_m = (float(size[0]) / 1000.0, float(size[1]) / 1000.0)
    pen_reports = raw.get("pen_reports", [])
    if not isinstance(pen_reports, list) or not all(
        isinstance(r, int) and 0 <= r <= 255 for r in pen_reports
    ):
        raise DeviceError(f"{where}: 'pen_reports' must be a list of report IDs")
    aliases_raw = raw.get("usage_aliases", {})
    if not isinstance(aliases_raw, dict):
        raise DeviceError(f"{where}: 'usage_aliases' must be a table")
    aliases = {_int(str(k), where): _int(str(v), where) for k, v in aliases_raw.items()}
    report_fixup = raw.get("report_fixup")
    if report_fixup is not None and report_fixup not in REPORT_FIXUPS:
        raise DeviceError(
            f"{where}: unknown report_fixup {report_fixup!r}; known: {', '.join(REPORT_FIXUPS)}"
        )
    desc = raw.get("descriptor")
    descriptor = None
    if desc is not None:
        if not isinstance(desc, str):
            raise DeviceError(f"{where}: 'descriptor' must be a hex string")
        try:
            descriptor = bytes.fromhex(desc)
        except ValueError:
            raise DeviceError(f"{where}: 'descriptor' is not hex") from None
    family, geometry = _family(raw, size_m, where)
    if geometry is not None:
        descriptor = family_descriptor(geometry)
    return DeviceEntry(
        vid,
        pid,
        name,
        source,
        init,
        size_m,
        frozenset(pen_reports),
        aliases,
        descriptor,
        report_fixup if isinstance(report_fixup, str) else None,
        family,
        geometry,
    )


def _family(
    raw: dict[str, object], size_m: tuple[float, float] | None, where: str
) -> tuple[str | None, Geometry | None]:
    """`family` with the ranges its reports do not declare: max_x, max_y, max_pressure, size_mm."""
    family = raw.get("family")
    if family is None:
        return None, None
    if not isinstance(family, str) or family not in FAMILIES:
        raise DeviceError(f"{where}: unknown family {family!r}; known: {', '.join(FAMILIES)}")
    ranges = []
    for key in ("max_x", "max_y", "max_pressure"):
        v = raw.get(key)
        if not isinstance(v, int) or isinstance(v, bool) or not 0 < v < 1 << 31:
            raise DeviceError(f"{where}: family {family!r} needs '{key}', a positive integer")
        ranges.append(v)
    if size_m is None:
        raise DeviceError(f"{where}: family {family!r} needs 'size_mm' = [width, height]")
    source = raw.get("source")
    geom = Geometry(
        ranges[0], ranges[1], ranges[2], size_m[0] * 1000.0, size_m[1] * 1000.0, str(source)
    )
    return family, geom


def parse_table(text: str, where: str = "devices.toml") -> dict[tuple[int, int], DeviceEntry]:
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DeviceError(f"{where}: {exc}") from None
    table: dict[tuple[int, int], DeviceEntry] = {}
    devices = data.get("device", [])
    if not isinstance(devices, list):
        raise DeviceError(f"{where}: expected [[device]] tables")
    for i, raw in enumerate(devices):
        if not isinstance(raw, dict):
            raise DeviceError(f"{where}: device {i + 1} is not a table")
        entry = _entry(raw, f"{where}: device {i + 1}")
        key = (entry.vid, entry.pid)
        if key in table:
            raise DeviceError(f"{where}: {entry.vid:04x}:{entry.pid:04x} is listed twice")
        table[key] = entry
    return table


@cache
def builtin_table() -> dict[tuple[int, int], DeviceEntry]:
    text = resources.files("stiction.drivers.hid").joinpath("devices.toml").read_text("utf-8")
    return parse_table(text, str(Path(__file__).with_name("devices.toml")))


USER_TABLE_ENV = "STICTION_HID_DEVICES"


def user_table_path() -> Path:
    """Where a user's own entries live: $STICTION_HID_DEVICES, else the XDG config dir."""
    env = os.environ.get(USER_TABLE_ENV)
    if env:
        return Path(env)
    base = os.environ.get("XDG_CONFIG_HOME") or str(Path.home() / ".config")
    return Path(base) / "stiction" / "hid-devices.toml"


def user_table() -> dict[tuple[int, int], DeviceEntry]:
    """The user's entries (same format), read on every lookup so edits apply at once.

    Like libinput's local quirks: a device can be made to work without
    touching the installed package; an entry here replaces the built-in one.
    """
    path = user_table_path()
    try:
        text = path.read_text("utf-8")
    except FileNotFoundError:
        return {}
    except OSError as exc:
        raise DeviceError(f"cannot read the device table {path}: {exc}") from None
    return parse_table(text, str(path))


def lookup(vid: int, pid: int) -> DeviceEntry | None:
    """The entry for a device: the user's table first, then the built-in one."""
    return user_table().get((vid, pid)) or builtin_table().get((vid, pid))

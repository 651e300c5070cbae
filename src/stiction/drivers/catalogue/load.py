"""Reading the catalogue's files: generated (OpenTabletDriver), built-in (hand-written), user.

The generated and built-in files ship inside this package; the user's
overlay is today's ``hid-devices.toml`` (``$STICTION_HID_DEVICES``, else
``$XDG_CONFIG_HOME/stiction/hid-devices.toml``), read on every lookup so an
edit applies at once, as libinput reads its local quirks.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from functools import cache
from importlib import resources
from pathlib import Path

from stiction.drivers.catalogue.schema import Entry, Match, parse_entry
from stiction.errors import DeviceError
from stiction.tomlcheck import TomlReader
from stiction.userfiles import read_regular_text
from stiction.xdg import config_home

GENERATED = "otd.json"
BUILTIN = "devices.toml"
USER_TABLE_ENV = "STICTION_HID_DEVICES"


def parse_entries(
    devices: object, where: str, layer: str, locate: Callable[[int], str] | None = None
) -> tuple[Entry, ...]:
    """Validated entries; a DeviceError if two of them claim the same match.

    `locate(i)` says where entry i is (``file:line: device[i]`` for TOML, whose
    lines the shared checker knows); without it, ``file: device[i]``."""
    if not isinstance(devices, list):
        raise DeviceError(f"{where}: expected [[device]] tables")
    at = locate or (lambda i: f"{where}: device[{i}]")
    seen: dict[Match, Entry] = {}
    out = []
    for i, raw in enumerate(devices):
        entry = parse_entry(raw, at(i), layer)
        other = seen.get(entry.match)
        if other is not None:
            raise DeviceError(
                f"{at(i)}: {entry.match.describe()} is listed twice "
                f"({other.name!r} and {entry.name!r})"
            )
        seen[entry.match] = entry
        out.append(entry)
    return tuple(out)


def parse_toml(text: str, where: str, layer: str) -> tuple[Entry, ...]:
    """A TOML device table, read by the shared checker so errors carry the entry's line."""
    r = TomlReader(where, text, DeviceError)
    return parse_entries(
        r.data.get("device", []), where, layer, lambda i: r.location(("device", i))
    )


def parse_json(text: str, where: str, layer: str) -> tuple[Entry, ...]:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise DeviceError(f"{where}: {exc}") from None
    if not isinstance(data, dict):
        raise DeviceError(f"{where}: expected an object with a 'device' list")
    return parse_entries(data.get("device", []), where, layer)


def _package_file(name: str) -> tuple[str, str]:
    text = resources.files("stiction.drivers.catalogue").joinpath(name).read_text("utf-8")
    return text, str(Path(__file__).with_name(name))


@cache
def generated() -> tuple[Entry, ...]:
    """The entries generated from OpenTabletDriver's configurations (tools/gen_catalogue.py)."""
    text, where = _package_file(GENERATED)
    return parse_json(text, where, "generated")


@cache
def builtin() -> tuple[Entry, ...]:
    """The hand-written entries shipped with stiction (HID and evdev quirks)."""
    text, where = _package_file(BUILTIN)
    return parse_toml(text, where, "builtin")


def user_table_path() -> Path:
    """Where a user's own entries live: $STICTION_HID_DEVICES, else the XDG config dir."""
    env = os.environ.get(USER_TABLE_ENV)
    if env:
        return Path(env)
    return config_home() / "stiction" / "hid-devices.toml"


MAX_USER_TABLE_BYTES = 1 << 20
"""A user's own device entries: a few lines each."""


def user() -> tuple[Entry, ...]:
    """The user's overlay (same schema), read on every call; () when there is none."""
    path = user_table_path()
    if not path.exists():
        return ()
    # Read like every user file: a FIFO named by $STICTION_HID_DEVICES blocked
    # every command that looks a device up, and a binary file was a
    # UnicodeDecodeError traceback.
    text = read_regular_text(path, MAX_USER_TABLE_BYTES, DeviceError, "device table")
    return parse_toml(text, str(path), "user")

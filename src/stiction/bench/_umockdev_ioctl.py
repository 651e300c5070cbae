"""Answer a mocked evdev node's ioctls from a `.ioctl` table (umockdev GI controllers).

Imported by the controllers that umockdev needs in the system python3 (the
only one with `gi`): the fault benchmark's device storm and the evdev tests'
unplug controller. It must import nothing beyond the standard library, so
that those scripts can load it by path without stiction installed.
"""

from __future__ import annotations

import errno
import re
from typing import Any

_READ = 2


def _ioc(direction: int, nr: int, size: int) -> int:
    return (direction << 30) | (size << 16) | (ord("E") << 8) | nr


_NR = {"EVIOCGVERSION": 0x01, "EVIOCGID": 0x02, "EVIOCGNAME": 0x06, "EVIOCGPROP": 0x09}
_NR |= {"EVIOCGKEY": 0x18, "EVIOCGLED": 0x19, "EVIOCGBIT": 0x20, "EVIOCGABS": 0x40}
_NR |= {"EVIOCGEFFECTS": 0x84}
EVIOCGRAB = (1 << 30) | (4 << 16) | (ord("E") << 8) | 0x90
_LINE = re.compile(r"^(\w+)(?:\((\d+)\))? (-?\d+) ([0-9a-fA-F]*)$")


def load_table(path: str) -> dict[int, tuple[int, bytes]]:
    """The ioctl requests of a `.ioctl` file (umockdev's format) with their answers."""
    table = {}
    with open(path) as f:
        text = f.read()
    for line in text.splitlines():
        m = _LINE.match(line.strip())
        if not m:
            continue
        name, off, ret, data = m.group(1), int(m.group(2) or 0), int(m.group(3)), m.group(4)
        buf = bytes.fromhex(data)
        table[_ioc(_READ, _NR[name] + off, len(buf))] = (ret, buf)
    return table


def answer_from_table(table: dict[int, tuple[int, bytes]], req: int, client: Any) -> bool:
    """Answer ioctl `req` as the .ioctl table says, EINVAL if it has no entry."""
    hit = table.get(req)
    if hit is None:
        client.complete(-1, errno.EINVAL)  # e.g. EVIOCSCLOCKID
        return True
    ret, buf = hit
    client.get_arg().resolve(0, len(buf)).update(0, buf)
    client.complete(ret, 0)
    return True

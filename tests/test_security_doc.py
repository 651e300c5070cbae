"""docs/security.md's limits table names real constants with the values it states."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

DOC = Path(__file__).resolve().parents[1] / "docs" / "security.md"
ROW = re.compile(r"^\| [^|]+ \| ([^|]+) \| `([\w.]+)\.(\w+)` \|", re.M)
UNITS = {"bytes": 1, "MiB": 1 << 20, "GiB": 1 << 30, "bits": 1, "px a side": 1}


def _stated(text: str) -> float:
    m = re.match(r"(?:magnitude )?(-?[\d.e]+)(?: to ([\d.]+))? ?([A-Za-z ]+)?", text.strip())
    assert m, text
    number = float(m.group(2) or m.group(1))
    unit = (m.group(3) or "").strip()
    return number * UNITS.get(unit, 1)


def test_every_limit_in_the_table_is_the_constant_it_names() -> None:
    rows = ROW.findall(DOC.read_text())
    assert len(rows) >= 15
    for stated, module, name in rows:
        value = getattr(importlib.import_module(module), name)
        assert _stated(stated) == value, (module, name, stated, value)

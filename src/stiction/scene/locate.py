"""Find the line of a field in a TOML text, so scene errors can name it.

tomllib parses values but forgets where they were. Scene errors must name
file, line and field, so this module re-reads the text with a deliberately
small scanner: table headers, arrays of tables and ``key =`` lines, skipping
the inside of multi-line arrays and strings. It never decides what the file
means (tomllib does that); it only answers "where did this key start".
"""

from __future__ import annotations

import re
from collections.abc import Sequence

FieldPath = tuple[str | int, ...]

_HEADER = re.compile(r"^\s*(\[\[?)\s*([A-Za-z0-9_.\-\"' ]+?)\s*(\]\]?)\s*(#.*)?$")
_KEY = re.compile(r"^\s*([A-Za-z0-9_\-\"'. ]+?)\s*=")


def _split_key(key: str) -> tuple[str, ...]:
    return tuple(part.strip().strip("\"'") for part in key.split("."))


def _bracket_balance(text: str) -> int:
    """Open minus closed brackets/braces outside quoted strings and comments."""
    depth = 0
    quote = ""
    for ch in text:
        if quote:
            if ch == quote:
                quote = ""
        elif ch in "\"'":
            quote = ch
        elif ch == "#":
            break
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
    return depth


def field_lines(text: str) -> dict[FieldPath, int]:
    """Map every table and key path to the 1-based line where it begins."""
    lines: dict[FieldPath, int] = {}
    table: FieldPath = ()
    array_counts: dict[tuple[str, ...], int] = {}
    depth = 0
    in_multiline_string = ""
    for number, raw in enumerate(text.splitlines(), start=1):
        if in_multiline_string:
            if in_multiline_string in raw:
                in_multiline_string = ""
            continue
        if depth > 0:
            depth += _bracket_balance(raw)
            continue
        header = _HEADER.match(raw)
        if header and len(header.group(1)) == len(header.group(3)):
            names = _split_key(header.group(2))
            if header.group(1) == "[[":
                index = array_counts.get(names, 0)
                array_counts[names] = index + 1
                table = (*names, index)
            else:
                table = names
            lines.setdefault(table, number)
            continue
        key = _KEY.match(raw)
        if key:
            path = table + _split_key(key.group(1))
            lines.setdefault(path, number)
            value = raw[key.end() :]
            for q in ('"""', "'''"):
                if value.count(q) == 1:
                    in_multiline_string = q
            depth = max(_bracket_balance(value), 0)
    return lines


def line_of(lines: dict[FieldPath, int], path: Sequence[str | int]) -> int | None:
    """The line of `path`, or of its nearest enclosing table or key."""
    p = tuple(path)
    while p:
        if p in lines:
            return lines[p]
        p = p[:-1]
    return None


def format_path(path: Sequence[str | int]) -> str:
    """``("regions", 2, "radius")`` -> ``regions[2].radius``."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else part
    return out

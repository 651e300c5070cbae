"""Checking a hand-written TOML file, with errors that name file, line and key.

Scenes and the daemon's config are written by hand, and a mistake in either
must be reported as ``file:line: key.path: what is wrong`` rather than as a
traceback or a silently ignored typo. `TomlReader` is the one checker both
use: it parses, keeps the line of every key, and raises the caller's error
class with the full location; each file format adds its own value rules.

tomllib parses values but forgets where they were, so `field_lines`
re-reads the text with a deliberately small scanner: table headers, arrays
of tables and ``key =`` lines, skipping the inside of multi-line arrays and
strings. It never decides what the file means (tomllib does that); it only
answers "where did this key start".
"""

from __future__ import annotations

import difflib
import json
import re
import tomllib
from collections.abc import Collection, Mapping, Sequence
from pathlib import Path
from typing import Any, NoReturn

from stiction.errors import StictionError
from stiction.userfiles import shown

FieldPath = tuple[str | int, ...]

#: a key as written: bare parts, "basic" (with escapes) or 'literal' quoted parts, dots
_KEY_TEXT = r"""(?:"(?:[^"\\]|\\.)*"|'[^']*'|[A-Za-z0-9_.\- ])+?"""
_HEADER = re.compile(rf"^\s*(\[\[?)\s*({_KEY_TEXT})\s*(\]\]?)\s*(#.*)?$")
_KEY = re.compile(rf"^\s*({_KEY_TEXT})\s*=")


def _split_key(key: str) -> tuple[str, ...]:
    """The path a (dotted, maybe quoted) key names, as tomllib reads it: a quoted
    key may hold dots, escapes and newlines, which splitting on "." gets wrong."""
    try:
        node: Any = tomllib.loads(f"{key} = 0")
    except tomllib.TOMLDecodeError:
        return tuple(part.strip().strip("\"'") for part in key.split("."))
    path: list[str] = []
    while isinstance(node, dict) and len(node) == 1:
        ((name, node),) = node.items()
        path.append(name)
    return tuple(path)


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


_BARE = re.compile(r"[A-Za-z0-9_-]+")


def format_path(path: Sequence[str | int]) -> str:
    """``("regions", 2, "radius")`` -> ``regions[2].radius``.

    A key that is not a bare TOML key is written as the file would quote it
    (``"a\\nb"``), so a newline, a dot or a control character in a key can
    neither break the one-line message nor hide which key is meant; a very
    long one is shortened like any repeated user string."""
    out = ""
    for part in path:
        if isinstance(part, int):
            out += f"[{part}]"
            continue
        name = part if _BARE.fullmatch(part) else json.dumps(part, ensure_ascii=False)
        name = shown(name)
        out += f".{name}" if out else name
    return out


def kind(value: Any) -> str:
    """A TOML value as an error message names it: ``number 3``, ``an array of 2``."""
    if isinstance(value, bool):
        return f"boolean {str(value).lower()}"
    if isinstance(value, (int, float)):
        return f"number {value}"
    if isinstance(value, str):
        return f"string {value!r}"
    if isinstance(value, list):
        return f"an array of {len(value)}"
    if isinstance(value, dict):
        return "a table"
    return type(value).__name__


def unknown_key(key: str, allowed: Collection[str]) -> str:
    """The message for a key that is not in `allowed`, with the likely intended one.

    A typo (`rat`, `colour`, `deamon`) is the usual cause; difflib's ratio finds
    the known key it is closest to, and the message offers it first.
    """
    close = difflib.get_close_matches(key, list(allowed), n=1, cutoff=0.6)
    hint = f"did you mean {close[0]!r}? " if close else ""
    return f"unknown key; {hint}expected one of {', '.join(sorted(allowed))}"


class TomlReader:
    """One TOML text: its data, where each key is, and failures that say so.

    `error` is the StictionError subclass raised (SceneError, ConfigError):
    callers catch their own kind of mistake.
    """

    def __init__(self, source: str | Path, text: str, error: type[StictionError]) -> None:
        self.source = source
        self.error = error
        try:
            self.data: dict[str, Any] = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise error(f"{source}: not valid TOML: {exc}") from None
        except RecursionError:
            raise error(f"{source}: arrays or tables nested too deeply") from None
        self.lines = field_lines(text)

    def location(self, path: FieldPath) -> str:
        """``source:line: key.path`` (line and path when known): where a message points."""
        line = line_of(self.lines, path)
        where = f"{self.source}:{line}" if line is not None else str(self.source)
        field = format_path(path)
        return f"{where}: {field}" if field else where

    def fail(self, path: FieldPath, message: str) -> NoReturn:
        """Raise `message` as ``source:line: key.path: message``."""
        raise self.error(f"{self.location(path)}: {message}")

    def table(self, value: Any, path: FieldPath, allowed: set[str]) -> Mapping[str, Any]:
        """`value` as a table whose keys are all in `allowed` (a typo is an error, not ignored)."""
        if not isinstance(value, dict):
            self.fail(path, f"must be a table, got {kind(value)}")
        for key in value:
            if key not in allowed:
                self.fail((*path, key), unknown_key(key, allowed))
        return value

    def string(self, value: Any, path: FieldPath) -> str:
        if not isinstance(value, str) or not value:
            self.fail(path, f"must be a non-empty string, got {kind(value)}")
        return value

    def boolean(self, value: Any, path: FieldPath) -> bool:
        if not isinstance(value, bool):
            self.fail(path, "must be true or false")
        return value

"""The live readers' shape path: one read's events handled by code written for its shape.

A device's reads come in few *shapes*: the sequence of (type, code) in a
read -- which axes changed this frame, then SYN_REPORT. The generated
readers (live_code.py, live_mt_code.py) walk a read event by event: a tuple
per event, a chain of code tests, a range test and a store, about 100 ns
an event in CPython. For a shape seen before, all of that is known but the
values, so the reader writes a function for the shape instead
(`shape(tup)`: straight-line code that takes the values out of one tuple,
tests every range at once, assigns the cells and builds the samples) and
looks it up per read:

- one `struct` call per read unpacks, for every event but the last, its
  type and code as one unsigned 32-bit number and its value, and for the
  last event its time and type and code (`unpacker`, one precompiled
  Struct per read length); the shape's key is the tuple's type-and-code
  numbers, `tup[:-3:2]` -- exact, every byte of type and code in it;
- the reader's own dict maps the key to the function bound to its cells;
  a key it has not seen goes to `Shapes.learn`, which compiles the shape's
  code once per kind of device (`Book`, shared by every reader of that kind)
  and binds it to this reader's closure cells (`types.FunctionType` with the
  reader's cells: no compile per device);
- the function returns `MISS` before it changes anything when the read is
  not what its shape's code covers (the last event not a SYN_REPORT, a value
  out of range, a slot out of range, ...): the reader's general loop then
  takes the read, unchanged.

What the shape code does not cover at all -- keys, SYN codes other than
the read's final SYN_REPORT, unknown axes, tracking ids -- is never
compiled: such a key maps to False and its reads take the general loop.

Bounded against a device that sends many shapes (a hostile or broken one):
a kind of device compiles at most `MAX_COMPILED` shapes in a process, and
it and each reader remember at most `MAX_KNOWN` keys; past either, a new shape takes
the general loop, paying one unpack and one dict lookup more per read (a
constant: the reader stops asking to learn), and nothing grows.
"""

from __future__ import annotations

import struct
import types
from collections.abc import Callable
from typing import Any

from stiction.drivers.evdev.columns import MIN_EVENTS
from stiction.drivers.evdev.frames import INPUT_EVENT

MAX_COMPILED = 128
"""Shapes compiled per kind of device and process (each a few hundred microseconds
once and a code object of a few kilobytes)."""
MAX_KNOWN = 512
"""Keys a reader remembers (compiled or not): its dict does not grow past this."""
MAX_EVENTS = MIN_EVENTS - 1
"""Longest read (in events) the shape path unpacks: longer ones are the compiled
loop's (columns.py), as the readers hand them over."""

MISS: Any = object()
"""What a shape function returns when the read is not one its code covers: it has
changed nothing, and the reader's general loop takes the read."""

_TYPE_CODE = struct.Struct("@HH")
_AS_KEY = struct.Struct("@I")
#: the part of `struct input_event` before type and code: the time
_TIME = INPUT_EVENT.size - 8


def key_of(ev_type: int, code: int) -> int:
    """An event's type and code as the unpacker gives them: one 32-bit number."""
    (k,) = _AS_KEY.unpack(_TYPE_CODE.pack(ev_type, code))
    return int(k)


def type_code(k: int) -> tuple[int, int]:
    """The (type, code) a key number stands for."""
    t, c = _TYPE_CODE.unpack(_AS_KEY.pack(k))
    return int(t), int(c)


SYN_REPORT_KEY = key_of(0, 0)


def _unpacker(n: int) -> Callable[[bytes], tuple[int, ...]]:
    """The Struct for a read of `n` events: (type-and-code, value) for each but the
    last, then the last event's (seconds, microseconds, type-and-code)."""
    fmt = "@" + f"{_TIME}xIi" * (n - 1) + "llI4x"
    s = struct.Struct(fmt)
    if s.size != n * INPUT_EVENT.size:  # refuse at import, not at the first read
        raise RuntimeError(f"shape unpacker for {n} events is {s.size} bytes")
    return s.unpack


UNPACKERS: dict[int, Callable[[bytes], tuple[int, ...]]] = {
    n * INPUT_EVENT.size: _unpacker(n) for n in range(1, MAX_EVENTS + 1)
}
"""By read length in bytes: the read's unpacker (reads of other lengths take the
general loop, which raises for a length that is not whole events)."""


def range_lines(checks: list[tuple[str, int, int, bool]]) -> list[str]:
    """Lines that count each value out of its range, as the readers' loops do.

    `checks`: (variable, lo, hi, off_surface) -- off_surface when the axis's
    range is the surface's, so a value outside it also means the samples clamp
    (`inside = False`). One test for all in the usual case; only a read with a
    value out of range tests each (the reader's `stats` is the assembler's
    counter)."""
    if not checks:
        return []
    lines = ["if (", *(f"    {v} < {lo} or {v} > {hi} or" for v, lo, hi, _ in checks)]
    lines[-1] = lines[-1][: -len(" or")]
    lines.append("):")
    for v, lo, hi, off_surface in checks:
        lines += [f"    if {v} < {lo} or {v} > {hi}:", "        stats['value_out_of_range'] += 1"]
        if off_surface:
            lines.append("        inside = False")
    return lines


def shape_of(key: tuple[int, ...]) -> list[tuple[int, int]]:
    """The (type, code) of every event of a read with this key but its last."""
    return [type_code(k) for k in key]


Writer = Callable[[list[tuple[int, int]]], "str | None"]
"""Writes a shape function's body (statements, indented by 4, using `tup`) for the
events before the final SYN_REPORT, or None when the shape is not covered."""


class Book:
    """One kind of device's compiled shape code, shared by all its readers.

    `writer` writes a shape's body; `cells` names the reader's variables the
    body may use (they become the function's free variables, bound per
    reader); `namespace` is the reader's globals."""

    def __init__(self, writer: Writer, cells: tuple[str, ...], namespace: dict[str, Any]) -> None:
        self.writer = writer
        self.cells = cells
        self.namespace = namespace
        self.codes: dict[tuple[int, ...], types.CodeType | None] = {}
        #: (key, code) of every compiled shape: what a new reader binds at once
        self.compiled_items: list[tuple[tuple[int, ...], types.CodeType]] = []
        #: the source of every compiled shape, for reading what runs
        self.sources: dict[tuple[int, ...], str] = {}

    def code(self, key: tuple[int, ...]) -> types.CodeType | None:
        """The shape's compiled code, or None (not covered, or the cap reached)."""
        if key in self.codes:
            return self.codes[key]
        if len(self.compiled_items) >= MAX_COMPILED or len(self.codes) >= MAX_KNOWN:
            return None  # not remembered either: the dict stays bounded
        body = self.writer(shape_of(key))
        code = None
        if body is not None:
            code = self._compile(body, key)
            self.sources[key] = body
            self.compiled_items.append((key, code))
        self.codes[key] = code
        return code

    def _compile(self, body: str, key: tuple[int, ...]) -> types.CodeType:
        cells = ", ".join(self.cells)
        text = (
            "def outer():\n"
            f"    {cells} = {', '.join('None' for _ in self.cells)}\n"
            "    def shape(tup):\n"
            f"        nonlocal {cells}\n"
            + "".join(f"        {line}\n" for line in body.splitlines())
            + "    return shape\n"
        )
        name = f"<evdev live shape {key!r}>"
        scope: dict[str, Any] = {}
        exec(compile(text, name, "exec"), self.namespace, scope)
        return scope["outer"]().__code__  # type: ignore[no-any-return]


class Shapes:
    """One reader's shape functions: `get(key)` per read, `learn(key)` on a miss.

    `cells` is a function of the reader that names every variable a shape
    function may use: its closure is the reader's cells."""

    def __init__(self, book: Book, cells: types.FunctionType) -> None:
        self.book = book
        self.cells = cells
        self.known: dict[tuple[int, ...], Any] = {}
        self.get = self.known.get
        #: the closure every shape function of the book takes (they all name the
        #: same cells), made at the first
        self.freevars: tuple[str, ...] = ()
        self.closure: tuple[Any, ...] = ()
        # the shapes the book compiled for earlier readers of this kind, bound at
        # once: cheaper than one `learn` call each as they come
        if book.compiled_items:
            self._bind(book.compiled_items[0][1])
            new, ns, closure = types.FunctionType, book.namespace, self.closure
            self.known.update({k: new(c, ns, None, None, closure) for k, c in book.compiled_items})

    def learn(self, key: tuple[int, ...]) -> Any:
        """The function for a key this reader has not seen (False: none), or None
        when this reader or its book remembers no more keys: the reader then
        stops asking (`fresh` in live_mt_code.READ_START), and a new shape costs
        it one dict lookup more than its loop, not a call."""
        if len(self.known) >= MAX_KNOWN:
            return None
        code = self.book.code(key)
        if code is None and key not in self.book.codes:
            return None  # the book is full
        fn: Any = False
        if code is not None:
            if code.co_freevars != self.freevars:  # the first (the same for all after)
                self._bind(code)
            fn = types.FunctionType(code, self.book.namespace, None, None, self.closure)
        self.known[key] = fn
        return fn

    def _bind(self, code: types.CodeType) -> None:
        """The closure for `code`'s free variables: this reader's cells."""
        if code.co_freevars == self.cells.__code__.co_freevars:
            # the same names in the same order: the reader's closure itself
            self.closure = self.cells.__closure__ or ()
        else:
            cell_of = cells_of(self.cells)
            self.closure = tuple(cell_of[name] for name in code.co_freevars)
        self.freevars = code.co_freevars


def cells_of(fn: types.FunctionType) -> dict[str, Any]:
    """A nested function's closure cells by name."""
    return dict(zip(fn.__code__.co_freevars, fn.__closure__ or (), strict=True))

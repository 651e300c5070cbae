"""One read() of a live device straight to PenSamples: a reader written per device.

A live pen delivers one frame per read(): four to seven events and one
sample. Through the assembler (`device.read_samples`) that cost about
4 us, most of it per call, not per event: the events become a list of
tuples, the feed loop loads the assembler's state into locals and writes it
back, a Frame and a Contact are built only to be taken apart by
`frame_samples`. Here, as hid/report_code.py does for HID report layouts,
the reader is written out as Python source for the device at hand, and is
itself the samples generator (no call and no list per read):

- the events are walked straight off `struct.iter_unpack`;
- each axis's value lives in a closure cell (`c<code>`), read and written
  as cheaply as a local, so nothing is loaded from or stored into the
  assembler per read; a snapshot taken as the read begins puts them back
  if the read has to go to the assembler after all;
- range checks compare against literal numbers, and at SYN_REPORT the
  PenSample is filled in directly with the units' arithmetic written in
  (the same operations, in the same order, as units._sample_function);
- keys change the assembler's own key set, and the assembler works out
  what follows (`_key_state`: tool, tip, buttons) at SYN_REPORT; a contact
  that ends repeats its last sample tip-up and out of range, as
  frame_samples does with the assembler's ended Contact.

Anything else -- a SYN_DROPPED or other SYN code, a read ending mid-frame,
a long read (the compiled loop's, columns.py) -- is handed over: the state
as the read began is written into the assembler (`store`), the assembler
takes the whole read, and the reader takes the state back (`load`) once
the assembler stands at a frame boundary; until then every read goes
through the assembler. Counters are added only when a read went well, so
the samples and the counters are the assembler's own
(tests/evdev/test_evdev_live.py compares them read by read on every
recording cut into reads of one frame and of random sizes, and on random
streams with keys, SYN_DROPPED and garbage). The reader of a multi-touch
device is written by live_mt_code.py.

Before its loop, the reader looks the read's shape up (live_shapes.py):
a read of a shape seen before is taken by a function written for it
(live_shape_code.py), with no per-event dispatch; the loop takes the rest.
"""

from __future__ import annotations

import functools
import textwrap
from collections.abc import Callable, Iterable, Iterator
from typing import cast

from evdev import ecodes

from stiction.drivers.evdev import live_mt_code, live_shape_code
from stiction.drivers.evdev.frames import Contact, FrameAssembler
from stiction.drivers.evdev.live_mt_code import (
    COLLECT,
    HAND_OVER,
    KEY_EVENT_AND_READ_END,
    READ_START,
    TOOK_ONE,
)
from stiction.drivers.evdev.live_pen_sample import derived_fields, sample_code, tip_expression
from stiction.drivers.evdev.live_shapes import MISS, UNPACKERS, Book, Shapes
from stiction.drivers.evdev.single_code import sorted_codes
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.sample import PenSample, Tool

#: the assembler's path for one read's bytes (device.read_samples, bound to asm and units)
Fallback = Callable[[bytes], list[PenSample]]
#: the samples that end every contact when the device went away, given the last read
End = Callable[[bytes], list[PenSample]]
Samples = Callable[[Iterable[bytes]], Iterator[PenSample]]


class LiveReader:
    """A live device's samples: `samples(reads)`, reads of whole events -> PenSamples.

    `samples` raises what the reads raise; for `gone` (DeviceGone) it first
    yields the samples `end` makes, which end every contact still down.
    `count()` is how many samples it has yielded (the source's stats);
    `store()` hands the assembler the state the reader keeps to itself.
    """

    def __init__(
        self,
        samples: Samples,
        store: Callable[[], None],
        count: Callable[[], int],
        source: str | None,
        shaped: Callable[[], int] = lambda: 0,
    ) -> None:
        self.samples = samples
        self.store = store
        self.count = count
        #: how many reads a shape function took (live_shapes.py)
        self.shaped = shaped
        #: the generated source, for reading what runs (None: not specialised)
        self.source = source


def _lines(template: str, codes: list[int], indent: str) -> str:
    return "".join(indent + template.format(c=c) + "\n" for c in codes)


def _ended_code(indent: str) -> str:
    """Statements that collect the ended contact's sample: its last one, tip up,
    out of range, at this frame's time (units.sample on the ended Contact)."""
    lines = [
        "o = last_sample",
        "s = blank()",
        "s.t = made  # its frame's time once the read went well",
        "s.x = o.x",
        "s.y = o.y",
        "s.tip = False",
        "s.in_range = False",
        "s.contact = 0",
        "s.pressure = o.pressure",
        "s.tool = o.tool",
        "s.tilt_x = o.tilt_x",
        "s.tilt_y = o.tilt_y",
        "s.buttons = o.buttons",
        *COLLECT,
        "last_tool = None",
    ]
    return "".join(f"{indent}{line}\n" for line in lines)


def _tool_code(asm: FrameAssembler) -> str:
    """At SYN_REPORT: the keys' consequences, then the contact's tool (single_code.py's
    rules); `continue` when the frame has no contact, else on to its sample.

    With BTN_TOOL_* keys the tool is the keys' (`key_tool`), and the last frame's
    tool equals it until a key changes (load() checks so), so only a frame with a
    key event looks at it again. Without, the tool is the default once a
    position came (`seen`)."""
    refresh = (
        "                        keys_changed = False\n"
        "                        key_state()\n"
        "                        key_tool = asm._key_tool\n"
        "                        key_touch = asm._key_touch\n"
        "                        buttons = asm._button_state\n"
    )
    if asm._has_tool_keys:
        return (
            "                    if keys_changed:\n"
            + refresh
            + "                        if key_tool is None:\n"
            + "                            if last_tool is not None:\n"
            + _ended_code(" " * 32)
            + "                            continue\n"
            + "                        last_tool = key_tool\n"
            + "                    elif last_tool is None:\n"
            + "                        continue  # no contact\n"
        )
    return (
        "                    if keys_changed:\n"
        + refresh
        + "                    if not seen:\n"
        + "                        if last_tool is not None:\n"
        + _ended_code(" " * 28)
        + "                        continue\n"
        + "                    last_tool = default_tool\n"
    )


def _cells(asm: FrameAssembler, units: SurfaceUnits) -> list[str]:
    """The reader's variables a pen's shape function uses (its free variables)."""
    return [
        *(f"c{c}" for c in sorted_codes(asm)),
        *(f"{kind}{code}" for code, _, _ in derived_fields(units, asm) for kind in "rf"),
        "seen",
        "last_tool",
        "last_sample",
        "inside",
        "asm",
        "stats",
        "default_tool",
        "key_touch",
        "buttons",
    ]


def source(asm: FrameAssembler, units: SurfaceUnits) -> str:
    """The reader's source for this device (read it to see what runs).

    The events of a read write straight into the cells; `snap`, taken when
    the read begins, puts them back if the read turns out to need the
    assembler, which then takes the whole read (the frames this reader
    completed included: counters are only added when a read ends well).
    """
    codes = sorted_codes(asm)
    # a shape function's cache of the fields one axis decides (live_shape_code._pen_sample)
    derived = [code for code, _, _ in derived_fields(units, asm)]
    ranges = asm._ranges
    x, y = ecodes.ABS_X, ecodes.ABS_Y
    p, tx, ty = ecodes.ABS_PRESSURE, ecodes.ABS_TILT_X, ecodes.ABS_TILT_Y
    state = ", ".join(
        [
            *(f"c{c}" for c in codes),
            "seen",
            "last_tool",
        ]
    )
    # with tool keys, the contact's tool is the keys' (see _tool_code)
    consistent = "(last_tool is None) == (key_tool is None)" if asm._has_tool_keys else "True"
    x0, x1, y0, y1 = units._bounds
    surface = {x: (x0, x1), y: (y0, y1)}
    branches = []
    for i, c in enumerate(codes):
        lo, hi = ranges[c]
        body = f"                c{c} = value\n"
        body += f"                if value < {lo} or value > {hi}:\n"
        body += "                    odd = (*(odd or ()), 'value_out_of_range')\n"
        if c in surface:
            if surface[c] == (lo, hi):
                body += "                    inside = False\n"
            else:
                s_lo, s_hi = surface[c]
                body += f"                if value < {s_lo!r} or value > {s_hi!r}:\n"
                body += "                    inside = False\n"
            body += "                seen = True\n"
        branches.append(f"            {'if' if i == 0 else 'elif'} code == {c}:\n{body}")
    branches.append("            else:\n                odd = (*(odd or ()), 'unknown_code')\n")
    tip = tip_expression(asm)
    last_contact = (
        f"(0, None, None, last_tool, {f'c{x}' if x in asm._abs else '0'}, "
        f"{f'c{y}' if y in asm._abs else '0'}, {f'c{p}' if asm._has_pressure else 'None'}, "
        f"{tip}, True, {f'c{tx}' if asm._has_tilt else 'None'}, "
        f"{f'c{ty}' if asm._has_tilt else 'None'}, buttons)"
    )
    xv = f"c{x}" if x in asm._abs else "0"
    yv = f"c{y}" if y in asm._abs else "0"
    inside = f"{x0!r} <= {xv} <= {x1!r} and {y0!r} <= {yv} <= {y1!r}"
    return f"""abs_ = asm._abs
stats = asm._counts
keys = asm._keys  # the assembler's own key set, changed in place
valid_keys = asm._valid_keys
key_state = asm._key_state
ok = False  # the cells hold the assembler's state; else the assembler holds it
{_lines("c{c} = 0", codes, "")}{_lines("r{c} = f{c} = None", derived, "")}seen = False
last_tool = None  # the tool of the last frame's contact; None: it had none
force = False  # the assembler's _dirty_all when loaded: kept until a frame is made
loaded_frames = 0  # the assembler's frame count when loaded
key_tool = None
key_touch = False
buttons = 0
made_samples = 0
shaped = 0  # reads taken by a shape function (live_shapes.py)
inside = False  # the position is on the surface (False: the samples clamp it)
last_sample = None  # the last frame's sample: an ended contact repeats it


def load():
    \"\"\"Take the state from the assembler, if it stands at a clean frame boundary.\"\"\"
    nonlocal ok, {state}, inside, last_sample, force, loaded_frames
    nonlocal key_tool, key_touch, buttons
    if (
        asm._n_pending
        or asm._dropping
        or asm._undo_abs
        or asm._keys_ok is not None
        or asm._keys_changed
        or asm.needs_resync
    ):
        ok = False
        return
{_lines("c{c} = abs_[{c}]", codes, "    ")}    seen = asm._seen_position
    force = asm._dirty_all  # a new assembler's first frame: the same contact rule
    loaded_frames = asm._frames
    inside = {inside}
    last = asm._last
    last_tool = last[0].tool if last else None
    last_sample = sample(last[0], 0.0) if last else None
    key_tool = asm._key_tool
    key_touch = asm._key_touch
    buttons = asm._button_state
    ok = {consistent}


def store():
    \"\"\"Hand the assembler the state as of the last frame; the assembler holds it now.\"\"\"
    nonlocal ok
    if not ok:
        return
    ok = False
{_lines("abs_[{c}] = c{c}", codes, "    ")}    asm._seen_position = seen
    asm._seen_start = seen
    asm._dirty_all = force and asm._frames == loaded_frames
    asm._last = (tnew(Contact, {last_contact}),) if last_tool is not None else ()


def count():
    return made_samples


def count_shaped():
    return shaped


def cells():
    \"\"\"Names every variable a shape function may use (live_shapes.cells_of).\"\"\"
    return ({", ".join(_cells(asm, units))})


def samples(reads):
    nonlocal {state}, made_samples, inside, last_sample, key_tool, key_touch, buttons
    nonlocal shaped
{READ_START.format(took=TOOK_ONE)}            snap = ({state})
            ev_type = 0  # an empty read is a whole one
            odd = None  # the read's anomalies, counted once the read went well
            keys_changed = False
            ksnap = None  # the key set, kept once a key comes
            made = 0
            first = None  # the read's samples, yielded once the whole read went well
            rest = None
            for ev_type, code, value in unpack(data):
                if ev_type == 3:  # EV_ABS
{textwrap.indent("".join(branches), " " * 8)}                    continue
                if ev_type == 0:
                    if code != 0:  # SYN_DROPPED, SYN_CONFIG, SYN_MT_REPORT: the assembler's
                        break
                    # SYN_REPORT: the frame is complete
                    # (single_code.py's rules: the contact follows the keys and axes)
                    made += 1
{_tool_code(asm)}{sample_code(units, asm, " " * 20)}                    continue
{KEY_EVENT_AND_READ_END}
            # the read needs the assembler (or ends mid-frame): it takes the whole read
            {state} = snap
            if ksnap is not None:
                keys.clear()
                keys.update(ksnap)
                key_state()  # what follows from the keys, as it was
                key_tool = asm._key_tool
                key_touch = asm._key_touch
                buttons = asm._button_state
{HAND_OVER}"""


_Make = Callable[..., tuple[Samples, Callable[[], None], Callable[[], int], Callable[[], int]]]
#: the end of `make`: the reader's shape functions (live_shapes.Shapes, bound to its
#: cells), its state taken from the assembler, its functions handed out
_END = """
shapes_ = Shapes(book, cells)
known = shapes_.get
learn = shapes_.learn
load()
return samples, store, count, count_shaped
"""
#: no read's unpacker: a reader made with shapes=False takes no read by its shape
_NO_SHAPES: dict[int, object] = {}
#: the compiled readers, with their source, by everything the source depends on
_FACTORIES: dict[tuple[object, ...], tuple[_Make, str]] = {}
#: each compiled reader's shape book (live_shapes.Book), by the same key
BOOKS: dict[tuple[object, ...], Book] = {}
#: the same by the description and units objects themselves (a DeviceSource reuses
#: its own; comparing a key is a deep tuple comparison): (desc, units, compiled)
_BY_IDENTITY: dict[tuple[int, int], tuple[object, object, tuple[_Make, str]]] = {}


def _key(asm: FrameAssembler, units: SurfaceUnits) -> tuple[object, ...]:
    """Everything source() reads: devices that agree on it share one compiled reader."""
    scales = (units._pressure, units._tilt_x, units._tilt_y)
    return (
        tuple(sorted(asm._ranges.items())),
        asm._has_tool_keys,
        asm._has_pressure,
        asm._has_touch_key,
        asm._pressure_min,
        asm._has_tilt,
        asm._default_tool,
        units._bounds,
        units._rx,
        units._ry,
        # (offset, scale) pairs: hashing them is cheaper than the dataclasses
        *((v.offset, v.scale, v.lo, v.hi) if v is not None else None for v in scales),
    )


def live_reader(
    asm: FrameAssembler,
    units: SurfaceUnits,
    fallback: Fallback,
    end: End,
    gone: type[BaseException],
    long_read: int,
    shapes: bool = True,
) -> LiveReader:
    """The reader generated for `asm`'s device (live_mt_code.py writes a multi-touch one).

    `fallback(data)`: the assembler's path for a read (device.read_samples
    bound to asm and units); it takes every read of `long_read` bytes or
    more. `end(data)`: the samples that end the contacts once `gone` was
    raised after the read `data`. `shapes=False`: no shape functions
    (live_shapes.py), every read walked by the loop -- the reader as it was
    before them, for the benchmark's comparison.
    """
    known = _BY_IDENTITY.get((id(asm.desc), id(units)))
    if known is not None and known[0] is asm.desc and known[1] is units:
        make, text = known[2]
    else:
        compiled = _compiled(asm, units)
        if len(_BY_IDENTITY) >= 64:  # a bound for a process that opens many devices
            _BY_IDENTITY.clear()
        _BY_IDENTITY[(id(asm.desc), id(units))] = (asm.desc, units, compiled)
        make, text = compiled
    samples, store, count, shaped = make(
        asm,
        asm._default_tool,
        fallback,
        end,
        gone,
        long_read,
        units.sample,
        asm._buttons,
        UNPACKERS.get if shapes else _NO_SHAPES.get,
    )
    return LiveReader(samples, store, count, text, shaped)


def _compiled(asm: FrameAssembler, units: SurfaceUnits) -> tuple[_Make, str]:
    """The compiled reader for the device and its source, made at the first call."""
    if asm.multitouch:
        key: tuple[object, ...] = ("mt", asm.num_slots, asm._has_mt_pressure, *_key(asm, units))
    else:
        key = ("single", *_key(asm, units))
    made = _FACTORIES.get(key)
    if made is None:
        if asm.multitouch:
            text = live_mt_code.source(asm, units)
            writer, cells = live_shape_code.mt_body, live_mt_code.cells(asm)
        else:
            text = source(asm, units)
            writer, cells = live_shape_code.pen_body, _cells(asm, units)
        namespace: dict[str, object] = {
            "Shapes": Shapes,
            "miss": MISS,
            "tnew": tuple.__new__,
            "Contact": Contact,
            "blank": live_mt_code.Filling,
            "pen": PenSample,
            "unpack": live_mt_code.TYPE_CODE_VALUE.iter_unpack,
            "stamp": live_mt_code.TIME.unpack_from,
            "stamped": live_mt_code.stamped,
            "pen_tool": Tool.PEN,
            "finger": Tool.FINGER,
        }
        book = Book(
            functools.partial(writer, asm, units),
            tuple(cells),
            namespace,
        )
        namespace["book"] = book
        body = text + _END
        head = (
            "def make(asm, default_tool, fallback, end, gone, long_read, sample, key_buttons,"
            " unpackers):\n"
        )
        name = f"<evdev live reader: {asm.desc.name}>"
        exec(compile(head + textwrap.indent(body, "    "), name, "exec"), namespace)
        made = (cast(_Make, namespace["make"]), text)
        _FACTORIES[key] = made
        BOOKS[key] = book
    return made

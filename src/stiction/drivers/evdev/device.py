"""A live /dev/input/eventN: python-evdev for the device, its bytes read directly.

What a well-behaved evdev client does, and this one does:

- reads whole `struct input_event`s and keeps a partial one for the next
  read instead of misframing the rest of the stream (see `batches()`);
- asks the kernel for CLOCK_MONOTONIC event times (EVIOCSCLOCKID, as libinput
  does), so sample times share the daemon's clock; if the node refuses, the
  default CLOCK_REALTIME stays and `clock` says so;
- on SYN_DROPPED drops the partial frame, skips to the next SYN_REPORT, then
  re-reads keys (EVIOCGKEY), axis values (EVIOCGABS) and all slots
  (EVIOCGMTSLOTS through fcntl, which python-evdev does not wrap), and
  reports the re-read state as a frame;
- grabs exclusively only when asked, and releases the grab on every exit
  path (the kernel also drops it when the fd closes, even on a crash);
- on unplug (ENODEV, or EOF from a hung-up node) ends every contact, then
  raises DeviceError; the daemon may open the path again when it returns.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import functools
import logging
import os
import select
import struct
import threading
import time
import weakref
from collections import Counter
from collections.abc import Iterator
from typing import Any, cast

from evdev import ecodes

from stiction.drivers.evdev import columns, sizes
from stiction.drivers.evdev.base import EvdevSourceBase
from stiction.drivers.evdev.description import EV_ABS, EV_KEY, EV_SYN, AbsAxis, DeviceDescription
from stiction.drivers.evdev.frames import INPUT_EVENT, DeviceState, Frame, FrameAssembler, _Slot
from stiction.drivers.evdev.live_code import LiveReader, live_reader
from stiction.drivers.evdev.source import frame_samples
from stiction.drivers.evdev.units import SurfaceUnits
from stiction.drivers.sample import PenSample, Tool
from stiction.errors import DeviceError

log = logging.getLogger(__name__)

Event = tuple[int, int, int, int, int]


def _close_fds(*fds: int) -> None:
    for fd in fds:
        with contextlib.suppress(OSError):
            os.close(fd)


_READ_SIZE = INPUT_EVENT.size * 256
_COLUMNS_MIN_BYTES = INPUT_EVENT.size * columns.MIN_EVENTS


def read_samples(
    asm: FrameAssembler, units: SurfaceUnits, data: bytes, compile: bool = False
) -> list[PenSample]:
    """The samples of the frames one read()'s bytes (whole events) complete.

    The reference path for a live read, and the generated reader's
    (`live_reader_for`) hand-over for the reads it does not take. A read of
    many events (a reader that fell behind) goes through the
    compiled loop (columns.py) -- once it is compiled: compile=False, the
    default, never makes a live reader wait seconds for numba (a replay or
    `columns.warm()` compiles it). A short read -- the usual frame or two of
    a live device -- or one the loop refuses goes event by event through the
    assembler and `frame_samples`. Both give the same samples
    (tests/evdev/test_evdev_columns.py).
    """
    if len(data) >= _COLUMNS_MIN_BYTES:
        made = columns.samples(asm, units, data, compile=compile)
        if made is not None:
            return made
    frames = asm.feed_many(list(INPUT_EVENT.iter_unpack(data)))
    if len(frames) == 1:
        return frame_samples(units, frames[0])
    out: list[PenSample] = []
    for f in frames:
        out += frame_samples(units, f)
    return out


#: FrameAssembler's attributes that new_assembler() makes afresh for each copy; every
#: other attribute must hold an immutable value (_IMMUTABLE), or nothing is copied
_MADE_AFRESH = frozenset(
    {
        "_counts",
        "_undo_abs",
        "_undo_slots",
        "_keys",
        "_abs",
        "_ranges",
        "_slots",
        "_spare_slot",
        "_dirty",
        "feed_many",
    }
)
_IMMUTABLE = (int, float, str, type(None), frozenset, Tool, DeviceDescription)
SlotState = tuple[int, int, int, int | None, int, int]
#: per description (by identity, as live_code._BY_IDENTITY): (description, the
#: template's attributes, its slots' and spare slot's states) for a description
#: whose assembler can be copied, else (description, None, (), None)
_TEMPLATES: dict[
    int, tuple[DeviceDescription, dict[str, object] | None, tuple[SlotState, ...], SlotState | None]
] = {}


def _copyable(attrs: dict[str, object]) -> bool:
    """Everything but _MADE_AFRESH is immutable, and those are what _copy expects."""
    for name, value in attrs.items():
        if name in _MADE_AFRESH:
            continue
        if isinstance(value, tuple):
            if not all(isinstance(v, _IMMUTABLE) for v in value):
                return False
        elif not isinstance(value, _IMMUTABLE):
            return False
    return (
        attrs.keys() >= _MADE_AFRESH
        and type(attrs["_counts"]) is Counter
        and all(type(attrs[n]) is dict for n in ("_undo_abs", "_undo_slots", "_abs", "_ranges"))
        and all(type(attrs[n]) is set for n in ("_keys", "_dirty"))
        and type(attrs["_slots"]) is list
        and all(type(s) is _Slot for s in attrs["_slots"])  # type: ignore[attr-defined]
        and type(attrs["_spare_slot"]) is _Slot
    )


def _slot(state: SlotState) -> _Slot:
    made = object.__new__(_Slot)
    made.restore(state)
    return made


def new_assembler(desc: DeviceDescription) -> FrameAssembler:
    """`FrameAssembler(desc)`, made by copying one made earlier for the same description.

    What a device pays when it is opened: FrameAssembler.__init__ works out
    the description's properties, ranges and slots in Python (about 8 us);
    a copy of a pristine assembler made once per description takes its
    immutable attributes in one dict update and makes only the mutable ones
    afresh (_MADE_AFRESH: counters, undo state, key set, axis values, slots,
    the bound `feed_many`), so no two assemblers share mutable state. Should
    FrameAssembler gain an attribute this does not know to be immutable, no
    copy is made (`FrameAssembler(desc)` as before);
    tests/evdev/test_evdev_live_setup.py checks every recording's copy equals
    a new assembler and shares nothing mutable with it.
    """
    known = _TEMPLATES.get(id(desc))
    if known is None or known[0] is not desc:
        made = FrameAssembler(desc)
        attrs = dict(vars(made))
        if len(_TEMPLATES) >= 64:  # a bound for a process that opens many devices
            _TEMPLATES.clear()
        if _copyable(attrs):
            # the pristine state, kept apart: `made` itself is handed out and changes
            states = tuple(s.state() for s in attrs["_slots"])  # type: ignore[attr-defined]
            spare = attrs["_spare_slot"].state()  # type: ignore[attr-defined]
            pristine = vars(_copy(attrs, states, spare))
            _TEMPLATES[id(desc)] = (desc, pristine, states, spare)
        else:
            _TEMPLATES[id(desc)] = (desc, None, (), None)
        return made
    _, pristine_attrs, states, spare = known
    if pristine_attrs is None or spare is None:
        return FrameAssembler(desc)
    return _copy(pristine_attrs, states, spare)


def _copy(attrs: dict[str, Any], states: tuple[SlotState, ...], spare: SlotState) -> FrameAssembler:
    """An assembler with `attrs`, the mutable ones made afresh (_MADE_AFRESH), its
    slots in `states`."""
    asm: Any = object.__new__(FrameAssembler)
    asm.__dict__.update(attrs)
    asm._counts = Counter()
    asm._undo_abs = {}
    asm._undo_slots = {}
    asm._keys = set()
    asm._dirty = set()
    asm._abs = attrs["_abs"].copy()
    asm._ranges = attrs["_ranges"].copy()
    asm._slots = [_slot(s) for s in states]
    asm._spare_slot = _slot(spare)
    asm.bind_feed()  # feed_many as __init__ binds it, to this instance
    return cast(FrameAssembler, asm)


class DeviceGone(DeviceError):
    """The device was unplugged while being read; it may come back as a new node."""


def live_reader_for(asm: FrameAssembler, units: SurfaceUnits) -> LiveReader:
    """The reader of a live device's reads (live_code.py): DeviceSource.samples() runs
    its `samples` over the node's read()s, the benchmark over a recording cut into
    one read per frame. It takes the common read itself and hands the rest to
    `read_samples` -- the same samples either way (tests/evdev/test_evdev_live.py).
    When the device goes away (DeviceGone), every contact still down ends first."""

    def end(data: bytes) -> list[PenSample]:
        last = INPUT_EVENT.unpack_from(data, len(data) - INPUT_EVENT.size) if data else (0, 0)
        frame = asm.finish(last[0], last[1])
        return frame_samples(units, frame) if frame is not None else []

    fallback = functools.partial(read_samples, asm, units)
    return live_reader(asm, units, fallback, end, DeviceGone, _COLUMNS_MIN_BYTES)


_IOC_WRITE, _IOC_READ = 1, 2


def _ioc(direction: int, nr: int, size: int) -> int:
    return (direction << 30) | (size << 16) | (ord("E") << 8) | nr


EVIOCSCLOCKID = _ioc(_IOC_WRITE, 0xA0, 4)


def EVIOCGMTSLOTS(size: int) -> int:
    return _ioc(_IOC_READ, 0x0A, size)


_SLOT_CODES = (
    ecodes.ABS_MT_TRACKING_ID,
    ecodes.ABS_MT_POSITION_X,
    ecodes.ABS_MT_POSITION_Y,
    ecodes.ABS_MT_PRESSURE,
    ecodes.ABS_MT_DISTANCE,
    ecodes.ABS_MT_TOOL_TYPE,
)


def _udev_properties(path: str) -> dict[str, str]:
    """ID_INPUT_* tags from udev; empty when udev (or pyudev) is unavailable."""
    try:
        import pyudev

        ctx = pyudev.Context()
        dev = pyudev.Devices.from_device_file(ctx, path)
        return {k: str(v) for k, v in dev.properties.items() if k.startswith("ID_INPUT")}
    except Exception:  # udev missing in containers; the bits alone still classify
        return {}


def describe(dev: Any, udev: dict[str, str] | None = None) -> DeviceDescription:
    """A DeviceDescription from an open python-evdev InputDevice."""
    caps = dev.capabilities(absinfo=True)
    axes: dict[int, AbsAxis] = {}
    for code, info in caps.get(EV_ABS, []):
        axes[code] = AbsAxis(
            info.value, info.min, info.max, info.fuzz, info.flat, float(info.resolution)
        )
    other = {t: frozenset(c) for t, c in caps.items() if t not in (EV_SYN, EV_KEY, EV_ABS) and c}
    try:
        props = frozenset(dev.input_props())
    except (OSError, SystemError):
        props = frozenset()
    return DeviceDescription(
        name=dev.name,
        bustype=dev.info.bustype,
        vendor=dev.info.vendor,
        product=dev.info.product,
        version=dev.info.version,
        properties=props,
        keys=frozenset(caps.get(EV_KEY, [])),
        axes=axes,
        other=other,
        udev=udev or {},
    )


def _open(path: str) -> Any:
    import evdev

    try:
        return evdev.InputDevice(path)
    except FileNotFoundError:
        raise DeviceError(f"{path}: no such input device (unplugged, or a wrong path?)") from None
    except PermissionError:
        raise DeviceError(
            f"{path}: permission denied; install stiction's udev rule (udev/) so the "
            "logged-in user gets access, or add yourself to the 'input' group"
        ) from None
    except IsADirectoryError:
        raise DeviceError(f"{path} is a directory, not an input device") from None
    except OSError as exc:
        if exc.errno == errno.ENOTTY:
            raise DeviceError(f"{path} is not an evdev input device (/dev/input/eventN)") from None
        raise DeviceError(f"{path}: cannot open: {exc.strerror or exc}") from None
    except SystemError:
        # python-evdev turns some refused ioctls into SystemError (EVIOCGVERSION, ...)
        raise DeviceError(f"{path} is not an evdev input device (/dev/input/eventN)") from None


class DeviceSource(EvdevSourceBase):
    """SampleSource over one evdev node."""

    def __init__(
        self,
        path: str,
        grab: bool = False,
        size_mm: tuple[float, float] | None = None,
        require_size: bool = True,
    ) -> None:
        """`require_size=False` lets diagnostic tools read frames of a device whose
        size is unknown (metres are then null); samples() needs the size."""
        self.path = path
        self._dev = _open(path)
        self._lock = threading.RLock()  # close() may run in a signal handler
        self._closed = threading.Event()
        self._released = False
        self._reading = False
        self._grabbed = False
        self._stats: Counter[str] = Counter()
        self._assembler: FrameAssembler | None = None
        self._live: LiveReader | None = None  # samples() counts its own samples
        self._wake_r, self._wake_w = os.pipe()
        # closes the pipe once, whether through close() or when an unclosed source
        # is garbage-collected (python-evdev closes the device fd itself then)
        self._close_pipe = weakref.finalize(self, _close_fds, self._wake_r, self._wake_w)
        try:
            desc = describe(self._dev, _udev_properties(path))
            desc = sizes.apply(desc, size_mm)
            if require_size:
                sizes.require(desc)
            self.description = desc
            self._units = SurfaceUnits(desc)
            self.clock = self._set_monotonic_clock()
            if grab:
                try:
                    self._dev.grab()
                except OSError as exc:
                    if exc.errno == errno.EBUSY:
                        raise DeviceError(
                            f"{path} ({desc.name!r}) is grabbed by another program"
                        ) from None
                    raise DeviceError(f"{path}: cannot grab: {exc.strerror or exc}") from None
                self._grabbed = True
        except BaseException:
            self._release()
            raise

    # -- SampleSource --------------------------------------------------------

    def samples(self) -> Iterator[PenSample]:
        """Each read()'s samples (`live_reader_for`); every contact ends before DeviceGone."""
        if self._live is not None:  # an earlier samples() call's count stays counted
            self._stats["samples"] += self._live.count()
        reader = live_reader_for(self._new_assembler(), self._units)
        self._live = reader
        # a function returning the reader's generator, not a generator itself: one
        # layer less per sample; the size check runs at the first next(), as it did
        return reader.samples(self._reads(require_size=True))

    def stats(self) -> dict[str, int]:
        out = super().stats()
        if self._live is not None:
            out["samples"] = out.get("samples", 0) + self._live.count()
        return out

    def close(self) -> None:
        """Idempotent; wakes a blocked reader, which then releases the device."""
        if self._closed.is_set():
            return
        self._closed.set()
        with contextlib.suppress(OSError):
            os.write(self._wake_w, b"x")
        with self._lock:
            if not self._reading:
                self._release()

    # -- reading -------------------------------------------------------------

    def batches(self) -> Iterator[list[Event]]:
        """The raw events as each read() returns them (for `stiction evdev record`)."""
        for data in self._reads():
            yield list(INPUT_EVENT.iter_unpack(data))

    def _reads(self, require_size: bool = False) -> Iterator[bytes]:
        """Each read()'s whole `struct input_event`s, as bytes.

        The node is read directly (`os.read` on python-evdev's fd, unpacked
        with `struct`), not through python-evdev's read(): that one builds a
        Python InputEvent per event, which the assembler would only unpack
        again, and it drops the tail of a read that ends mid-event, after
        which every later event is misframed. A kernel never returns partial
        events, but a pty-backed node does under load (umockdev, the tests);
        here the tail is kept for the next read and counted as
        `partial_reads`. Raises DeviceGone (a DeviceError) when the device
        goes away; the grab is released however the iteration ends.
        `require_size`: refuse (DeviceError) at the first next() when the
        surface size is unknown, as samples() needs it.
        """
        if require_size:
            sizes.require(self.description)
        with self._lock:
            if self._released or self._closed.is_set():
                return
            self._reading = True
        fd = self._dev.fd
        size = INPUT_EVENT.size
        carry = b""
        try:
            while not self._closed.is_set():
                ready, _, _ = select.select([fd, self._wake_r], [], [])
                if self._wake_r in ready:
                    return
                try:
                    data = os.read(fd, _READ_SIZE)
                except BlockingIOError:
                    continue
                except OSError as exc:
                    if exc.errno in (errno.ENODEV, errno.EIO, errno.EBADF):
                        raise self._gone(exc.strerror or str(exc)) from None
                    raise DeviceError(f"{self.path}: read failed: {exc.strerror or exc}") from None
                if not data:
                    # select said readable and read() got 0 bytes: end of file, the node
                    # was hung up (a real unplug gives ENODEV; umockdev gives EOF).
                    raise self._gone("end of file")
                if carry:
                    data = carry + data
                whole = len(data) - len(data) % size
                carry = data[whole:]
                if carry:
                    self._stats["partial_reads"] += 1
                if not whole:
                    continue
                self._stats["events"] += whole // size
                yield data[:whole] if carry else data
        finally:
            with self._lock:
                self._reading = False
                if self._closed.is_set():
                    self._release()
                else:
                    self._ungrab()

    def _new_assembler(self) -> FrameAssembler:
        asm = new_assembler(self.description)
        asm.query_state = self._query_state  # SYN_DROPPED: re-read, report as a frame
        self._assembler = asm
        return asm

    def frames(self) -> Iterator[Frame]:
        """Frames as the kernel completes them; DeviceError when the device goes away."""
        asm = self._new_assembler()
        last = (0, 0)
        try:
            for batch in self.batches():
                last = batch[-1][:2]
                yield from asm.feed_many(batch)
        except DeviceGone:
            end = asm.finish(*last)  # every contact ends before the error is reported
            if end is not None:
                yield end
            raise

    def _gone(self, why: str) -> DeviceGone:
        """The error for an unplug; the source is finished, so everything is released."""
        self._stats["unplugged"] += 1
        self._closed.set()
        return DeviceGone(f"{self.path} ({self.description.name!r}) went away ({why})")

    def _query_state(self) -> DeviceState:
        """Keys, axis values and slots, re-read from the kernel after SYN_DROPPED."""
        dev = self._dev
        keys: frozenset[int] = frozenset()
        axes: dict[int, int] = {}
        slots: dict[int, list[int]] = {}
        try:
            keys = frozenset(dev.active_keys())
        except (OSError, SystemError):
            self._stats["resync_failed_keys"] += 1
        for code in self.description.axes:
            try:
                axes[code] = dev.absinfo(code).value
            except (OSError, SystemError):
                self._stats["resync_failed_axes"] += 1
        n = self.description.num_slots
        for code in _SLOT_CODES if n else ():
            if code not in self.description.axes:
                continue
            buf = bytearray(struct.pack("i", code) + bytes(4 * n))
            try:
                fcntl.ioctl(dev.fd, EVIOCGMTSLOTS(len(buf)), buf, True)
            except OSError:
                self._stats["resync_failed_slots"] += 1
                break
            slots[code] = list(struct.unpack_from(f"{n}i", buf, 4))
        return DeviceState(keys, axes, slots)

    def _set_monotonic_clock(self) -> str:
        try:
            fcntl.ioctl(self._dev.fd, EVIOCSCLOCKID, struct.pack("i", time.CLOCK_MONOTONIC))
        except OSError as exc:
            log.info("%s: kernel event times stay CLOCK_REALTIME (%s)", self.path, exc)
            return "realtime"
        return "monotonic"

    # -- cleanup -------------------------------------------------------------

    def _ungrab(self) -> None:
        if self._grabbed:
            self._grabbed = False
            # gone already? then the kernel dropped the grab with the device
            with contextlib.suppress(OSError):
                self._dev.ungrab()

    def _release(self) -> None:
        if self._released:
            return
        self._released = True
        self._ungrab()
        with contextlib.suppress(OSError):
            self._dev.close()
        self._close_pipe()

    def __enter__(self) -> DeviceSource:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

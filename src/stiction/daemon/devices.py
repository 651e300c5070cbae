"""Devices: what a spec names, how it is opened, read and mapped onto the loop clock.

Each live device has a reader thread that blocks in the driver's
``samples()`` and appends every sample, stamped with the monotonic time it
arrived, to a deque; the loop takes everything up to the tick time without
ever blocking on a device. A device that goes away (the driver raises
DeviceError) is marked absent; its contacts end with phase "up" and the
hot-plug watcher reopens it when it comes back.

Sample times come from the device's clock (the kernel's event time, a
recording's time base) and are mapped onto the loop clock per device: the
offset is the smallest ``arrival - sample time`` seen (the fastest delivery),
creeping up slowly so clock drift is followed and a clock step is re-learnt.
"""

from __future__ import annotations

import collections
import logging
import math
import os
import stat
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from stiction.daemon.mapping import MappingConfig
from stiction.daemon.stats import RateMeter
from stiction.daemon.wake import Waker
from stiction.drivers.sample import PenSample
from stiction.drivers.source import SampleSource
from stiction.errors import DeviceError, SizeUnknown, StictionError

if TYPE_CHECKING:
    from stiction.drivers.info import DeviceInfo

log = logging.getLogger("stiction.daemon.devices")

_HEX = frozenset("0123456789abcdefABCDEF")

STEP_RESET_S = 1.0
"""A device clock that jumps by more than this against the loop clock is re-learnt."""
OFFSET_CREEP = 1e-3
"""Per-sample fraction by which the offset follows a later delivery (drift)."""


@dataclass(frozen=True, slots=True)
class DeviceConfig:
    """One [[devices]] entry (or a --device flag with the defaults)."""

    spec: str
    mapping: MappingConfig = field(default_factory=MappingConfig)
    mapping_given: bool = False
    surface_size: tuple[float, float] | None = None
    grab: bool = False
    backend: str | None = None
    """"hidraw" or "evdev" to read a VID:PID or named device through that
    backend; None follows stiction.drivers.discovery's rule."""


BACKENDS = ("hidraw", "evdev")


@dataclass(frozen=True, slots=True)
class Spec:
    """A parsed device spec: `kind` is synthetic, replay, hidraw, evdev, vidpid or name.

    `backend` is the backend a ``hidraw:``/``hid:`` or ``evdev:`` prefix asks
    for a VID:PID or a name (a path's kind already is its backend)."""

    kind: str
    target: str
    extra: str | None = None
    backend: str | None = None

    @property
    def finite(self) -> bool:
        """Replays and synthetic strokes can run under the virtual clock."""
        return self.kind in ("synthetic", "replay")


def _is_vidpid(text: str) -> bool:
    head, sep, rest = text.partition(":")
    return bool(sep) and len(head) == 4 and len(rest) == 4 and set(head + rest) <= _HEX


def _with_backend(backend: str, rest: str) -> Spec:
    """What follows a ``hidraw:``/``hid:`` or ``evdev:`` prefix: a path, a VID:PID
    or ``name:TEXT``; anything else is kept for spec_problem to refuse."""
    if _is_vidpid(rest):
        return Spec("vidpid", rest.lower(), backend=backend)
    head, sep, name = rest.partition(":")
    if sep and head == "name":
        return Spec("name", name, backend=backend)
    return Spec(backend, rest)


def parse_spec(text: str) -> Spec:
    """``synthetic:NAME``, ``replay:PATH[,EVENTS]``, ``/dev/hidrawN``,
    ``/dev/input/eventN``, ``VID:PID``, ``name:TEXT`` or any other text as a
    name to match; ``hidraw:`` (or ``hid:``) and ``evdev:`` before a path, a
    VID:PID or ``name:TEXT`` pick the backend."""
    t = text.strip()
    if not t:
        raise StictionError("empty device spec")
    head, sep, rest = t.partition(":")
    if sep and head == "synthetic":
        return Spec("synthetic", rest or "demo")
    if sep and head == "replay":
        if not rest:
            raise StictionError("replay: needs a recording path (replay:PATH)")
        path, _, events = rest.partition(",")
        return Spec("replay", path, events or None)
    if sep and head in ("hid", "hidraw"):
        return _with_backend("hidraw", rest)
    if sep and head == "evdev":
        return _with_backend("evdev", rest)
    if sep and head == "name":
        return Spec("name", rest)
    if t.startswith("/dev/hidraw"):
        return Spec("hidraw", t)
    if t.startswith("/dev/input/"):
        return Spec("evdev", t)
    if _is_vidpid(t):
        return Spec("vidpid", t.lower())
    return Spec("name", t)


def _vidpid_problem(text: str) -> str | None:
    head, _, rest = text.partition(":")
    if len(head) == 4 and len(rest) == 4 and set(head + rest) <= _HEX:
        return None
    return f"malformed VID:PID {text!r} (two 4-digit hex numbers, e.g. 256c:006d)"


def _path_problem(path: str, may_appear: bool) -> str | None:
    """Why `path` can never be an input device, or None if it is one or may become one."""
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        if may_appear:
            return None  # a /dev/input or /dev/hidraw node not plugged in yet
        return f"{path} does not exist and is not a /dev/input or /dev/hidraw node"
    except OSError:
        return None  # exists but unreadable: opening names the permission problem
    if stat.S_ISCHR(mode):
        kind = _char_subsystem(path)
        if kind is None or kind in ("input", "hidraw"):
            return None
        return (
            f"{path} is a {kind} device, not an input device "
            "(an evdev node in /dev/input or a /dev/hidrawN)"
        )
    hint = " (a recording? use replay:PATH)" if stat.S_ISREG(mode) else ""
    return f"{path} is not a character device{hint}"


def _char_subsystem(path: str) -> str | None:
    """The kernel subsystem of character device `path` ("input", "hidraw", "mem" for
    /dev/null, "tty", ...) from sysfs; None where sysfs does not say."""
    try:
        rdev = os.stat(path).st_rdev
        link = f"/sys/dev/char/{os.major(rdev)}:{os.minor(rdev)}/subsystem"
        return os.path.basename(os.readlink(link)) or None
    except OSError:
        return None


def spec_problem(spec: Spec) -> str | None:
    """Why a parsed spec can never become a device, or None if it is one or may appear later.

    Checked before the daemon starts, so that a typo is an error (exit 2)
    instead of a daemon that waits forever with 0 ticks. Replays and
    synthetic strokes are checked when they are opened, which the daemon does
    at once.
    """
    t = spec.target
    if spec.kind in ("hidraw", "evdev"):
        if not t.startswith("/"):
            if spec.kind == "hidraw":
                return _vidpid_problem(t)
            return f"not a path, VID:PID or name:TEXT after evdev: {t!r}"
        node = os.path.basename(t)
        may_appear = t.startswith("/dev/input/") or (
            os.path.dirname(t) == "/dev" and node.startswith("hidraw")
        )
        return _path_problem(t, may_appear)
    if spec.kind == "name":
        if t.startswith(("/", "./", "../")):
            return _path_problem(t, False)
        head, sep, rest = t.partition(":")
        if sep and head and rest and head.isalnum() and rest.isalnum() and len(head) <= 4:
            return _vidpid_problem(t)
    return None


def backend_problem(spec: Spec, backend: str | None) -> str | None:
    """Why `backend` (a config's ``backend`` key) cannot apply to `spec`, or None."""
    if backend is None:
        return None
    if backend not in BACKENDS:
        return f"must be 'hidraw' or 'evdev', got {backend!r}"
    if spec.kind in ("synthetic", "replay"):
        return f"a {spec.kind}: spec has no backend to choose; remove the backend key"
    if spec.kind in BACKENDS and spec.kind != backend:
        return (
            f"{spec.target} is read through {spec.kind}; name the device by VID:PID or "
            f"name for backend = {backend!r}"
        )
    if spec.backend is not None and spec.backend != backend:
        return f"the spec asks for {spec.backend} and the backend key for {backend}"
    return None


def _nodes_for(spec: Spec, backend: str | None) -> list[DeviceInfo]:
    """The discovered nodes that would read a VID:PID or name spec, best first."""
    from stiction.drivers.discovery import discover_all, select

    if spec.kind == "vidpid":
        return select(discover_all(), lambda i: i.vid_pid == spec.target, backend)
    want = spec.target.lower()
    return select(discover_all(), lambda i: want in i.name.lower(), backend)


DAEMON_SIZE_HOW = "size_mm = [width, height] in its [[devices]] entry of the stictiond config"
"""How stictiond's user gives a device's size (docs/daemon.md)."""


def open_source(
    spec: Spec,
    cfg: DeviceConfig,
    realtime: bool,
    loop: bool,
    size_how: str = DAEMON_SIZE_HOW,
) -> SampleSource:
    """Open what a spec names with the matching driver factory.

    A device without a size is refused naming `size_how`: how the user of the
    command that opens it (the daemon, `stiction trace`) gives one."""
    try:
        return _open_source(spec, cfg, realtime, loop)
    except SizeUnknown as exc:
        raise exc.told(size_how) from None


def _open_source(spec: Spec, cfg: DeviceConfig, realtime: bool, loop: bool) -> SampleSource:
    size = cfg.surface_size
    if spec.kind == "synthetic":
        from stiction.drivers.fake import synthetic

        return synthetic(spec.target, realtime=realtime, loop=loop)
    if spec.kind == "replay":
        path = Path(spec.target)
        if not path.exists():
            raise DeviceError(f"replay: no such recording {path}")
        if path.suffix == ".hid":
            from stiction.drivers.hid import replay as hid_replay

            return hid_replay(path, realtime=realtime, size_m=size)
        from stiction.drivers.evdev import replay as evdev_replay

        size_mm = (size[0] * 1e3, size[1] * 1e3) if size else None
        return evdev_replay(path, spec.extra, realtime=realtime, size_mm=size_mm)
    backend = cfg.backend or spec.backend
    if spec.kind == "hidraw" or (spec.kind == "vidpid" and backend == "hidraw"):
        from stiction.drivers import hid

        # open_hidraw picks the pen interface of a VID:PID itself
        return hid.open_hidraw(spec.target, size_m=size)
    if spec.kind == "evdev":
        from stiction.drivers import evdev

        size_mm = (size[0] * 1e3, size[1] * 1e3) if size else None
        return evdev.open_device(spec.target, grab=cfg.grab, size_mm=size_mm)
    # A VID:PID or a name: the node discovery picks for that device (or the
    # backend asked for), the first that opens.
    nodes = _nodes_for(spec, backend)
    usable = [info for info in nodes if info.problem is None]
    if usable:
        info = usable[0]
        why = f"asked for {backend}" if backend else info.reason
        log.info("device_backend spec=%s node=%s reason=%s", spec.target, info.path, why)
        return _open_source(Spec(info.backend, info.path), cfg, realtime, loop)
    what = f"id {spec.target}" if spec.kind == "vidpid" else f"a name like {spec.target!r}"
    through = f" through {backend}" if backend else ""
    if nodes:
        raise DeviceError(f"the device with {what}{through} cannot be read: {nodes[0].problem}")
    raise DeviceError(f"no device with {what}{through} is present")


class ClockMap:
    """Maps one device's sample times onto the loop's monotonic clock."""

    def __init__(self) -> None:
        self.offset: float | None = None
        self.steps = 0

    def observe(self, sample_t: float, arrival: float) -> None:
        d = arrival - sample_t
        if self.offset is None or abs(d - self.offset) > STEP_RESET_S:
            if self.offset is not None:
                self.steps += 1
            self.offset = d
        elif d < self.offset:
            self.offset = d
        else:
            self.offset += (d - self.offset) * OFFSET_CREEP

    def to_loop(self, sample_t: float) -> float:
        return sample_t + (self.offset or 0.0)


Arrival = tuple[PenSample, float]


@dataclass(eq=False)
class DeviceSlot:
    """One configured device and everything the loop knows about it."""

    config: DeviceConfig
    spec: Spec
    name: str
    state: str = "absent"  # "open" | "absent" | "ended"
    opened: bool = False  # ever opened: an absent slot never opened is reported "waiting"
    source: SampleSource | None = None
    kind: str = "pen"
    surface_size: tuple[float, float] | None = None
    queue: collections.deque[Arrival] = field(default_factory=collections.deque)
    pending: collections.deque[Arrival] = field(default_factory=collections.deque)
    clock: ClockMap = field(default_factory=ClockMap)
    samples: int = 0
    rejected: int = 0
    errors: int = 0
    reopened: int = 0
    meter: RateMeter = field(default_factory=RateMeter)
    last_t: float = -math.inf
    went_away: bool = False
    """Set by the reader when the device left; the loop ends its contacts."""
    run: Any = None
    """The pipeline's per-device contact state (stiction.scene.pipeline.DeviceRun)."""
    thread: threading.Thread | None = None
    iterator: Iterator[PenSample] | None = None
    lookahead: PenSample | None = None
    sent_tick: int = -1
    """Tick of the last frame published for this device (the next frame's prev_tick)."""
    quiet: bool = False
    """Its last tick brought no input and no contact, nor did the one before:
    when every device is quiet, the loop may idle."""

    def driver_stats(self) -> dict[str, int]:
        if self.source is None:
            return {}
        try:
            return dict(self.source.stats())
        except Exception:  # a driver's stats must never break the stats reply
            return {}


def valid(s: PenSample) -> bool:
    """A sample the loop can use: finite numbers where numbers belong.
    Anything else a driver might hand over is rejected, never raised."""
    try:
        return (
            math.isfinite(s.t)
            and math.isfinite(s.x)
            and math.isfinite(s.y)
            and isinstance(s.contact, int)
        )
    except (TypeError, ValueError, AttributeError):
        return False


def start_reader(
    slot: DeviceSlot, on_gone: Callable[[DeviceSlot], None], waker: Waker | None = None
) -> None:
    """Read `slot.source` on a thread until it ends, fails or is closed.

    Each sample is queued before `waker` is told, so an idle loop that wakes
    finds it (see stiction.daemon.wake)."""
    source = slot.source
    assert source is not None
    queue = slot.queue
    waker = waker or Waker()

    def run() -> None:
        try:
            for s in source.samples():
                queue.append((s, time.monotonic()))
                if waker.armed:
                    waker.wake()
            if slot.state == "open":
                slot.state = "ended"
                log.info("device_ended device=%s", slot.name)
        except DeviceError as exc:
            slot.errors += 1
            log.warning("device_gone device=%s error=%s", slot.name, exc)
            slot.state = "absent"
            on_gone(slot)
        except Exception:
            slot.errors += 1
            log.exception("device_reader_failed device=%s", slot.name)
            slot.state = "absent"
            on_gone(slot)
        finally:
            slot.went_away = True
            waker.wake()

    slot.went_away = False
    slot.thread = threading.Thread(target=run, name=f"reader {slot.name}", daemon=True)
    slot.thread.start()


def take_live(slot: DeviceSlot, prev_t: float, t: float) -> tuple[list[PenSample], float | None]:
    """Everything that arrived for `slot`, mapped onto the loop clock, up to tick `t`.

    Only samples that arrived by `t` are looked at (drain_live). Samples
    whose mapped time lies after `t` wait for the next tick; a sample
    mapped at or before the previous tick (clock jitter) is placed just after
    it so that none is lost. Returns the samples and the arrival time of the
    newest one handed over (for the latency statistic).
    """
    drain_live(slot, t)
    taken = select_live(slot, prev_t, t)
    commit_live(slot, taken)
    return taken.samples, taken.newest


@dataclass(slots=True)
class Taken:
    """What `select_live` would hand a tick, before anything is removed."""

    samples: list[PenSample]
    newest: float | None
    """Arrival time of the newest sample handed over (None: none)."""
    last_t: float
    """The slot's `last_t` once they are taken."""


def drain_live(slot: DeviceSlot, until: float = math.inf) -> None:
    """Move what the reader queued by loop time `until` (its arrival stamp)
    into the slot's pending samples, learning the device clock from each
    arrival.

    Done at a tick, or earlier (the loop's prepared tick, stiction.daemon.prepare):
    the clock sees the same arrivals in the same order either way, so when
    the draining happens changes nothing that is taken later. The tick at
    deadline t drains only what arrived by t: a sample stamped after it,
    queued before a late tick ran, waits for the next tick. So a tick's
    frame depends on what arrived by its deadline, not on how late the loop
    ran it, and an arrival after the deadline cannot spoil a tick prepared
    for it."""
    q = slot.queue
    pending = slot.pending
    while q and q[0][1] <= until:
        s, arrival = q.popleft()
        if not valid(s):
            slot.rejected += 1
            continue
        slot.clock.observe(s.t, arrival)
        pending.append((s, arrival))


def select_live(slot: DeviceSlot, prev_t: float, t: float) -> Taken:
    """The pending samples a tick at `t` takes, retimed, without taking them."""
    out: list[PenSample] = []
    newest: float | None = None
    floor = math.nextafter(prev_t, math.inf)
    last_t = slot.last_t
    to_loop = slot.clock.to_loop
    for s, arrival in slot.pending:
        lt = to_loop(s.t)
        if lt > t:
            break
        lt = max(lt, floor, last_t)
        last_t = lt
        out.append(_retime(s, lt))
        newest = arrival
    return Taken(out, newest, last_t)


def commit_live(slot: DeviceSlot, taken: Taken) -> None:
    """Remove what `select_live` selected from the slot's pending samples."""
    pending = slot.pending
    for _ in range(len(taken.samples)):
        pending.popleft()
    slot.last_t = taken.last_t
    slot.samples += len(taken.samples)


def take_virtual(slot: DeviceSlot, t: float) -> list[PenSample]:
    """Pull samples from a finite source up to loop time `t` (virtual clock)."""
    out: list[PenSample] = []
    it = slot.iterator
    if it is None:
        return out
    while True:
        s = slot.lookahead
        if s is None:
            try:
                s = next(it)
            except StopIteration:
                slot.iterator = None
                slot.state = "ended"
                slot.went_away = True
                break
            except DeviceError as exc:
                slot.errors += 1
                log.warning("device_gone device=%s error=%s", slot.name, exc)
                slot.iterator = None
                slot.state = "ended"
                slot.went_away = True
                break
            if not valid(s):
                slot.rejected += 1
                continue
        lt = slot.clock.to_loop(s.t)
        if lt > t:
            slot.lookahead = s
            break
        slot.lookahead = None
        lt = max(lt, slot.last_t)
        slot.last_t = lt
        out.append(_retime(s, lt))
    slot.samples += len(out)
    return out


def _retime(s: PenSample, t: float) -> PenSample:
    if t == s.t:
        return s
    return PenSample(
        t=t,
        x=s.x,
        y=s.y,
        tip=s.tip,
        in_range=s.in_range,
        contact=s.contact,
        pressure=s.pressure,
        tool=s.tool,
        tilt_x=s.tilt_x,
        tilt_y=s.tilt_y,
        buttons=s.buttons,
    )

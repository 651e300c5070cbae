"""Fixed-rate tick deadlines that never drift and never cascade.

Deadline n is ``start + n / rate`` computed from n, never by adding a period
to the previous deadline, so rounding cannot accumulate over a long run. A
tick that starts more than `late_threshold` after its deadline is counted as
late; if the loop falls so far behind that the next deadline has already
passed, the missed deadlines are skipped (and counted) rather than run back
to back, so one hiccup costs one late tick, not a burst of them.

The clock is separate from the schedule: `RealClock` sleeps on the monotonic
clock, `VirtualClock` jumps straight to each deadline, so a replay runs as
fast as the machine allows and gives the same ticks every time.

An idle daemon sleeps through deadlines (nothing to simulate, nothing new to
publish); `Schedule.resume` puts it back on the same grid without counting
those deadlines as missed.
"""

from __future__ import annotations

import contextlib
import ctypes
import math
import os
import sys
import time
from collections.abc import Callable
from typing import Protocol

PR_SET_TIMERSLACK = 29


Warm = Callable[[float], None]
"""What the loop runs at the start of its spin, given the coming deadline."""

Watch = Callable[[float, float], bool]
"""What the loop runs on each turn of the spin's polling, given the coming
deadline and the time now (the prepared tick redone when input arrives);
True when it did some of the tick's work."""

Nap = Callable[[float], None]
"""Sleep up to the given seconds, less if input arrives for a prepared
device; what the loop does between an early preparation and the spin."""

WARM_MARGIN = 0.2
"""The warm pass runs only if its expected duration plus this share of the
spin is left when the sleep ends: a later wake-up goes straight to polling.
At 0.5 (0.15 ms at the default spin) a loaded 20 s bench run skipped the
pass before 323 of 2000 ticks, the sleep having overshot by more. The
price of a smaller reserve: a pass that takes longer than its mean by more
than the reserve starts the tick that much late (passes measured p50
0.30 ms, p99 0.7 ms in a scratch run at load average 2)."""
WARM_CAP_S = 0.001
"""A warm pass that took longer (preempted, say) counts as this long in the
estimate, so one stall does not make every following wake-up early."""
WARM_EMA = 0.05
"""Weight of the newest warm pass in the running estimate of its duration."""
YIELD_S = 20e-6
YIELD_UNTIL_S = 150e-6
"""After a preparation, the polling sleeps YIELD_S at a time while more
than YIELD_UNTIL_S is left, then spins. Spinning throughout, the loop held
the interpreter for the whole 0.5-0.7 ms it was awake before the deadline,
and a reader, decoding in Python in 0.2 ms switch intervals, had most
samples due in that time stamped after the deadline (a period more of
latency for them; docs/daemon.md, "Issue 15: the prepared tick"). The
sleeps hand it the interpreter; the last 0.15 ms stays a spin, which a
20 us sleep's overshoot on the development VM stays well inside."""
LATE_INIT_S = 0.001
LATE_MIN_S = 0.0002
LATE_MAX_S = 0.003
"""With a nap (the loop's prepared tick), the clock wakes for the
preparation this much earlier than the spin and the preparation's learnt
duration need: a high quantile of how late that wake-up comes, learnt
online (LATE_QUANTILE), kept within these bounds. A wake-up later than the
whole lead leaves the preparation running past the deadline, or no
preparation at all, and that tick's work is the slow one (docs/daemon.md,
"Issue 15: the prepared tick"). A longer lead costs no tick work, only the
preparations redone for input arriving within it."""
LATE_QUANTILE = 0.995
LATE_STEP_S = 50e-6
"""The quantile's step: a wake-up later than the estimate raises it by
about this much, one on time lowers it by LATE_STEP_S * (1 - LATE_QUANTILE),
so that it settles where that share of wake-ups is later (stochastic
gradient descent on the quantile's pinball loss)."""
NAP_MIN_S = 50e-6
"""Naps shorter than this are not worth a wait: the polling's short sleeps take over."""


class Clock(Protocol):
    def now(self) -> float: ...
    def sleep_until(
        self,
        deadline: float,
        warm: Warm | None = None,
        watch: Watch | None = None,
        nap: Nap | None = None,
    ) -> None: ...


class RealClock:
    """time.monotonic, with a sleep that ends on the deadline rather than after it.

    A plain sleep wakes late by the kernel's timer slack plus however long
    the scheduler takes to run the thread again (0.1-0.3 ms typically on a
    virtual machine). With `spin` > 0 the clock sleeps to `spin` seconds
    before the deadline and then polls the clock until it passes, trading
    that much CPU per tick (0.3 ms at 100 Hz is 3% of a core, and only while
    the daemon ticks: an idle daemon does not) for a tick that starts on
    time. The polling holds the interpreter, but the daemon's short switch
    interval hands it to a reader thread that needs it within 0.2 ms.

    `warm`, if given, runs once at the start of the spin, before the bare
    polling: CPU the spin burns anyway brings the tick's code and data back
    into the caches (stiction.daemon.warm says what it runs and what that
    measured). The clock learns how long a warm pass takes (`warm_s`, a
    running mean) and wakes that much earlier, so the pass does not eat
    into the polling that puts the tick on time; a wake-up too late to fit
    it skips it. With no spin there is nothing to warm in: it never runs.

    `watch`, if given, is called on every turn of the polling after the
    warm pass with the deadline and the time: it must return at once when
    there is nothing to do (stiction.daemon.prepare redoes a prepared tick
    there when input arrived after it). It runs only where the warm pass
    did. A `warm` given with a watch is the loop's preparation of the tick
    itself rather than a warm pass: it runs on any wake-up before the
    deadline, and the part of it (or of the watch's work) that runs past
    the deadline is recorded (`overrun`) for the loop to count as the
    tick's work (for the watch's, the wall-clock time stands for its CPU
    time too: it runs without sleeping).

    `nap`, if given with both, moves the preparation ahead of the spin: the
    clock wakes `late_s` earlier than the spin and the preparation's learnt
    duration need (`late_s` a high quantile of that wake-up's lateness,
    learnt online), prepares, then naps until the spin; `nap` ends early
    when input arrives, and `watch` redoes the tick then, long before the
    deadline. A wake-up late by up to `late_s` still finds the tick
    prepared at the deadline; only input arriving in the last moments
    before it costs work after it.
    """

    virtual = False

    def __init__(self, spin: float = 0.0) -> None:
        if not (math.isfinite(spin) and 0.0 <= spin <= 0.005):
            raise ValueError(f"spin must be between 0 and 5 ms, got {spin * 1e3:g} ms")
        self.spin = spin
        self.warm_s = 0.0
        """Running mean of a warm pass's duration (s)."""
        self.warmed = 0
        self.warm_skipped = 0
        self.overrun = 0.0
        """How far the last sleep's warm pass ran past the deadline (s): the
        loop counts it as the tick's work, not as its lateness."""
        self.overrun_cpu = 0.0
        """The CPU time of that part (the pass's CPU time in proportion)."""
        self.overran = 0
        """Preparations that ran past their deadline."""
        self.late_s = LATE_INIT_S
        """The learnt high quantile of the early wake-up's lateness (s), with a nap."""

    def now(self) -> float:
        return time.monotonic()

    def sleep_until(
        self,
        deadline: float,
        warm: Warm | None = None,
        watch: Watch | None = None,
        nap: Nap | None = None,
    ) -> None:
        spin = self.spin
        if nap is not None and warm is not None and watch is not None and spin:
            self._prepare_ahead(deadline, warm, watch, nap)
            return
        monotonic = time.monotonic
        lead = spin + self.warm_s if warm is not None and spin else spin
        remaining = deadline - lead - monotonic()
        if remaining > 0:
            time.sleep(remaining)
        self.overrun = self.overrun_cpu = 0.0
        if spin:
            if warm is not None:
                start = monotonic()
                room = deadline - start
                # A warm pass must leave the polling its reserve; a preparation
                # (given with its watch) is the tick's own work, better begun
                # late than after the deadline: it runs whenever there is room.
                if room >= self.warm_s + spin * WARM_MARGIN or (watch is not None and room > 0):
                    if self._timed(warm, deadline, start, prepares=watch is not None):
                        return
                    if watch is not None:
                        self._watch_until(deadline, watch)
                        return
                else:
                    self.warm_skipped += 1
            while monotonic() < deadline:
                pass

    def _prepare_ahead(self, deadline: float, warm: Warm, watch: Watch, nap: Nap) -> None:
        """Wake for the preparation well ahead of the spin, prepare, nap to the
        spin (watching for input), then poll to the deadline as after any
        preparation."""
        monotonic = time.monotonic
        self.overrun = self.overrun_cpu = 0.0
        target = deadline - (self.spin + self.warm_s + self.late_s)
        remaining = target - monotonic()
        if remaining > 0:
            time.sleep(remaining)
        start = monotonic()
        if remaining > 0:
            self._learn_lateness(start - target)
        if start >= deadline:
            self.warm_skipped += 1  # too late for anything but the ordinary tick
            return
        if self._timed(warm, deadline, start, prepares=True):
            return
        self._watch_until(deadline, watch, nap)

    def _timed(self, warm: Warm, deadline: float, start: float, *, prepares: bool) -> bool:
        """Run the warm pass or preparation begun at `start`, learning how long it
        takes; True when it was a preparation and ran past the deadline.

        A preparation's part past the deadline is the tick's work (`overrun`,
        and its share of the thread's CPU time); a warm pass's is lateness, as
        the tick starts after it."""
        cpu = time.thread_time()
        warm(deadline)
        end = time.monotonic()
        took = end - start
        self.warm_s += (min(took, WARM_CAP_S) - self.warm_s) * WARM_EMA
        self.warmed += 1
        if end > deadline and prepares:
            self.overrun = end - deadline
            self.overran += 1
            self.overrun_cpu = (time.thread_time() - cpu) * self.overrun / took
            return True
        return False

    def _learn_lateness(self, late: float) -> None:
        """One step of the quantile estimate `late_s` (LATE_QUANTILE)."""
        if late > self.late_s:
            step = LATE_STEP_S * LATE_QUANTILE
        else:
            step = -LATE_STEP_S * (1.0 - LATE_QUANTILE)
        self.late_s = min(max(self.late_s + step, LATE_MIN_S), LATE_MAX_S)

    def _watch_until(self, deadline: float, watch: Watch, nap: Nap | None = None) -> None:
        """Poll to the deadline after a preparation, running `watch` on every
        turn; until the spin `nap` (if given), then sleeping YIELD_S at a
        time while more than YIELD_UNTIL_S is left; the watch's work past
        the deadline is recorded as `overrun`."""
        monotonic = time.monotonic
        sleep = time.sleep
        spin = self.spin
        past = 0.0
        while (now := monotonic()) < deadline:
            if watch(deadline, now):
                past = monotonic() - deadline
                continue
            left = deadline - now
            if nap is not None and left - spin > NAP_MIN_S:
                nap(left - spin)
            elif left > YIELD_UNTIL_S:
                sleep(YIELD_S)  # the readers take the interpreter meanwhile
        if past > 0:
            self.overrun = self.overrun_cpu = past
            self.overran += 1


def tighten_timer_slack() -> bool:
    """Ask Linux to wake this thread's timers on time (slack 1 ns, not 50 us).

    The default slack lets the kernel batch wake-ups up to 50 us late; a
    thread that keeps a deadline is worth the extra precision. Returns False
    where the call is not available (not Linux); nothing else changes then.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return bool(libc.prctl(PR_SET_TIMERSLACK, 1, 0, 0, 0) == 0)
    except (OSError, AttributeError):
        return False


class VirtualClock:
    """Time is whatever the last deadline was: ticks cost no waiting."""

    virtual = True

    def __init__(self, start: float = 0.0) -> None:
        self._now = start

    def now(self) -> float:
        return self._now

    def sleep_until(
        self,
        deadline: float,
        warm: Warm | None = None,
        watch: Watch | None = None,
        nap: Nap | None = None,
    ) -> None:
        """Jump to `deadline`; a virtual tick is not slowed by cold caches: no warm pass."""
        self._now = max(self._now, deadline)


def set_realtime(priority: int) -> str | None:
    """Run the calling thread under SCHED_FIFO at `priority` (1-99).

    A real-time thread runs the moment it wakes, ahead of every ordinary
    process: on a busy machine (renderers, a compositor, a build) the tick no
    longer waits for them. SCHED_RESET_ON_FORK makes every thread and process
    it starts ordinary again, so only the loop is real-time. Returns None, or
    why the kernel refused (it needs CAP_SYS_NICE or an RLIMIT_RTPRIO of at
    least `priority`); the thread is then unchanged.
    """
    if not hasattr(os, "sched_setscheduler"):
        return "real-time scheduling is not available on this platform"
    try:
        policy = os.SCHED_FIFO | os.SCHED_RESET_ON_FORK
        os.sched_setscheduler(0, policy, os.sched_param(priority))
    except OSError as exc:
        return (
            f"{exc.strerror or exc}: SCHED_FIFO needs CAP_SYS_NICE or an "
            f"RLIMIT_RTPRIO of at least {priority} (docs/daemon.md)"
        )
    return None


def set_thread_realtime(native_id: int, priority: int) -> str | None:
    """SCHED_FIFO at `priority` for another thread of this process (Linux: a tid).

    The readers run below the loop: above every ordinary process, so that a
    reader holding the GIL is not preempted by a compositor or a build while
    the loop waits for it, and below the loop, so that the loop runs first
    when both are ready. Returns None or why the kernel refused."""
    if not hasattr(os, "sched_setscheduler"):
        return "real-time scheduling is not available on this platform"
    try:
        policy = os.SCHED_FIFO | os.SCHED_RESET_ON_FORK
        os.sched_setscheduler(native_id, policy, os.sched_param(priority))
    except OSError as exc:
        return f"{exc.strerror or exc}"
    return None


_SCHED_SETATTR = {"x86_64": 314, "aarch64": 274}
"""sched_setattr(2)'s system call number (glibc has long had no wrapper)."""


class _SchedAttr(ctypes.Structure):
    """struct sched_attr up to sched_period (SCHED_ATTR_SIZE_VER0, 48 bytes)."""

    _fields_ = [
        ("size", ctypes.c_uint32),
        ("sched_policy", ctypes.c_uint32),
        ("sched_flags", ctypes.c_uint64),
        ("sched_nice", ctypes.c_int32),
        ("sched_priority", ctypes.c_uint32),
        ("sched_runtime", ctypes.c_uint64),
        ("sched_deadline", ctypes.c_uint64),
        ("sched_period", ctypes.c_uint64),
    ]


def request_slice(seconds: float) -> str | None:
    """Ask Linux's fair scheduler for time slices of `seconds` for the calling thread.

    Since Linux 6.12 an ordinary (SCHED_OTHER) thread may request its own
    slice through sched_setattr's sched_runtime (clamped to 0.1-100 ms; 0
    goes back to the default); under EEVDF a shorter slice gives the thread
    an earlier virtual deadline when it wakes, so it preempts a CPU-bound
    task sooner instead of waiting for that task's slice to end. No
    privilege is needed: the policy and nice value stay as they are. An
    experiment (`stiction bench daemon --slice-ms`), not something the
    daemon does by itself: on the shared VM the runs were too noisy to say
    whether it helps (docs/daemon.md). Returns None, or why it could not.
    """
    if not (math.isfinite(seconds) and 0.0 <= seconds <= 0.1):
        raise ValueError(f"slice must be between 0 and 100 ms, got {seconds * 1e3:g} ms")
    number = _SCHED_SETATTR.get(os.uname().machine)
    if not sys.platform.startswith("linux") or number is None:
        return "sched_setattr is only called on Linux x86_64 and aarch64 here"
    try:
        nice = os.getpriority(os.PRIO_PROCESS, 0)  # the calling thread's, on Linux
        attr = _SchedAttr(
            size=ctypes.sizeof(_SchedAttr),
            sched_policy=os.SCHED_OTHER,
            sched_flags=1,  # SCHED_FLAG_RESET_ON_FORK: threads it starts get the default
            sched_nice=nice,
            sched_runtime=round(seconds * 1e9),
        )
        libc = ctypes.CDLL(None, use_errno=True)
        if libc.syscall(number, 0, ctypes.byref(attr), 0) != 0:
            return os.strerror(ctypes.get_errno())
    except (OSError, AttributeError) as exc:
        return str(exc)
    return None


def set_ordinary() -> None:
    """Back to ordinary scheduling (lowering a thread's priority needs no rights)."""
    if hasattr(os, "sched_setscheduler"):
        with contextlib.suppress(OSError):
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))


class Schedule:
    """Deadlines on a fixed grid, with late and skipped ticks counted."""

    def __init__(self, rate: float, start: float, late_threshold: float | None = None) -> None:
        if not (math.isfinite(rate) and rate > 0):
            raise ValueError(f"rate must be a positive number, got {rate}")
        self.rate = rate
        self.start = start
        self.late_threshold = 0.5 / rate if late_threshold is None else late_threshold
        self.index = 0
        """Grid index of the next deadline (skipped deadlines advance it too)."""
        self.ticks = 0
        """Ticks run so far: the wire tick number of the next tick."""
        self.late = 0
        self.skipped = 0
        self.slept = 0
        """Deadlines an idle daemon slept through (not late, not missed)."""

    @property
    def deadline(self) -> float:
        return self.start + self.index / self.rate

    def begin(self, now: float) -> float:
        """Record that the tick for the current deadline starts at `now`;
        returns its lateness (seconds, negative if early)."""
        lateness = now - self.deadline
        if lateness > self.late_threshold:
            self.late += 1
        return lateness

    def finish(self, now: float) -> None:
        """Move to the next deadline after `now`, skipping any already missed."""
        self.ticks += 1
        self.index += 1
        if self.deadline < now:
            behind = math.floor((now - self.start) * self.rate) + 1
            self.skipped += behind - self.index
            self.index = behind

    def resume(self, now: float) -> None:
        """After idling: the next deadline is the first one not before `now`.

        Deadlines passed while idle are counted as slept, not skipped: nothing
        was due at them."""
        first = math.ceil((now - self.start) * self.rate - 1e-9)
        if first > self.index:
            self.slept += first - self.index
            self.index = first

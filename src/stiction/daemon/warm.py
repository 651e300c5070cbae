"""Keep the tick's working set warm while the loop spins to its deadline.

After each 10 ms sleep the (virtual) CPU comes back with cold caches: other
processes ran on it, and the tick's code (the interpreter paths of
take_live, the compiled scene tick's dispatch, msgpack, pyzmq's send) has
been evicted. Measured in a scratch run on the 2-CPU development VM (timing
the tick's parts with time.perf_counter_ns, synthetic:demo, no
subscribers), the live tick took about 0.3 ms where the same work back to
back takes 0.04 ms; its parts were each several times slower, the scene
step 130 us against 40 us once warmed, msgpack 24 us against 5, pyzmq's
send 54 us against 12.

The loop already burns the last `spin_ms` before each deadline polling the
clock. `Warmer.warm` spends the start of that spin running the same code
paths on scratch state instead: a scratch device slot fed one hover sample
(take_live), a scratch contact state stepped by the current pipeline, a
frame built and encoded from it, and a send through the publisher's
``warm`` (a socket with no peer, so nothing leaves the process). Nothing
the warm pass touches is read by a real tick: the frames published are
byte for byte those of a loop that never warms
(tests/daemon/test_daemon_warm.py replays a recording both ways).
"""

from __future__ import annotations

import copy
import logging
import time
from dataclasses import dataclass
from typing import Any, Protocol

from stiction import protocol
from stiction.daemon.devices import DeviceSlot, take_live
from stiction.drivers.sample import PenSample
from stiction.scene.pipeline import DeviceRun, Pipeline

log = logging.getLogger("stiction.daemon.warm")


@dataclass(eq=False, slots=True)
class _Scratch:
    """A device's stand-in: its own slot, contact state and mapping copy."""

    mapping: Any
    """The real mapping this scratch copied (a new one means a new scratch)."""
    slot: DeviceSlot
    run: DeviceRun
    sample: PenSample


class Loop(Protocol):
    """What the warm pass reads of the daemon (stiction.daemon.service.Daemon)."""

    @property
    def pipeline(self) -> Pipeline: ...
    @property
    def slots(self) -> list[DeviceSlot]: ...
    @property
    def publisher(self) -> Any: ...


class Warmer:
    """Runs the tick's code paths on scratch copies of each open device."""

    def __init__(self, daemon: Loop, period: float) -> None:
        """`period`: the tick period (the scratch's previous tick is one before)."""
        self.daemon = daemon
        self.period = period
        self._scratch: dict[int, _Scratch] = {}
        self.passes = 0
        self.enabled = True

    def warm(self, t: float, slots: list[DeviceSlot] | None = None) -> None:
        """One pass over every open device (or those of `slots`) for the tick
        at `t` (the previous tick taken as a period before); never raises.

        A failure (a bug: scratch state is ours alone) turns warming off for
        good and is logged once; the loop goes on without it."""
        if not self.enabled:
            return
        try:
            self._warm(t, t - self.period, self.daemon.slots if slots is None else slots)
            self.passes += 1
        except Exception:
            self.enabled = False
            log.exception("warm_failed (the loop goes on without warming)")

    def _warm(self, t: float, prev_t: float, slots: list[DeviceSlot]) -> None:
        d = self.daemon
        pipeline = d.pipeline
        send = getattr(d.publisher, "warm", None)
        for slot in slots:
            run = slot.run
            if run is None:
                continue
            s = self._for(slot, run)
            s.slot.queue.append((s.sample, time.monotonic()))
            samples, _ = take_live(s.slot, prev_t, t)
            contacts = pipeline.step(s.run, t, prev_t, samples)
            frame = protocol.frame(0, -1, t, s.slot.last_t, slot.name, contacts)
            if send is not None:
                send(protocol.frame_topic(slot.name), frame)

    def _for(self, slot: DeviceSlot, run: DeviceRun) -> _Scratch:
        """The slot's scratch, made anew when the slot's mapping changed (a
        reopened device, a scene with another display)."""
        s = self._scratch.get(id(slot))
        if s is None or s.mapping is not run.mapping:
            w, h = slot.surface_size or (0.1, 0.1)
            twin = DeviceSlot(config=slot.config, spec=slot.spec, name=slot.name)
            sample = PenSample(t=0.0, x=w / 2, y=h / 2, tip=False, in_range=True)
            s = _Scratch(run.mapping, twin, DeviceRun(copy.deepcopy(run.mapping)), sample)
            self._scratch[id(slot)] = s
        return s

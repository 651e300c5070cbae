#!/usr/bin/env python3
"""What the parts of the generated live evdev reader cost: the reader against copies of
itself with one part left out, timed in one process.

Usage: python tools/ablate_evdev_reader.py [--repeat N] [--data DIR]

Each variant is the reader's generated source (drivers/evdev/live_code.py,
live_mt_code.py) with one part removed, so its time is an upper bound on what
that part costs; the variants are not correct readers (none is kept). The
parts are the per-event loop's, so every reader here is made without its
shape functions (`shapes=False`, live_shapes.py): with them, the loop takes
only the reads no shape function covers (3% of the recordings' one-frame
reads), and the variants would time the shape functions instead:

- same: the reader unchanged, compiled again (the noise floor: it should
  match `reader` within a fraction of a per cent);
- no-snapshot: the read does not keep the state it began with (which lets a
  read hand itself to the assembler);
- no-frame-count: the assembler's frame counter is not advanced per read.

Every recording in DIR (default ../shared/data/evdev) is cut into one read
per frame, as `stiction bench evdev` does, and every variant reads it through
a reader made afresh (the set-up timed alone and taken out); the timings are
interleaved, minimum of the process's CPU time over N repeats. Prints the
steady microseconds per frame for each recording and pooled, and each
variant's difference from the reader. This is the evidence for the figures
in docs/evdev.md ("Where the per-read time goes"); it is not a benchmark.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
RECORDINGS = (
    "uc-logic-wp5540u-pen.evemu",
    "wacom-cintiq-12wx.evemu",
    "wacom-intuos4-6x9.desc",
    "wacom-cintiq-13hd-touch-pen.evemu",
    "elantech-touchpad.samsung-700z3a.evemu",
    "synaptics-touchpad.hp8470p.desc",
    "wacom-intuos5-touch-m-finger.desc",
    "cypress-trackpad.two-finger-press.evemu",
)

Edit = Callable[[str], str]
VARIANTS: dict[str, Edit] = {
    "reader": lambda text: text,
    "same": lambda text: text,
    "no-snapshot": lambda text: re.sub(r"snap = \(.*\)\n", "snap = None\n", text, count=1),
    "no-frame-count": lambda text: text.replace("asm._frames += made\n", "pass\n"),
}


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(prog="tools/ablate_evdev_reader.py", description=__doc__)
    parser.add_argument("--repeat", type=int, default=12, help="timed repeats (default 12)")
    parser.add_argument("--data", type=Path, default=ROOT.parent / "shared" / "data" / "evdev")
    opts = parser.parse_args(argv)

    import functools

    from stiction.drivers.evdev import columns, live_code, live_mt_code, sizes
    from stiction.drivers.evdev.device import DeviceGone, read_samples
    from stiction.drivers.evdev.frames import INPUT_EVENT, FrameAssembler
    from stiction.drivers.evdev.recording import load
    from stiction.drivers.evdev.units import SurfaceUnits

    def loop_reader(asm: FrameAssembler, units: SurfaceUnits) -> live_code.LiveReader:
        """The live reader without shape functions: every read walked by its loop."""
        fallback = functools.partial(read_samples, asm, units)
        long_read = INPUT_EVENT.size * columns.MIN_EVENTS
        return live_code.live_reader(
            asm, units, fallback, fallback, DeviceGone, long_read, shapes=False
        )

    single, multi = live_code.source, live_mt_code.source
    devices = []
    for name in RECORDINGS:
        rec = load(opts.data / name)
        size_mm = (100.0, 60.0) if "synaptics" in name else None  # as stiction bench evdev
        desc = sizes.apply(rec.description, size_mm)
        data = b"".join(INPUT_EVENT.pack(*e) for e in rec.events)
        reads, start = [], 0
        for i, e in enumerate(rec.events):
            if e[2] == 0 and e[3] == 0:
                reads.append(data[start * INPUT_EVENT.size : (i + 1) * INPUT_EVENT.size])
                start = i + 1
        devices.append((name, desc, SurfaceUnits(desc), reads))

    # Each variant's compiled reader per device, made through the generator itself.
    compiled: dict[tuple[str, str], object] = {}
    for variant, edit in VARIANTS.items():
        live_code._FACTORIES.clear()
        live_code._BY_IDENTITY.clear()
        live_code.source = lambda a, u, e=edit: e(single(a, u))  # type: ignore[assignment,misc]
        live_mt_code.source = lambda a, u, e=edit: e(multi(a, u))  # type: ignore[assignment,misc]
        for name, desc, units, _ in devices:
            compiled[(variant, name)] = live_code._compiled(FrameAssembler(desc), units)
    live_code.source, live_mt_code.source = single, multi
    real_compiled = live_code._compiled

    best = {key: float("inf") for key in compiled}
    for _ in range(opts.repeat):
        for (variant, name), made in compiled.items():
            _, desc, units, reads = next(d for d in devices if d[0] == name)
            live_code._compiled = lambda a, u, m=made: m  # type: ignore[assignment,misc]
            live_code._BY_IDENTITY.clear()  # else the first variant's reader is reused
            readers = [loop_reader(FrameAssembler(desc), units) for _ in range(10)]
            t0 = time.process_time()
            for r in readers:
                for _ in r.samples(reads):
                    pass
            whole = (time.process_time() - t0) / 10
            live_code._BY_IDENTITY.clear()
            readers = [loop_reader(FrameAssembler(desc), units) for _ in range(10)]
            t0 = time.process_time()
            for r in readers:
                for _ in r.samples(()):
                    pass
            setup = (time.process_time() - t0) / 10
            best[(variant, name)] = min(best[(variant, name)], (whole - setup) / len(reads))
    live_code._compiled = real_compiled

    print(f"{'recording':32}" + "".join(f"{v:>16}" for v in VARIANTS))
    frames = sum(len(d[3]) for d in devices)
    pooled = dict.fromkeys(VARIANTS, 0.0)
    for name, _, _, reads in devices:
        print(f"{name[:32]:32}" + "".join(f"{best[(v, name)] * 1e6:16.3f}" for v in VARIANTS))
        for v in VARIANTS:
            pooled[v] += best[(v, name)] * len(reads)
    print(
        f"{'pooled (us per frame)':32}"
        + "".join(f"{pooled[v] / frames * 1e6:16.3f}" for v in VARIANTS)
    )
    ref = pooled["reader"]
    print(
        f"{'difference from the reader':32}"
        + "".join(f"{(pooled[v] - ref) / ref:+16.1%}" for v in VARIANTS)
    )
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "src"))
    sys.exit(main(sys.argv[1:]))

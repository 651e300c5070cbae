#!/usr/bin/env python3
"""What the catalogue adds on real descriptors, and how its sizes compare with the descriptors'.

Usage: python tools/catalogue_coverage.py [COVERAGE_DIR]

COVERAGE_DIR defaults to ../shared/data/coverage (descriptors from
linuxwacom/wacom-hid-descriptors with libinput's size for each, see its
README). For every descriptor whose USB id is in the catalogue it prints
whether a size is known from the descriptor alone and with the catalogue,
and, where the descriptor, the catalogue and libinput all give a tablet
size, how far the first two are from libinput's (the largest of the width
and height differences, in mm). This is the evidence for the precedence in
docs/devices.md ("Catalogue or descriptor"); it is not a benchmark.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
COVERAGE = ROOT.parent / "shared" / "data" / "coverage"


def _mm(size: tuple[float, float]) -> str:
    return f"{size[0] * 1000:.1f} x {size[1] * 1000:.1f}"


def main(argv: list[str]) -> int:
    from stiction.drivers.hid.descriptor import parse_descriptor
    from stiction.drivers.hid.devices import lookup
    from stiction.drivers.hid.facts import describe_device
    from stiction.drivers.hid.recording import load_recording
    from stiction.drivers.hid.stream import ReportStream
    from stiction.errors import StictionError

    folder = Path(argv[0]) if argv else COVERAGE
    oracles = sorted(folder.glob("*.json"))
    if not oracles:
        print(f"catalogue_coverage: no *.json oracles in {folder}", file=sys.stderr)
        return 2
    known = alone = with_catalogue = 0
    compared = []
    for path in oracles:
        oracle = json.loads(path.read_text("utf-8"))
        rec = load_recording(path.with_suffix(".hid"))
        entry = lookup(rec.vid, rec.pid, None, rec.name or None, descriptor=rec.descriptor)
        if entry is None:
            continue
        known += 1
        try:
            own = ReportStream(parse_descriptor(rec.descriptor), rec.name).surface_size
        except StictionError:
            own = None
        facts = describe_device(rec.vid, rec.pid, rec.name, rec.descriptor)
        alone += own is not None
        with_catalogue += facts.surface_m is not None or facts.size_from == "vendor-init"
        tablets = [d["size_mm"] for d in oracle["libinput"] if d["kind"] == "tablet"]
        if own is not None and entry.size_m is not None and tablets and tablets[0]:
            lib = tablets[0]
            d_own = max(abs(own[i] * 1000 - lib[i]) for i in (0, 1))
            d_cat = max(abs(entry.size_m[i] * 1000 - lib[i]) for i in (0, 1))
            compared.append((path.stem, own, entry.size_m, lib, d_own, d_cat))
    print(f"descriptors whose id is in the catalogue: {known}")
    print(f"  with a size from the descriptor alone: {alone}")
    print(f"  with a size or a vendor initialisation, catalogue included: {with_catalogue}")
    print(f"descriptor, catalogue and libinput sizes all known: {len(compared)}")
    print(f"{'descriptor':48s} {'own mm':>15s} {'catalogue mm':>15s} {'libinput':>10s}  off by")
    for name, own, cat, lib, d_own, d_cat in compared:
        print(
            f"{name:48s} {_mm(own):>15s} {_mm(cat):>15s} {lib[0]:>4} x {lib[1]:<3}"
            f"  {d_own:.1f} / {d_cat:.1f}"
        )
    # Closer by more than 0.1 mm; the rest are even (their sizes differ by rounding).
    own_closer = sum(c[4] + 0.1 < c[5] for c in compared)
    cat_closer = sum(c[5] + 0.1 < c[4] for c in compared)
    print(
        f"closer to libinput by > 0.1 mm: descriptor {own_closer}, catalogue {cat_closer}, "
        f"even {len(compared) - own_closer - cat_closer}"
    )
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "src"))
    sys.exit(main(sys.argv[1:]))

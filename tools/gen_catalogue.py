#!/usr/bin/env python3
"""Regenerate src/stiction/drivers/catalogue/otd.json from OpenTabletDriver's tablet facts.

Usage: python tools/gen_catalogue.py [FACTS_JSON] [--check]

FACTS_JSON defaults to ../shared/data/tablets/otd-tablets.json (beside the
checkout). With --check nothing is written: the exit status says whether
the committed file is current (0) or stale (1).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "src" / "stiction" / "drivers" / "catalogue" / "otd.json"
FACTS = ROOT.parent / "shared" / "data" / "tablets" / "otd-tablets.json"


def render(facts: Path) -> str:
    from stiction.drivers.catalogue.otd import generate

    return json.dumps(generate(json.loads(facts.read_text("utf-8"))), indent=1) + "\n"


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(
        prog="tools/gen_catalogue.py",
        description="Regenerate the device catalogue's otd.json from OpenTabletDriver's facts.",
    )
    parser.add_argument(
        "facts", nargs="?", type=Path, default=FACTS, help=f"the facts file (default: {FACTS})"
    )
    parser.add_argument(
        "--check",
        action="store_true",
        help="write nothing; exit 0 if the committed file is current, 1 if stale",
    )
    opts = parser.parse_args(argv)
    facts = opts.facts
    try:
        text = render(facts)
    except (OSError, ValueError, KeyError) as exc:
        print(f"gen_catalogue: cannot read {facts}: {exc}", file=sys.stderr)
        return 2
    if opts.check:
        current = OUT.exists() and OUT.read_text("utf-8") == text
        print(f"{OUT.name}: {'current' if current else 'stale: run tools/gen_catalogue.py'}")
        return 0 if current else 1
    OUT.write_text(text, "utf-8")
    print(f"wrote {OUT} ({text.count(chr(10))} lines)")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "src"))
    sys.exit(main(sys.argv[1:]))

#!/usr/bin/env python3
"""Regenerate src/stiction/drivers/catalogue/otd.json from OpenTabletDriver's tablet facts.

Usage: python tools/gen_catalogue.py [FACTS_JSON] [--check]

FACTS_JSON defaults to ../shared/data/tablets/otd-tablets.json (beside the
checkout). With --check nothing is written: the exit status says whether
the committed file is current (0) or stale (1).
"""

from __future__ import annotations

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
    args = [a for a in argv if not a.startswith("--")]
    facts = Path(args[0]) if args else FACTS
    try:
        text = render(facts)
    except (OSError, ValueError, KeyError) as exc:
        print(f"gen_catalogue: cannot read {facts}: {exc}", file=sys.stderr)
        return 2
    if "--check" in argv:
        current = OUT.exists() and OUT.read_text("utf-8") == text
        print(f"{OUT.name}: {'current' if current else 'stale: run tools/gen_catalogue.py'}")
        return 0 if current else 1
    OUT.write_text(text, "utf-8")
    print(f"wrote {OUT} ({text.count(chr(10))} lines)")
    return 0


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT / "src"))
    sys.exit(main(sys.argv[1:]))

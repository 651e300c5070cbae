"""Coverage-guided fuzzing of one parser with atheris (libFuzzer), for `make fuzz`.

    python fuzz/run.py TARGET [libFuzzer flags]

Seeds come from the real files in ../shared/data and the package's examples;
a crashing input is written to tests/regressions/TARGET/ (libFuzzer's
artifact prefix), where tests/test_regressions.py replays it in `make test`.
"""

from __future__ import annotations

import sys
from pathlib import Path

import atheris

HERE = Path(__file__).resolve().parent
REPO = HERE.parent
SHARED = REPO.parent / "shared" / "data"

with atheris.instrument_imports(include=["stiction"]):
    # The parsers themselves, imported here so that they are instrumented
    # (targets.py imports them lazily, for the regression test's sake).
    import stiction.drivers.evdev.evemu
    import stiction.drivers.evdev.libinput_record
    import stiction.drivers.hid.decoder
    import stiction.drivers.hid.descriptor
    import stiction.drivers.hid.recording
    import stiction.drivers.hid.stream
    import stiction.protocol
    import stiction.scene.load
    import stiction.sim.trace  # noqa: F401

    sys.path.insert(0, str(HERE))
    import targets


def _seeds(name: str) -> list[Path]:
    pick = {
        "hid_recording": list(SHARED.glob("hid/*.hid"))[:10],
        "evemu": list(SHARED.glob("evdev/*.evemu")),
        "scene": list((REPO / "src/stiction/scene/examples").glob("*.toml")),
        "trace": list((REPO / "src/stiction/sim/examples").glob("stroke.csv")),
    }
    return pick.get(name, [])


def main() -> None:
    name = sys.argv[1]
    if name not in targets.TARGETS:
        sys.exit(f"unknown target {name!r}; known: {', '.join(targets.TARGETS)}")
    corpus = REPO / ".fuzz-corpus" / name
    corpus.mkdir(parents=True, exist_ok=True)
    for seed in _seeds(name):
        dest = corpus / seed.name
        if not dest.exists():
            dest.write_bytes(seed.read_bytes()[:65536])
    crashes = REPO / "tests" / "regressions" / name
    crashes.mkdir(parents=True, exist_ok=True)
    argv = [sys.argv[0], *sys.argv[2:], f"-artifact_prefix={crashes}/", str(corpus)]

    def one(data: bytes) -> None:
        targets.run_one(name, data)

    atheris.Setup(argv, one)
    atheris.Fuzz()


if __name__ == "__main__":
    main()

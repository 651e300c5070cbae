"""Pipeline.fork: a device's contact state stepped as a copy, for the daemon's prepared tick.

The daemon computes each tick before its deadline on a fork and keeps it
(Pipeline.adopt) or drops it. Here a random multi-contact stroke is stepped
three ways at every tick: a fork that is dropped, then the state itself, and
a fork that is kept, each against a reference pipeline stepped plainly. A
dropped fork must leave no trace, and a kept one must be the tick itself,
to the bit, across contacts beginning and ending (when the contact tables
are rebuilt) and a scene change.
"""

from __future__ import annotations

import pickle

from test_scene_batch import BACKEND, DEFAULTS, EXAMPLES, SIZE, _strokes

from stiction.daemon.mapping import AreaMapping, MappingConfig, RelativeMapping
from stiction.scene.load import default_scene, load_scene
from stiction.scene.pipeline import DeviceRun, Pipeline


def _state(dev: DeviceRun) -> bytes:
    s = dev.slots
    if s is None:
        return pickle.dumps(dict(dev.tracks))
    parts = (dict(dev.tracks), s.S, s.L, s.order_ids, s.order_slots, s.pos_of, list(s.free))
    return pickle.dumps(parts)


def test_a_dropped_fork_leaves_no_trace_and_a_kept_one_is_the_tick() -> None:
    scenes = [load_scene(EXAMPLES / "demo.toml"), default_scene()]
    ticks = _strokes(7, 4, 160)
    mapping = AreaMapping(SIZE, scenes[0].display, MappingConfig())
    ref, dev = DeviceRun(mapping), DeviceRun(mapping)
    p = Pipeline(scenes[0], BACKEND, DEFAULTS)
    prev = 0.0
    kept = 0
    ended = 0
    for n, samples in enumerate(ticks):
        if n == 80:
            p = Pipeline(scenes[1], BACKEND, DEFAULTS)
        t = (n + 1) * 0.01
        want = p.step(ref, t, prev, samples)
        before = _state(dev)
        dropped = p.fork(dev)
        assert dropped is not None
        p.step(dropped, t, prev, samples)
        assert _state(dev) == before, f"tick {n}: a dropped fork changed the state"
        if n % 2:
            got = p.step(dev, t, prev, samples)
        else:
            fork = p.fork(dev)
            assert fork is not None
            got = p.step(fork, t, prev, samples)
            Pipeline.adopt(dev, fork)
            kept += 1
        assert pickle.dumps(got) == pickle.dumps(want), f"tick {n}"
        ended += sum(c["phase"] == "up" for c in want)
        assert _state(dev) == _state(ref), f"tick {n}"
        prev = t
    assert kept == 80
    assert ended > 5  # contacts did end (and begin again): the tables were rebuilt


def test_a_relative_mapping_is_not_forked() -> None:
    scene = default_scene()
    p = Pipeline(scene, BACKEND, DEFAULTS)
    dev = DeviceRun(RelativeMapping(SIZE, scene.display, MappingConfig(mode="relative")))
    assert p.fork(dev) is None

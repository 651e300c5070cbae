"""The compiled pipeline: only the stages a scene asks for, with the real simulator."""

from __future__ import annotations

import itertools

from stiction.daemon.mapping import AreaMapping, MappingConfig
from stiction.drivers.sample import PenSample
from stiction.scene.backend import SimulatorBackend
from stiction.scene.load import default_scene, parse_scene
from stiction.scene.pipeline import DeviceRun, Pipeline

BACKEND = SimulatorBackend()
DEFAULTS = BACKEND.defaults()
# 0.2 m x 0.1 m surface on a 2000 x 1000 display: 10 px per mm.
SIZE = (0.2, 0.1)

HALF = """
[scene]
display = [2000, 1000]
effects = [{effects}]
[materials.glue]
mu_s = 1.0
mu_k = 0.1
[[regions]]
shape = "rect"
rect = [1000, 0, 1000, 1000]
material = "glue"
"""


def _run(scene_text: str | None, path: list[tuple[float, float, bool]], dt: float = 0.01):  # type: ignore[no-untyped-def]
    scene = parse_scene(scene_text, "t.toml") if scene_text else default_scene((2000, 1000))
    pipe = Pipeline(scene, BACKEND, DEFAULTS)
    dev = DeviceRun(AreaMapping(SIZE, scene.display, MappingConfig()))
    frames = []
    for i, (x, y, tip) in enumerate(path):
        t = (i + 1) * dt
        sample = PenSample(t=t, x=x, y=y, tip=tip, pressure=0.5)
        frames.append((pipe.step(dev, t, t - dt, [sample]), dev))
    return pipe, dev, frames


def _drag(x0: float, x1: float, n: int) -> list[tuple[float, float, bool]]:
    return [(x0 + (x1 - x0) * i / (n - 1), 0.05, True) for i in range(n)]


def test_pass_through_keeps_no_simulator_and_copies_the_touch() -> None:
    pipe, dev, frames = _run(HALF.format(effects='"stick_slip", "string"'), _drag(0.01, 0.09, 20))
    for contacts, _ in frames:
        (c,) = contacts
        assert c["material"] == "pass-through" and c["phase"] == "slip"
        assert c["pointer_m"] == c["touch_m"] and c["tension"] == 0.0
    assert not pipe.holds_simulator(dev, 0)


def test_friction_region_sticks_then_slips() -> None:
    pipe, dev, frames = _run(HALF.format(effects='"stick_slip"'), _drag(0.12, 0.18, 60))
    phases = [f[0][0]["phase"] for f in frames]
    assert phases[0] == "stick" and "slip" in phases
    assert all(f[0][0]["material"] == "glue" for f in frames)
    assert pipe.holds_simulator(dev, 0)


def test_string_and_pressure_fields_only_when_asked() -> None:
    _, _, plain = _run(HALF.format(effects='"stick_slip"'), _drag(0.12, 0.13, 5))
    assert all("string" not in c and "pressure" not in c for f in plain for c in f[0])
    _, _, full = _run(
        HALF.format(effects='"stick_slip", "string", "pressure_load"'), _drag(0.12, 0.13, 5)
    )
    for contacts, _ in full:
        (c,) = contacts
        assert set(c["string"]) == {"length_px", "dir"}  # type: ignore[typeddict-item]
        assert c["pressure"] == 0.5 and c["load_gain"] == 1.0  # type: ignore[typeddict-item]
    _, _, none = _run("[scene]\neffects = []\n", _drag(0.12, 0.13, 5))
    assert all(c["pointer_m"] == c["touch_m"] and "string" not in c for f in none for c in f[0])


def test_entering_friction_grabs_the_pen_and_leaving_glides_back() -> None:
    # Drag from the free half (x < 0.1 m) into the glue half and back out.
    path = _drag(0.08, 0.12, 30) + _drag(0.12, 0.04, 60)
    pipe, dev, frames = _run(HALF.format(effects='"stick_slip"'), path)
    materials = [f[0][0]["material"] for f in frames]
    assert materials[0] == "pass-through" and "glue" in materials
    entered = materials.index("glue")
    assert frames[entered][0][0]["phase"] == "stick"
    # Back in free space the pointer converges on the touch and the simulator is dropped.
    last = frames[-1][0][0]
    assert last["material"] == "pass-through" and last["pointer_m"] == last["touch_m"]
    assert not pipe.holds_simulator(dev, 0)
    jumps = [
        abs(b[0][0]["pointer_px"][0] - a[0][0]["pointer_px"][0])
        for a, b in itertools.pairwise(frames)
    ]
    assert max(jumps) < 40  # no jump: at most the stroke's own speed (13 px/tick) plus the glide


def test_lift_reports_up_once_and_forgets_the_contact() -> None:
    path = [*_drag(0.12, 0.13, 5), (0.13, 0.05, False)]
    _, dev, frames = _run(None, path)
    assert frames[-1][0][0]["phase"] == "hover"
    pipe = Pipeline(default_scene((2000, 1000)), BACKEND, DEFAULTS)
    out = pipe.step(dev, 1.0, 0.99, [PenSample(t=1.0, x=0.13, y=0.05, tip=False, in_range=False)])
    assert [c["phase"] for c in out] == ["up"]
    assert dev.tracks == {}
    assert pipe.step(dev, 1.01, 1.0, []) == []


def test_default_scene_wire_has_the_standard_material() -> None:
    pipe = Pipeline(default_scene(), BACKEND, DEFAULTS)
    wire = pipe.wire()
    assert wire["outside"] == "standard"
    assert wire["materials"]["standard"]["mu_s"] == 0.7
    assert wire["materials"]["standard"]["k"] == DEFAULTS["k"]

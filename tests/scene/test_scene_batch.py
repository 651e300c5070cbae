"""The batch pipeline against the naive per-contact one: the same frames, tick by tick.

`NaivePipeline` steps one ContactSim per contact; `Pipeline` steps every
contact of a tick in one call over rows. They must publish the same contacts
(ids, phases, materials, fields) with the same numbers, on the demo scene and
on random scenes and strokes (hypothesis), including across a scene change
and parameters applied while contacts sit on a material (issue 13).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from stiction.daemon.mapping import AreaMapping, MappingConfig, RelativeMapping
from stiction.drivers.sample import PenSample
from stiction.scene.backend import SimulatorBackend
from stiction.scene.load import load_scene, parse_scene
from stiction.scene.model import Scene
from stiction.scene.pipeline import DeviceRun, NaivePipeline, Pipeline

BACKEND = SimulatorBackend()
DEFAULTS = BACKEND.defaults()
SIZE = (0.2, 0.1)
EXAMPLES = Path(__file__).resolve().parents[2] / "src" / "stiction" / "scene" / "examples"
TOL_M = 1e-12
TOL_PX = 1e-6


def _same(got: list[Any], want: list[Any], where: str) -> None:
    assert [c["id"] for c in got] == [c["id"] for c in want], where
    for g, w in zip(got, want, strict=True):
        assert set(g) == set(w), where
        assert g["phase"] == w["phase"], where
        assert g["material"] == w["material"], where
        for key, tol in (("touch_m", TOL_M), ("pointer_m", TOL_M), ("touch_px", TOL_PX)):
            assert np.allclose(g[key], w[key], rtol=0, atol=tol), (where, key, g, w)
        assert np.allclose(g["pointer_px"], w["pointer_px"], rtol=0, atol=TOL_PX), where
        assert math.isclose(g["tension"], w["tension"], rel_tol=1e-9, abs_tol=1e-12), where
        if "string" in w:
            gs, ws = g["string"], w["string"]
            assert math.isclose(gs["length_px"], ws["length_px"], rel_tol=1e-9, abs_tol=1e-6)
            assert np.allclose(gs["dir"], ws["dir"], rtol=0, atol=1e-6), where
        if "pressure" in w:
            assert g["pressure"] == w["pressure"] and g["load_gain"] == w["load_gain"], where


def _strokes(seed: int, contacts: int, ticks: int) -> list[list[PenSample]]:
    """Random drags with pauses, lifts, hover, pressure and up to three samples per tick."""
    rng = np.random.default_rng(seed)
    pos = rng.uniform(0.0, 1.0, (contacts, 2)) * SIZE
    vel = np.zeros((contacts, 2))
    state = np.zeros(contacts, dtype=np.int64)  # 0 touching, 1 hover, 2 away
    out = []
    for n in range(ticks):
        batch = []
        k = int(rng.integers(0, 4))
        for j in range(k):
            t = (n + (j + 1) / (k + 1)) * 0.01
            vel += rng.normal(0, 0.03, (contacts, 2))
            vel[rng.uniform(size=contacts) < 0.2] = 0.0
            pos = np.clip(pos + vel * 0.01 / max(k, 1), 0.0, SIZE)
            flip = rng.uniform(size=contacts)
            state = np.where(flip < 0.03, (state + 1) % 3, state)
            pressure = rng.uniform(0, 1, contacts)
            for c in range(contacts):
                if rng.uniform() < 0.2:
                    continue
                p: float | None = float(pressure[c]) if c % 3 else None
                batch.append(
                    PenSample(
                        t=t,
                        x=float(pos[c, 0]),
                        y=float(pos[c, 1]),
                        tip=bool(state[c] == 0),
                        in_range=bool(state[c] < 2),
                        pressure=p,
                        contact=c,
                    )
                )
        out.append(batch)
    return out


def _compare(
    scenes: list[Scene],
    ticks: list[list[PenSample]],
    switch_at: int = 10**9,
    mapping: Any = None,
    compiled: bool = True,
) -> None:
    """Both pipelines over the same ticks; the scene changes to scenes[1] at tick switch_at."""
    make = mapping or (lambda sc: AreaMapping(SIZE, sc.display, MappingConfig()))
    naive = NaivePipeline(scenes[0], BACKEND, DEFAULTS)
    batch = Pipeline(scenes[0], BACKEND, DEFAULTS, compiled=compiled)
    dn, db = DeviceRun(make(scenes[0])), DeviceRun(make(scenes[0]))
    prev = 0.0
    for n, samples in enumerate(ticks):
        if n == switch_at:
            naive = NaivePipeline(scenes[1], BACKEND, DEFAULTS)
            batch = Pipeline(scenes[1], BACKEND, DEFAULTS, compiled=compiled)
        t = (n + 1) * 0.01
        _same(batch.step(db, t, prev, samples), naive.step(dn, t, prev, samples), f"tick {n}")
        prev = t
    _same(batch.end_all(db), naive.end_all(dn), "end_all")
    assert db.tracks == {} and dn.tracks == {}


def test_demo_scene_batch_equals_naive() -> None:
    scene = load_scene(EXAMPLES / "demo.toml")
    _compare([scene], _strokes(1, 12, 300))


def test_the_tick_as_plain_python_equals_naive() -> None:
    """What runs while the compiled tick is still compiling (Pipeline.warm_up)."""
    scene = load_scene(EXAMPLES / "demo.toml")
    _compare([scene], _strokes(4, 5, 60), compiled=False)


def test_warm_up_compiles_the_tick_on_a_thread() -> None:
    pipe = Pipeline(load_scene(EXAMPLES / "demo.toml"), BACKEND, DEFAULTS)
    pipe.warm_up(wait=0.0)
    _, _, compiled = pipe._ready()
    assert compiled.ready.wait(300)
    assert pipe.warm_up(wait=0.0)


def test_every_example_scene_batch_equals_naive() -> None:
    for path in sorted(EXAMPLES.glob("*.toml")):
        _compare([load_scene(path)], _strokes(2, 6, 120))


def test_relative_mapping_runs_the_naive_pipeline() -> None:
    scene = load_scene(EXAMPLES / "demo.toml")
    _compare(
        [scene],
        _strokes(3, 4, 60),
        mapping=lambda sc: RelativeMapping(SIZE, sc.display, MappingConfig(mode="relative")),
    )


_MATERIAL = st.fixed_dictionaries(
    {
        "mu_s": st.sampled_from([0.0, 0.3, 0.7, 1.5]),
        "mu_k": st.sampled_from([0.0, 0.1, 0.4]),
    },
    optional={"k": st.sampled_from([0.05, 0.3, 2.0]), "C_l": st.sampled_from([500.0, 3000.0])},
)
_SHAPE = st.one_of(
    st.tuples(st.just("rect"), st.integers(0, 1800), st.integers(0, 900), st.integers(50, 900)),
    st.tuples(st.just("circle"), st.integers(0, 2000), st.integers(0, 1000), st.integers(20, 600)),
    st.tuples(st.just("polygon"), st.integers(0, 1500), st.integers(0, 700), st.integers(60, 700)),
)


def _scene_text(
    effects: list[str], materials: list[dict[str, float]], regions: list[Any], outside: int
) -> str:
    lines = ["[scene]", "display = [2000, 1000]", f"effects = {effects!r}".replace("'", '"')]
    if outside >= 0:
        lines.append(f'outside = "m{outside % len(materials)}"')
    for i, mat in enumerate(materials):
        lines.append(f"[materials.m{i}]")
        lines.extend(f"{k} = {v!r}" for k, v in mat.items())
    for j, (shape, a, b, c) in enumerate(regions):
        lines.append("[[regions]]")
        lines.append(f'name = "r{j}"')
        lines.append(f'shape = "{shape}"')
        if shape == "rect":
            lines.append(f"rect = [{a}, {b}, {c}, {c // 2 + 10}]")
        elif shape == "circle":
            lines.append(f"center = [{a}, {b}]")
            lines.append(f"radius = {c}")
        else:
            lines.append(f"points = [[{a}, {b}], [{a + c}, {b + c // 3}], [{a + c // 2}, {b + c}]]")
        mat = j % (len(materials) + 1)
        name = f"m{mat}" if mat < len(materials) else "pass-through"
        lines.append(f'material = "{name}"')
    return "\n".join(lines) + "\n"


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.sampled_from(["stick_slip", "string", "pressure_load"]), unique=True),
    st.lists(_MATERIAL, min_size=1, max_size=3),
    st.lists(_SHAPE, max_size=4),
    st.integers(-1, 2),
    st.integers(0, 2**32 - 1),
    st.integers(1, 6),
)
def test_random_scenes_batch_equals_naive(
    effects: list[str],
    materials: list[dict[str, float]],
    regions: list[Any],
    outside: int,
    seed: int,
    contacts: int,
) -> None:
    if "pressure_load" in effects and "stick_slip" not in effects:
        effects = [*effects, "stick_slip"]
    scene = parse_scene(_scene_text(effects, materials, regions, outside), "random.toml")
    # Half-way, the same scene with every material's values changed (set_params).
    changed = [{**m, "k": 0.4, "C_l": 1234.0, "mu_s": 0.2} for m in materials]
    scene2 = parse_scene(_scene_text(effects, changed, regions, outside), "random.toml")
    _compare([scene, scene2], _strokes(seed, contacts, 80), switch_at=40)


def test_new_parameters_apply_to_a_contact_already_on_the_material() -> None:
    """Issue 13: after set_params a stuck contact's tension follows the new k at the next tick."""
    text = '[scene]\ndisplay = [2000, 1000]\neffects = ["stick_slip", "string"]\noutside = "m"\n'
    soft = parse_scene(text + "[materials.m]\nmu_s = 1.0\nmu_k = 0.1\nk = 0.1\n", "a.toml")
    stiff = parse_scene(text + "[materials.m]\nmu_s = 1.0\nmu_k = 0.1\nk = 0.2\n", "b.toml")
    for cls in (Pipeline, NaivePipeline):
        pipe: Any = cls(soft, BACKEND, DEFAULTS)
        dev = DeviceRun(AreaMapping(SIZE, soft.display, MappingConfig()))
        out = []
        for n, x in enumerate([0.05, 0.051, 0.051, 0.051]):
            if n == 2:
                pipe = cls(stiff, BACKEND, DEFAULTS)  # what set_params / set_scene do
            t = (n + 1) * 0.01
            (c,) = pipe.step(dev, t, t - 0.01, [PenSample(t=t, x=x, y=0.05, tip=True)])
            out.append(c)
        assert [c["phase"] for c in out] == ["stick"] * 4
        assert math.isclose(out[1]["tension"], 0.1 * 0.001, rel_tol=1e-9)
        assert math.isclose(out[2]["tension"], 0.2 * 0.001, rel_tol=1e-9), cls
        length = out[2]["string"]["length_px"]  # type: ignore[typeddict-item]
        assert math.isclose(length, 2000 * math.sqrt(0.2 * 0.001), rel_tol=1e-9)

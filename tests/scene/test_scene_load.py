"""Scene files: the shipped examples load, and every mistake names file, line and field."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from stiction.errors import SceneError
from stiction.scene.load import default_scene, example_path, load_scene, parse_scene
from stiction.scene.model import Circle, Polygon, Rect

EXAMPLES = ["demo", "paper", "comparison", "pressure", "passthrough"]

GOOD = """\
[scene]
name = "t"
display = [800, 600]
effects = ["stick_slip", "string"]

[materials.rubber]
mu_s = 0.9
mu_k = 0.1

[[regions]]
shape = "rect"
rect = [0, 0, 100, 100]
material = "rubber"

[[regions]]
shape = "circle"
center = [400, 300]
radius = 50
material = "rubber"
"""


@pytest.mark.parametrize("name", EXAMPLES)
def test_shipped_examples_load(name: str) -> None:
    scene = load_scene(example_path(name))
    assert scene.name == name
    assert scene.display == (1920, 1080)


def test_demo_scene_has_sticky_slippery_and_free_space() -> None:
    scene = load_scene(example_path("demo"))
    sticky = scene.materials[scene.material_at(100, 500) or ""]
    slippery = scene.materials[scene.material_at(1800, 500) or ""]
    assert sticky.mu_s > 0.9 and slippery.mu_s < 0.2
    assert scene.material_at(700, 100) is None  # pass-through between the bands
    assert scene.material_at(960, 540) == "standard"  # the disc lies on top


def test_default_scene_is_the_papers_standard_stimulus_with_string() -> None:
    scene = default_scene()
    m = scene.materials[scene.material_at(5, 5) or ""]
    assert (m.mu_s, m.mu_k) == (0.7, 0.1)
    assert scene.effects == {"stick_slip", "string"}


@pytest.mark.parametrize(
    ("old", "new", "line", "field"),
    [
        ("radius = 50", "radius = -3", 18, "regions[1].radius"),
        ("mu_s = 0.9", 'mu_s = "high"', 7, "materials.rubber.mu_s"),
        (
            'material = "rubber"\n\n[[regions]]',
            'material = "glue"\n\n[[regions]]',
            13,
            "regions[0].material",
        ),
        ("display = [800, 600]", "display = [800]", 3, "scene.display"),
        ('effects = ["stick_slip", "string"]', 'effects = ["string"]', 4, "scene.effects"),
        ('effects = ["stick_slip", "string"]', 'effects = ["sparkle"]', 4, "scene.effects"),
        ("mu_k = 0.1", "mu_k = 0.1\nmu_z = 1", 9, "materials.rubber.mu_z"),
        ('shape = "circle"', 'shape = "hexagon"', 16, "regions[1].shape"),
        ("rect = [0, 0, 100, 100]", "rect = [0, 0, 0, 100]", 12, "regions[0].rect"),
        ("center = [400, 300]", "center = [400, nan]", 17, "regions[1].center"),
    ],
)
def test_errors_name_file_line_and_field(
    tmp_path: Path, old: str, new: str, line: int, field: str
) -> None:
    assert old in GOOD
    path = tmp_path / "bad.toml"
    path.write_text(GOOD.replace(old, new, 1))
    with pytest.raises(SceneError) as exc:
        load_scene(path)
    assert str(exc.value).startswith(f"{path}:{line}: {field}: "), str(exc.value)


def test_good_text_is_accepted_and_geometry_kept() -> None:
    scene = parse_scene(GOOD, "good.toml")
    assert isinstance(scene.regions[0].shape, Rect)
    assert isinstance(scene.regions[1].shape, Circle)
    assert scene.outside is None


def test_syntax_error_names_file_and_line(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=r"x\.toml: not valid TOML: .*line 2"):
        parse_scene("[scene]\nname = \n", "x.toml")


def test_unreadable_file_is_a_scene_error(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="cannot read scene"):
        load_scene(tmp_path / "missing.toml")


def test_multiline_polygon_points_do_not_confuse_line_numbers() -> None:
    text = (
        '[materials.a]\nmu_s = 1\nmu_k = 0.1\n\n[[regions]]\nshape = "polygon"\n'
        "points = [\n  [0, 0],\n  [10, 0],\n  [10, 10],\n]\n"
        'material = "b"\n'
    )
    with pytest.raises(SceneError, match=r"^s\.toml:12: regions\[0\]\.material: unknown"):
        parse_scene(text, "s.toml")


def test_region_can_be_a_pass_through_hole() -> None:
    text = GOOD + '\n[[regions]]\nshape = "rect"\nrect = [10, 10, 20, 20]\n'
    text += 'material = "pass-through"\n'
    scene = parse_scene(text, "hole.toml")
    assert scene.material_at(15, 15) is None
    assert scene.material_at(50, 50) == "rubber"


def test_pressure_table_requires_the_effect() -> None:
    with pytest.raises(SceneError, match="pressure_load: given but"):
        parse_scene(GOOD + "\n[pressure_load]\nmin_gain = 0.2\n", "p.toml")


@given(
    st.lists(
        st.tuples(st.integers(-50, 50), st.integers(-50, 50)), min_size=3, max_size=3, unique=True
    ),
    st.floats(-60, 60),
    st.floats(-60, 60),
)
def test_polygon_matches_triangle_barycentric_test(
    pts: list[tuple[int, int]], x: float, y: float
) -> None:
    (x0, y0), (x1, y1), (x2, y2) = pts
    det = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2)
    if det == 0:
        return
    a = ((y1 - y2) * (x - x2) + (x2 - x1) * (y - y2)) / det
    b = ((y2 - y0) * (x - x2) + (x0 - x2) * (y - y2)) / det
    c = 1 - a - b
    margin = 1e-9
    if min(a, b, c) > margin:
        assert Polygon(tuple((float(p), float(q)) for p, q in pts)).contains(x, y)
    elif min(a, b, c) < -margin:
        assert not Polygon(tuple((float(p), float(q)) for p, q in pts)).contains(x, y)


@given(st.data())
def test_any_edit_of_a_scene_gives_a_scene_or_a_scene_error(data: st.DataObject) -> None:
    """Delete, duplicate or replace a stretch of a good file: never another exception."""
    text = GOOD
    for _ in range(data.draw(st.integers(1, 3))):
        i = data.draw(st.integers(0, len(text)))
        j = data.draw(st.integers(i, min(len(text), i + 12)))
        filler = data.draw(st.text(alphabet='[]{}=",.#-0123456789abcdefgnrstxyz \n', max_size=8))
        text = text[:i] + filler + text[j:]
    try:
        parse_scene(text, "fuzz.toml")
    except SceneError as exc:
        assert str(exc).startswith("fuzz.toml")

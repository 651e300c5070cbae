"""Surface metres -> display pixels: area mapping with aspect and rotation, relative mapping."""

from __future__ import annotations

import pytest

from stiction.daemon.mapping import (
    AreaMapping,
    MappingConfig,
    MappingError,
    RelativeMapping,
    make_mapping,
)

SIZE = (0.2, 0.1)  # a 2:1 tablet
DISPLAY = (1000, 1000)


def corners(m: AreaMapping) -> list[tuple[float, float]]:
    return [m.to_px(0, x, y) for x, y in ((0, 0), (0.2, 0), (0.2, 0.1), (0, 0.1))]


def test_stretch_maps_corners_to_corners() -> None:
    m = AreaMapping(SIZE, DISPLAY, MappingConfig(aspect="stretch"))
    assert corners(m) == [(0, 0), (1000, 0), (1000, 1000), (0, 1000)]


def test_keep_aspect_letterboxes_and_centres() -> None:
    m = AreaMapping(SIZE, DISPLAY, MappingConfig(aspect="keep"))
    assert corners(m) == [(0, 250), (1000, 250), (1000, 750), (0, 750)]
    # equal pixels per metre in x and y: a circle stays a circle
    assert m.px_per_m[0] == pytest.approx(m.px_per_m[1])


@pytest.mark.parametrize(
    ("rotate", "top_left_goes_to"),
    [(0, (0, 0)), (90, (1000, 0)), (180, (1000, 1000)), (270, (0, 1000))],
)
def test_rotation_moves_the_surface_origin_clockwise(
    rotate: int, top_left_goes_to: tuple[int, int]
) -> None:
    m = AreaMapping(SIZE, DISPLAY, MappingConfig(aspect="stretch", rotate=rotate))
    x, y = m.to_px(0, 0.0, 0.0)
    assert (x, y) == pytest.approx(top_left_goes_to)


def test_rotated_keep_uses_the_rotated_aspect() -> None:
    m = AreaMapping(SIZE, DISPLAY, MappingConfig(aspect="keep", rotate=90))
    xs = [p[0] for p in corners(m)]
    ys = [p[1] for p in corners(m)]
    # turned upright the tablet is 1:2, so it fills the height and half the width
    assert (min(xs), max(xs), min(ys), max(ys)) == pytest.approx((250, 750, 0, 1000))


def test_surface_and_screen_areas() -> None:
    cfg = MappingConfig(
        aspect="stretch", surface_area=(0.1, 0.0, 0.1, 0.1), screen_area=(100, 100, 200, 200)
    )
    m = AreaMapping(SIZE, DISPLAY, cfg)
    assert m.to_px(0, 0.1, 0.0) == pytest.approx((100, 100))
    assert m.to_px(0, 0.2, 0.1) == pytest.approx((300, 300))
    assert m.to_px(0, 0.0, 0.0) == pytest.approx((-100, 100))  # outside: extrapolated


def test_relative_mapping_starts_each_contact_at_the_cursor() -> None:
    m = RelativeMapping(SIZE, DISPLAY, MappingConfig(mode="relative"))
    assert m.cursor == (500, 500)
    m.begin(1, 0.15, 0.05)
    assert m.to_px(1, 0.15, 0.05) == (500, 500)  # touching down does not jump
    p = m.to_px(1, 0.16, 0.05)  # 1 cm right = 1000/0.2 * 0.01 = 50 px
    assert p == pytest.approx((550, 500))
    m.end(1)
    m.begin(2, 0.01, 0.09)  # a new stroke elsewhere continues from the cursor
    assert m.to_px(2, 0.01, 0.09) == pytest.approx((550, 500))


def test_unknown_size_needs_configuration() -> None:
    with pytest.raises(MappingError, match="set size_mm"):
        make_mapping(None, DISPLAY, MappingConfig(), "mystery")


@pytest.mark.parametrize(
    "cfg",
    [
        MappingConfig(mode="warp"),
        MappingConfig(aspect="fill"),
        MappingConfig(rotate=45),
        MappingConfig(screen_area=(0, 0, 0, 10)),
        MappingConfig(gain=0.0),
    ],
)
def test_bad_settings_are_refused(cfg: MappingConfig) -> None:
    with pytest.raises(MappingError):
        make_mapping(SIZE, DISPLAY, cfg, "dev")

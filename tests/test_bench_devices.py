"""The coverage benchmark's judgement: the kernel's resolution model, the tolerance, the verdicts.

Verdicts are checked on real captures of shared/data/coverage, copied into a
folder of their own with the oracle as captured or with libinput's size
changed, so that each verdict is shown to follow from the figures.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from stiction.bench._kernel_res import kernel_extent_mm, kernel_resolution
from stiction.bench.devices import (
    coverage_rows,
    descriptor_file_rows,
    recording_rows,
    sizes_match,
)
from stiction.drivers.hid.descriptor import Field


def _axis(lmax: int, pmax: int, unit: int, exponent: int) -> Field:
    return Field(0, 0x10030, 0, 16, 1, 0, lmax, 0, pmax, unit, exponent, 2, 0x000D0004)


def test_kernel_rounds_resolution_to_whole_units_per_mm() -> None:
    """ThinkPad T14s touch screen: 1872 units over 17.4 cm (10.76 per mm) make resolution 11."""
    y = _axis(1872, 174, 0x11, -1)
    assert kernel_resolution(y) == 11
    assert kernel_extent_mm(y) == pytest.approx(170.18, abs=0.01)


def test_kernel_reads_inches_and_refuses_other_units() -> None:
    pen_y = _axis(6480, 1652, 0x13, -3)  # 1.652 in over 6480 units: 154.4/mm -> 154
    assert kernel_resolution(pen_y) == 154
    assert kernel_resolution(_axis(32767, 2048, 0x33, -3)) == 0  # in^3: no resolution
    assert kernel_resolution(_axis(100, 0, 0x11, -2)) == 0  # no physical extent
    assert kernel_extent_mm(_axis(100, 0, 0x11, -2)) is None


def test_tolerance_is_two_percent_or_one_and_a_half_mm_per_side() -> None:
    assert sizes_match((51.4, 100.0), (50.0, 100.0))  # 1.5 mm beats 2% on a small side
    assert not sizes_match((51.6, 100.0), (50.0, 100.0))
    assert sizes_match((306.0, 170.0), (300.0, 170.0))  # 2% beats 1.5 mm on a large one
    assert not sizes_match((306.5, 170.0), (300.0, 170.0))
    assert not sizes_match((300.0, 174.0), (300.0, 170.0))  # each side counts


def _copy(src: Path, dst: Path, slug: str, libinput_mm: list[float] | None = None) -> None:
    shutil.copy(src / f"{slug}.hid", dst / f"{slug}.hid")
    oracle = json.loads((src / f"{slug}.json").read_text())
    if libinput_mm is not None:
        for d in oracle["libinput"]:
            if d["size_mm"]:
                d["size_mm"] = libinput_mm
    (dst / f"{slug}.json").write_text(json.dumps(oracle))


@pytest.mark.parametrize(
    ("slug", "libinput_mm", "verdict", "reason"),
    [
        ("acer-spin-5-04f32560-1", None, "match", ""),
        ("lenovo-thinkpad-t14s-gen-1-04f32d4a-1", None, "libinput wrong", "rounds the resolution"),
        ("lenovo-thinkpad-t14s-gen-1-04f32d4a-1", [309.0, 150.0], "miss", "not what the kernel"),
        ("lenovo-chromebook-duet-5-27c60e51-1", None, "libinput wrong", "another unit"),
        ("huion-q620m-256c006d-2", None, "not a surface", "dial or wheel"),
        ("huion-kamvas-13-256c006d-2", None, "match", ""),  # its touch screen, pen left out
    ],
)
def test_verdicts_follow_from_the_figures(
    coverage_data: Path,
    tmp_path: Path,
    slug: str,
    libinput_mm: list[float] | None,
    verdict: str,
    reason: str,
) -> None:
    _copy(coverage_data, tmp_path, slug, libinput_mm)
    (row,) = coverage_rows(tmp_path)
    assert row.verdict == verdict
    assert reason in row.reason


def test_recordings_give_contacts_and_are_checked_against_a_known_size(
    hid_data: Path, coverage_data: Path, tmp_path: Path
) -> None:
    """XP-Pen Artist 10S: its capture in the coverage set is the oracle; a wrong oracle fails it."""
    recs = tmp_path / "hid"
    recs.mkdir()
    shutil.copy(hid_data / "xp-pen-artist-10s.hid", recs)
    (row,) = recording_rows(recs, coverage_data, None)
    assert row["ok"] and row["touching"] > 0 and row["size_matches"]
    assert row["known_mm"] == (217.0, 136.0)
    cov = tmp_path / "cov"
    cov.mkdir()
    _copy(coverage_data, cov, "xp-pen-artist-10s-5543004a-1", [254.0, 158.8])
    (row,) = recording_rows(recs, cov, None)
    assert not row["ok"] and row["size_matches"] is False


def test_a_refused_descriptor_is_a_named_miss_and_no_size_is_not_compared(
    coverage_data: Path, tmp_path: Path
) -> None:
    slug = "acer-spin-5-04f32560-1"
    _copy(coverage_data, tmp_path, slug)
    oracle = json.loads((tmp_path / f"{slug}.json").read_text())
    for d in oracle["libinput"]:
        d["size_mm"] = None
    (tmp_path / f"{slug}.json").write_text(json.dumps(oracle))
    broken = tmp_path / "broken-0000-1.hid"
    broken.write_text("N: broken\nI: 3 1234 5678\nR: 2 a1 01\n")  # a collection never closed
    (tmp_path / "broken-0000-1.json").write_text(json.dumps({"libinput": []}))
    by_slug = {r.slug: r for r in coverage_rows(tmp_path)}
    assert by_slug["broken-0000-1"].verdict == "miss"
    assert "never closed" in by_slug["broken-0000-1"].reason
    assert by_slug[slug].verdict == "no libinput size"


def test_descriptor_files_are_checked_against_an_otd_size_of_the_same_model(
    hid_data: Path, tmp_path: Path
) -> None:
    """XP-Pen Deco mini7: OTD's size matches; a model name that differs is no oracle."""
    folder = tmp_path / "hid"
    folder.mkdir()
    shutil.copy(hid_data / "xp-pen-deco-mini7.hid", folder)
    tablets = tmp_path / "tablets"
    tablets.mkdir()

    def otd(name: str, size: tuple[float, float]) -> None:
        ident = {"vid": "28bd", "pid": "0928"}
        t = {"name": name, "file": "x.json", "width_mm": size[0], "height_mm": size[1]}
        doc = {"tablets": [{**t, "identifiers": [ident]}]}
        (tablets / "otd-tablets.json").write_text(json.dumps(doc))

    otd("XP-Pen Deco mini7", (177.8, 111.1))
    (row,) = descriptor_file_rows(folder, None, tablets)
    assert row["ok"] is True and row["known_mm"] == (177.8, 111.1)
    otd("XP-Pen Deco mini7", (254.0, 152.4))
    (row,) = descriptor_file_rows(folder, None, tablets)
    assert row["ok"] is False
    otd("XP-Pen Deco 01", (254.0, 152.4))
    (row,) = descriptor_file_rows(folder, None, tablets)
    assert row["ok"] is None and row["known_mm"] is None


def test_a_folder_with_only_the_corpus_file_is_read_the_same(
    coverage_data: Path, tmp_path: Path
) -> None:
    """corpus.jsonl (descriptor_hex + the oracle) gives the rows the .json/.hid pairs give."""
    lines = (coverage_data / "corpus.jsonl").read_text().splitlines()[:5]
    (tmp_path / "corpus.jsonl").write_text("\n".join(lines) + "\n")
    pairs = tmp_path / "pairs"
    pairs.mkdir()
    for line in lines:
        _copy(coverage_data, pairs, json.loads(line)["slug"])
    from_corpus = {r.slug: (r.verdict, r.surface_mm) for r in coverage_rows(tmp_path)}
    from_pairs = {r.slug: (r.verdict, r.surface_mm) for r in coverage_rows(pairs)}
    assert from_corpus == from_pairs and len(from_corpus) == 5


def test_a_node_libinput_saw_only_as_a_touch_screen_is_checked_on_its_touch_contacts(
    coverage_data: Path, tmp_path: Path
) -> None:
    """Acer Spin 5: pen and touch screen on one node; libinput saw the touch screen only."""
    slug = "acer-spin-5-04f32560-1"
    _copy(coverage_data, tmp_path, slug)
    oracle = json.loads((tmp_path / f"{slug}.json").read_text())
    oracle["libinput"] = [d for d in oracle["libinput"] if d["kind"] == "touchscreen"]
    (tmp_path / f"{slug}.json").write_text(json.dumps(oracle))
    (row,) = coverage_rows(tmp_path)  # 301 x 170: the kernel's rounding of 295 x 166
    assert (row.kind, row.verdict, row.libinput_kind) == ("pen", "libinput wrong", "touchscreen")
    assert "touchscreen only" in row.reason and "rounding" in row.reason
    oracle["libinput"][0]["size_mm"] = [295.4, 166.2]  # as the touch report declares it
    (tmp_path / f"{slug}.json").write_text(json.dumps(oracle))
    (row,) = coverage_rows(tmp_path)
    assert (row.verdict, row.libinput_kind) == ("match", "touchscreen")
    oracle["libinput"][0]["size_mm"] = [250, 140]  # neither reading
    (tmp_path / f"{slug}.json").write_text(json.dumps(oracle))
    (row,) = coverage_rows(tmp_path)
    assert row.verdict == "miss"


def test_a_node_without_contacts_or_libinput_size_is_truthfully_no_surface(
    hid_data: Path, tmp_path: Path
) -> None:
    shutil.copy(hid_data / "microsoft-keyboard-045e-0773.hid", tmp_path / "kbd-1.hid")
    (tmp_path / "kbd-1.json").write_text(
        json.dumps({"libinput": [{"kind": None, "size_mm": None}], "kernel_driver": "hid-generic"})
    )
    (row,) = coverage_rows(tmp_path)
    assert (row.kind, row.verdict) == (None, "not a surface")

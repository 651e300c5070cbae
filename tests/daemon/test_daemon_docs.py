"""The TOML shown in docs/daemon.md and docs/scenes.md is valid as written."""

from __future__ import annotations

import re
from pathlib import Path

from stiction.daemon.config import load_options
from stiction.scene.load import parse_scene

DOCS = Path(__file__).resolve().parents[2] / "docs"


def _toml_blocks(name: str) -> list[str]:
    return re.findall(r"```toml\n(.*?)```", (DOCS / name).read_text(), flags=re.S)


def test_the_config_example_in_daemon_md_loads(tmp_path: Path) -> None:
    (block,) = [b for b in _toml_blocks("daemon.md") if "[daemon]" in b]
    cfg = tmp_path / "stictiond.toml"
    cfg.write_text(block)
    opts = load_options(cfg)
    assert opts.rate == 100.0 and opts.hwm == 1000
    assert opts.scene == tmp_path / "scenes" / "lab.toml"
    assert opts.devices[0].spec == "/dev/hidraw3"
    assert (opts.devices[1].spec, opts.devices[1].backend) == ("256c:006d", "evdev")
    assert opts.curve.secret_key == tmp_path / "keys" / "stictiond.key_secret"
    assert opts.params["k"] == 0.1


def test_the_full_scene_example_in_scenes_md_parses() -> None:
    (block,) = [b for b in _toml_blocks("scenes.md") if "[materials.rubber]" in b]
    scene = parse_scene(block, "doc.toml")
    assert [r.shape.__class__.__name__ for r in scene.regions] == ["Rect", "Circle", "Polygon"]
    assert scene.material_at(960, 980) is None  # the pass-through hole


def test_the_mapping_examples_in_mapping_md_load(tmp_path: Path) -> None:
    for i, block in enumerate(_toml_blocks("mapping.md")):
        cfg = tmp_path / f"m{i}.toml"
        cfg.write_text(block)
        assert load_options(cfg).devices

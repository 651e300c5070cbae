"""The shared TOML checker: every failure names file, line and key, as the caller's error."""

from __future__ import annotations

from pathlib import Path

import pytest

from stiction.daemon.config import ConfigError, load_options
from stiction.errors import SceneError, StictionError
from stiction.scene.load import parse_scene
from stiction.tomlcheck import TomlReader

TEXT = '[top]\nname = "x"\n\n[[items]]\nsize = 3\n\n[[items]]\nsize = "big"\n'


class Mine(StictionError):
    pass


def test_failures_name_the_line_of_the_key_and_raise_the_callers_class() -> None:
    r = TomlReader("f.toml", TEXT, Mine)
    with pytest.raises(Mine, match=r"^f\.toml:8: items\[1\]\.size: too big$"):
        r.fail(("items", 1, "size"), "too big")
    with pytest.raises(Mine, match=r"^f\.toml:2: top\.name: x$"):
        r.fail(("top", "name"), "x")
    with pytest.raises(Mine, match=r"^f\.toml: whole file$"):
        r.fail((), "whole file")


def test_a_key_not_in_the_text_is_placed_at_its_table() -> None:
    r = TomlReader("f.toml", TEXT, Mine)
    with pytest.raises(Mine, match=r"^f\.toml:4: items\[0\]\.colour: missing$"):
        r.fail(("items", 0, "colour"), "missing")


def test_unknown_keys_and_wrong_kinds() -> None:
    r = TomlReader("f.toml", TEXT, Mine)
    with pytest.raises(Mine, match=r"f\.toml:2: top\.name: unknown key; expected one of a, b"):
        r.table(r.data["top"], ("top",), {"a", "b"})
    with pytest.raises(Mine, match=r"f\.toml:7: items\[1\]: must be a table, got string 'big'"):
        r.table("big", ("items", 1), set())
    with pytest.raises(Mine, match=r"must be a non-empty string, got number 3"):
        r.string(3, ("items", 0, "size"))
    with pytest.raises(Mine, match=r"must be true or false"):
        r.boolean(1, ("items", 0, "size"))


def test_bad_toml_is_the_callers_error_too() -> None:
    with pytest.raises(Mine, match=r"^f\.toml: not valid TOML: "):
        TomlReader("f.toml", "a = [", Mine)


def test_scenes_and_the_config_both_use_it(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match=r"^s\.toml:2: scene\.nme: unknown key"):
        parse_scene('[scene]\nnme = "x"\n', "s.toml")
    cfg = tmp_path / "c.toml"
    cfg.write_text("[daemon]\nhotplug = 1\n")
    with pytest.raises(ConfigError, match=r"c\.toml:2: daemon\.hotplug: must be true or false"):
        load_options(cfg)


def test_the_device_catalogue_uses_it_and_names_the_entrys_line() -> None:
    from stiction.drivers.catalogue.load import parse_toml
    from stiction.errors import DeviceError

    first = '[[device]]\nid = "1:1"\nsource = "x"\n\n'
    text = first + '[[device]]\nid = "1:2"\nsource = "x"\nmax_x = 0\n'
    with pytest.raises(DeviceError, match=r"^o\.toml:5: device\[1\] \(0001:0002\): 'max_x' must"):
        parse_toml(text, "o.toml", "user")
    with pytest.raises(DeviceError, match=r"^o\.toml: not valid TOML"):
        parse_toml("[[device]", "o.toml", "user")


def test_a_typo_is_answered_with_the_key_it_was_probably_meant_to_be(tmp_path: Path) -> None:
    with pytest.raises(
        SceneError, match=r"s\.toml:4: materials\.a\.colour: .*did you mean 'color'\?"
    ):
        parse_scene('[materials.a]\nmu_s = 0.5\nmu_k = 0.1\ncolour = "#fff"\n', "s.toml")
    cfg = tmp_path / "c.toml"
    cfg.write_text("[deamon]\nrate = 100\n")
    with pytest.raises(
        ConfigError, match=r"c\.toml:1: deamon: unknown key; did you mean 'daemon'\?"
    ):
        load_options(cfg)
    cfg.write_text("[daemon]\nrat = 100\n")
    with pytest.raises(ConfigError, match=r"c\.toml:2: daemon\.rat: .*did you mean 'rate'\?"):
        load_options(cfg)
    r = TomlReader("f.toml", TEXT, Mine)  # nothing close: no guess
    with pytest.raises(Mine, match=r"unknown key; expected one of a, b$"):
        r.table(r.data["top"], ("top",), {"a", "b"})


QUOTED = (
    '[materials."wo.od"]\nmu_z = 1\n'
    '[materials.wood]\n"mu\\ns" = 2\n'
    "[materials.'a]b']\n\"x\\ty\" = 3\n"
)


@pytest.mark.parametrize(
    ("path", "expected"),
    [
        # a dot inside a quoted key is part of the name, not a separator
        (("materials", "wo.od", "mu_z"), 'f.toml:2: materials."wo.od".mu_z: bad'),
        # a newline in a key is shown as the file writes it: the message stays one line
        (("materials", "wood", "mu\ns"), 'f.toml:4: materials.wood."mu\\ns": bad'),
        (("materials", "a]b", "x\ty"), 'f.toml:6: materials."a]b"."x\\ty": bad'),
    ],
)
def test_quoted_keys_are_found_on_their_line_and_quoted_in_one_line(
    path: tuple[str, ...], expected: str
) -> None:
    r = TomlReader("f.toml", QUOTED, Mine)
    with pytest.raises(Mine) as info:
        r.fail(path, "bad")
    assert str(info.value) == expected


def test_a_key_thousands_of_characters_long_is_shortened_in_the_message() -> None:
    key = "k" * 5000
    r = TomlReader("f.toml", f"{key} = 1\n", Mine)
    with pytest.raises(Mine) as info:
        r.table(r.data, (), {"rate"})
    assert len(str(info.value)) < 400 and "(5000 characters)" in str(info.value)


def test_a_scene_key_with_a_newline_is_one_line_naming_its_line() -> None:
    with pytest.raises(SceneError) as info:
        parse_scene('[materials.wood]\n"mu\\ns" = 1\n', "s.toml")
    message = str(info.value)
    assert "\n" not in message and ':2: materials.wood."mu\\ns": unknown key' in message

"""udev/70-stiction.rules: generated from the device table, syntactically sane, uaccess only."""

from __future__ import annotations

import fnmatch
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from stiction.cli import main
from stiction.drivers.hid.devices import builtin_table, parse_table
from stiction.setup.udev_rules import RULES_NAME, USB_INITS, builtin_rules, render, shipped_ids

REPO = Path(__file__).resolve().parents[2]
COMMITTED = REPO / "udev" / RULES_NAME

# udev(7): match keys take == or !=, assignment keys =, += , -= or :=
MATCH_KEYS = {"ACTION", "KERNEL", "SUBSYSTEM", "KERNELS", "SUBSYSTEMS", "ENV", "ATTR", "ATTRS"}
ASSIGN_KEYS = {"TAG", "GOTO", "LABEL"}
FORBIDDEN = {"MODE", "GROUP", "OWNER", "RUN", "PROGRAM", "IMPORT"}
PAIR = re.compile(r'^([A-Z]+)(?:\{([A-Za-z0-9_]+)\})?(==|!=|\+=|-=|:=|=)"([^"]*)"$')


def _rules(text: str) -> list[list[tuple[str, str | None, str, str]]]:
    """Every rule line as (key, attribute, operator, value) tuples; asserts the syntax."""
    rules = []
    for n, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        assert not line.endswith("\\"), f"line {n}: continuation lines are not used"
        pairs = []
        for part in line.split(", "):
            m = PAIR.match(part.strip())
            assert m, f'line {n}: {part!r} is not KEY op "value"'
            key, attr, op, value = m.groups()
            assert key not in FORBIDDEN, f"line {n}: {key} is not allowed here"
            if key in MATCH_KEYS:
                assert op in ("==", "!="), f"line {n}: {key} is a match key, got {op}"
            else:
                assert key in ASSIGN_KEYS, f"line {n}: unknown key {key}"
                assert op in ("=", "+=", "-=", ":="), f"line {n}: {key} is assigned, got {op}"
            assert (attr is not None) == (key in ("ENV", "ATTR", "ATTRS")), f"line {n}: {part}"
            pairs.append((key, attr, op, value))
        rules.append(pairs)
    return rules


def test_committed_rules_are_what_the_table_generates() -> None:
    assert COMMITTED.read_text(encoding="utf-8") == builtin_rules(), (
        "udev/70-stiction.rules is stale: regenerate it with "
        "`stiction udev print > udev/70-stiction.rules` after changing devices.toml"
    )


def test_a_device_added_to_the_table_gets_a_rule() -> None:
    extra = parse_table('[[device]]\nid = "abcd:12ef"\nname = "New pad"\nsource = "test"\n')
    before = render(builtin_table().values())
    after = render([*builtin_table().values(), *extra.values()])
    assert after != before
    assert 'KERNELS=="*:ABCD:12EF.*", TAG+="uaccess"' in after
    assert "ABCD:12EF" not in before


def test_rules_parse_and_grant_only_uaccess() -> None:
    text = builtin_rules()
    assert "MODE" not in text and "0666" not in text
    rules = _rules(text)
    labels = {v for r in rules for k, _, _, v in r if k == "LABEL"}
    for rule in rules:
        keys = [k for k, _, _, _ in rule]
        if "LABEL" in keys:
            continue
        if "GOTO" in keys:
            assert {v for k, _, _, v in rule if k == "GOTO"} <= labels
            continue
        assert ("TAG", None, "+=", "uaccess") in rule, rule
        assert any(k in ("SUBSYSTEM", "SUBSYSTEMS") for k in keys), f"unscoped rule: {rule}"


def test_every_table_device_is_matched_on_any_bus() -> None:
    """The KERNELS glob matches the hid device's kernel name for USB, Bluetooth and I2C."""
    rules = _rules(builtin_rules())
    hid_globs = [v for r in rules for k, _, _, v in r if k == "KERNELS"]
    ids = {(r.vid, r.pid) for r in shipped_ids()}
    assert set(builtin_table()) <= ids and len(ids) > 200  # hand-written and generated
    for vid, pid in ids:
        for bus in ("0003", "0005", "0018"):
            name = f"{bus}:{vid:04X}:{pid:04X}.000A"
            assert any(fnmatch.fnmatchcase(name, g) for g in hid_globs), name
        other = f"0003:{vid:04X}:{(pid + 1) & 0xFFFF:04X}.0001"
        if (vid, (pid + 1) & 0xFFFF) not in ids:
            assert not any(fnmatch.fnmatchcase(other, g) for g in hid_globs), other


def test_usb_nodes_only_for_usb_vendor_init() -> None:
    rules = _rules(builtin_rules())
    usb = {
        (
            dict((k + (a or ""), v) for k, a, _, v in r)["ATTRidVendor"],
            dict((k + (a or ""), v) for k, a, _, v in r)["ATTRidProduct"],
        )
        for r in rules
        if ("SUBSYSTEM", None, "==", "usb") in r
    }
    wanted = {(f"{r.vid:04x}", f"{r.pid:04x}") for r in shipped_ids() if r.init in USB_INITS}
    assert usb == wanted and wanted
    huion = {(f"{e.vid:04x}", f"{e.pid:04x}") for e in builtin_table().values() if e.init}
    assert {("256c", "006d"), ("256c", "006e")} <= huion <= usb


def test_input_devices_by_udev_class() -> None:
    text = builtin_rules()
    for prop in ("ID_INPUT_TABLET", "ID_INPUT_TOUCHPAD", "ID_INPUT_TOUCHSCREEN"):
        assert f'SUBSYSTEM=="input", KERNEL=="event*", ENV{{{prop}}}=="1", TAG+="uaccess"' in text


def test_file_sorts_before_seat_late() -> None:
    """uaccess ACLs are applied in 73-seat-late.rules: the tag must be set before it."""
    assert sorted([RULES_NAME, "73-seat-late.rules"])[0] == RULES_NAME


def test_print_command(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["udev", "print"]) == 0
    assert capsys.readouterr().out == builtin_rules()


def test_install_to_path_then_unchanged(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    target = tmp_path / "rules.d" / RULES_NAME
    assert main(["udev", "install", "--path", str(target), "--dry-run"]) == 0
    assert not target.exists()
    assert "would write" in capsys.readouterr().out
    assert main(["udev", "install", "--path", str(target)]) == 0
    out = capsys.readouterr().out
    assert target.read_text() == builtin_rules()
    assert oct(target.stat().st_mode & 0o777) == "0o644"
    assert "udevadm control --reload && sudo udevadm trigger" in out
    assert main(["udev", "install", "--path", str(target)]) == 0
    assert "already up to date" in capsys.readouterr().out


def test_install_unwritable_is_one_line(tmp_path: Path) -> None:
    target = tmp_path / "file" / RULES_NAME
    (tmp_path / "file").write_text("not a directory")
    proc = subprocess.run(
        [sys.executable, "-m", "stiction", "udev", "install", "--path", str(target)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "cannot write" in proc.stderr
    assert "Traceback" not in proc.stderr


@pytest.mark.parametrize("kind", ["binary", "fifo", "directory"])
def test_install_over_something_that_is_not_a_rules_file_is_one_line(
    tmp_path: Path, kind: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """A binary file was a UnicodeDecodeError traceback; a FIFO hung the install."""
    target = tmp_path / RULES_NAME
    if kind == "binary":
        target.write_bytes(b"\xbc\xff\x00")
    elif kind == "fifo":
        os.mkfifo(target)
    else:
        target.mkdir()
    assert main(["udev", "install", "--path", str(target)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert ("--force" if kind == "binary" else "not a regular file") in err
    if kind == "binary":
        assert target.read_bytes() == b"\xbc\xff\x00"  # not replaced without --force


@pytest.mark.skipif(os.geteuid() != 0, reason="the default path is written only as root")
def test_as_root_dry_run_writes_nothing_to_etc(capsys: pytest.CaptureFixture[str]) -> None:
    before = Path("/etc/udev/rules.d", RULES_NAME).exists()
    assert main(["udev", "install", "--dry-run"]) == 0
    assert f"/etc/udev/rules.d/{RULES_NAME}" in capsys.readouterr().out
    assert Path("/etc/udev/rules.d", RULES_NAME).exists() == before


def test_not_root_prints_what_it_would_do_and_fails(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A normal user gets the rules, the reload command and how to run it as root."""
    monkeypatch.setattr(os, "geteuid", lambda: 1000)
    before = Path("/etc/udev/rules.d", RULES_NAME).exists()
    assert main(["udev", "install"]) == 2
    captured = capsys.readouterr()
    assert builtin_rules() in captured.out
    assert "udev install`" in captured.err and "sudo" in captured.err
    assert "nothing written" in captured.err
    assert Path("/etc/udev/rules.d", RULES_NAME).exists() == before


def test_install_page_counts_the_ids_the_rules_name() -> None:
    """docs/install.md says how many tablet ids the rules cover; it must stay true."""
    page = (REPO / "docs" / "install.md").read_text(encoding="utf-8")
    found = re.search(r"the hidraw nodes of the (\d+) tablet ids", page)
    assert found, "docs/install.md no longer says how many ids the rules cover"
    assert int(found.group(1)) == len(shipped_ids())

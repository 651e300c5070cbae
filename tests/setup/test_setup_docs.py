"""docs/install.md names only commands and flags that exist.

Every `stiction ...` and `stictiond ...` command in the guide's command
blocks is parsed by the real argument parsers, so a renamed flag or a removed
sub-command breaks this test instead of a reader's first evening.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from stiction.cli import build_parser as stiction_parser
from stiction.daemon.main import build_parser as stictiond_parser

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "install.md"


def _snippets(text: str) -> list[str]:
    """Indented command lines and `inline code` spans of the guide."""
    out = re.findall(r"`([^`\n]+)`", text)
    for line in text.splitlines():
        if line.startswith("    ") and not line.lstrip().startswith("#"):
            out.append(line.split(" #", 1)[0])
    return out


def _commands() -> list[list[str]]:
    """Each stiction/stictiond invocation in the guide."""
    out = []
    for snippet in _snippets(GUIDE.read_text(encoding="utf-8")):
        text = snippet.replace('"$(command -v stiction)"', "stiction")
        for part in re.split(r"&&|\|", text):
            try:
                words = shlex.split(part)
            except ValueError:  # prose in backticks, not a command
                continue
            if words[:1] == ["sudo"]:
                words = words[1:]
            if "..." in words or words == ["stiction"]:  # prose about a command
                continue
            if words[:1] in (["stiction"], ["stictiond"]) and words not in out:
                out.append(words)
    return out


def test_the_guide_has_commands() -> None:
    names = {tuple(c[:2]) for c in _commands()}
    for wanted in (("stiction", "udev"), ("stiction", "doctor"), ("stiction", "service")):
        assert wanted in names
    assert any(c[0] == "stictiond" for c in _commands())


@pytest.mark.parametrize("argv", _commands(), ids=" ".join)
def test_command_parses(argv: list[str]) -> None:
    parser = stiction_parser() if argv[0] == "stiction" else stictiond_parser()
    try:
        parser.parse_args(argv[1:])
    except SystemExit as exc:  # argparse rejects unknown commands and flags this way
        pytest.fail(f"docs/install.md: `{' '.join(argv)}` does not parse (exit {exc.code})")

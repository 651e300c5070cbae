"""The code blocks of the docs and their doc-test markers (convention: docs/design/README.md).

Pure parsing, no side effects: the test imports it to classify blocks, and
doc_runner.py (which runs inside a private network namespace) imports it to
know what to run.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PAGES = ("README.md", "docs/*.md", "docs/design/*.md")

# A fenced block whose language says it is not a shell session is classified by
# that language (toml and json are parsed, the rest are source examples).
LANG_KINDS = {"toml": "toml", "json": "json", "python": "source", "js": "source"}
SHELL_LANGS = {"", "sh", "bash", "shell", "console"}
KINDS = {"run", "skip", "synopsis", "output", "text", "toml"}
DIRECTIVES = {"skip", "xfail", "background"}

MARKER = re.compile(r"<!--\s*doc-test:(.*?)-->", re.S)


class MarkerError(ValueError):
    """A doc-test marker that does not follow the convention."""


@dataclass(frozen=True)
class Directive:
    verb: str  # skip | xfail | background
    prefix: str  # applies to command lines starting with this
    reason: str


@dataclass
class Block:
    page: str  # path relative to the repo
    line: int  # 1-based line of the block's first line
    text: str  # the block's content, indentation removed
    lang: str | None  # fenced: the language tag; indented: None
    kind: str | None = None  # None: unclassified
    arg: str = ""  # kind's argument: skip/text reason, output file
    directives: list[Directive] = field(default_factory=list)
    cont: bool = False  # runs in the session of the previous run block

    @property
    def id(self) -> str:
        return f"{self.page}:{self.line}"


def _parse_marker(body: str, where: str) -> tuple[str, str, list[Directive], bool]:
    lines = [ln.strip() for ln in body.strip().splitlines() if ln.strip()]
    if not lines:
        raise MarkerError(f"{where}: empty doc-test marker")
    head = lines[0]
    m = re.match(r"(\w[\w-]*)\s*:?\s*(.*)$", head)
    if not m or m.group(1) not in KINDS:
        raise MarkerError(f"{where}: doc-test kind must be one of {sorted(KINDS)}, got {head!r}")
    kind, arg = m.group(1), m.group(2).strip()
    cont = False
    if kind == "run" and arg.startswith("continue"):
        cont, arg = True, arg[len("continue") :].strip()
    if kind in ("skip", "text") and not arg:
        raise MarkerError(f"{where}: doc-test {kind} needs a reason")
    if kind == "output" and not arg:
        raise MarkerError(f"{where}: doc-test output needs the file it is copied from")
    directives = []
    for ln in lines[1:]:
        d = re.match(r"(\w+)\s+`([^`]+)`\s*(?::\s*(.*))?$", ln)
        if not d or d.group(1) not in DIRECTIVES:
            raise MarkerError(
                f"{where}: directive must be `VERB `PREFIX`: reason` with VERB in "
                f"{sorted(DIRECTIVES)}, got {ln!r}"
            )
        verb, prefix, reason = d.group(1), d.group(2), (d.group(3) or "").strip()
        if verb != "background" and not reason:
            raise MarkerError(f"{where}: {verb} `{prefix}` needs a reason")
        if kind != "run":
            raise MarkerError(f"{where}: directives belong to run blocks only")
        directives.append(Directive(verb, prefix, reason))
    return kind, arg, directives, cont


def parse_page(path: Path) -> list[Block]:
    """Every code block of a page (fenced, or indented by 4 spaces after a blank line)."""
    page = str(path.relative_to(REPO)) if path.is_relative_to(REPO) else path.name
    lines = path.read_text(encoding="utf-8").split("\n")
    blocks: list[Block] = []
    pending: tuple[str, int] | None = None  # marker body, line
    i = 0
    while i < len(lines):
        ln = lines[i]
        if ln.startswith("<!--") and "doc-test:" in ln:
            j = i
            while "-->" not in lines[j]:
                j += 1
            body = MARKER.search("\n".join(lines[i : j + 1]))
            assert body is not None
            pending = (body.group(1), i + 1)
            i = j + 1
            continue
        fence = re.match(r"^(```+)\s*(\S*)", ln)
        indented = ln.startswith("    ") and i > 0 and lines[i - 1].strip() == ""
        if fence or indented:
            if fence:
                j = i + 1
                while j < len(lines) and not lines[j].startswith(fence.group(1)):
                    j += 1
                text, lang, first, end = "\n".join(lines[i + 1 : j]), fence.group(2), i + 1, j + 1
            else:
                j = i
                while j < len(lines) and (
                    lines[j].startswith("    ")
                    or (
                        lines[j].strip() == ""
                        and j + 1 < len(lines)
                        and lines[j + 1].startswith("    ")
                    )
                ):
                    j += 1
                text = "\n".join(x[4:] for x in lines[i:j])
                lang, first, end = None, i + 1, j
            block = Block(page, first, text, lang)
            if pending is not None:
                where = f"{page}:{pending[1]}"
                block.kind, block.arg, block.directives, block.cont = _parse_marker(
                    pending[0], where
                )
            elif lang is not None and lang not in SHELL_LANGS:
                block.kind = LANG_KINDS.get(lang, "source")
                block.arg = f"a {lang} example"
            blocks.append(block)
            pending = None
            i = end
            continue
        if ln.strip() and pending is not None and not ln.lstrip().startswith("<!--"):
            raise MarkerError(f"{page}:{pending[1]}: a doc-test marker must precede a block")
        i += 1
    return blocks


def pages() -> list[Path]:
    out: list[Path] = []
    for pattern in PAGES:
        out.extend(sorted(REPO.glob(pattern)))
    return out


def all_blocks() -> list[Block]:
    return [b for p in pages() for b in parse_page(p)]


def commands(block: Block) -> list[tuple[str, list[str]]]:
    """(command, expected output lines) of a run block, continuation lines joined.

    In a console block (lines starting with "$ "), the lines after a command up
    to the next "$ " are the output it must print; otherwise no output is
    checked. Comment-only lines are dropped.
    """
    raw = block.text.split("\n")
    console = any(x.startswith("$ ") for x in raw)
    out: list[tuple[str, list[str]]] = []
    i = 0
    while i < len(raw):
        ln = raw[i]
        if console and not ln.startswith("$ "):
            if out and ln.strip():
                out[-1][1].append(ln.rstrip())
            i += 1
            continue
        cmd = ln[2:] if console else ln
        while cmd.rstrip().endswith("\\") and i + 1 < len(raw):
            i += 1
            cmd = cmd.rstrip()[:-1] + " " + raw[i].strip()
        i += 1
        if cmd.strip() and not cmd.lstrip().startswith("#"):
            out.append((cmd.strip(), []))
    return out


def strip_comment(cmd: str) -> str:
    """The command without a trailing `# comment` (for matching directives)."""
    return re.sub(r"\s+#\s.*$", "", cmd).strip()


def directive_for(block: Block, cmd: str) -> Directive | None:
    """The directive with the longest prefix the command starts with."""
    bare = strip_comment(cmd)
    hits = [d for d in block.directives if bare.startswith(d.prefix)]
    return max(hits, key=lambda d: len(d.prefix), default=None)

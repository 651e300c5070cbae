"""The documentation is executable: every code block of README.md, docs/ and docs/design/ is
classified, and the runnable ones run as written.

The convention (markers, directives, what the runner provides) is in
docs/design/README.md. The `run` blocks all run in one session
(doc_runner.py) inside a private network namespace (`unshare -rn`), so the
commands use the documented default endpoints as they are written, and the
daemons they start meet no other daemon on this machine; the session takes
some tens of seconds, the rest of this file milliseconds.
"""

from __future__ import annotations

import argparse
import json
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path
from typing import Any

import pytest
from doc_blocks import REPO, Block, Directive, MarkerError, all_blocks, pages, parse_page

from stiction.cli import build_parser as stiction_parser
from stiction.daemon.main import build_parser as stictiond_parser

RUNNER = Path(__file__).resolve().parent / "doc_runner.py"
DOC_PORTS = (5556, 5557, 8765)  # the documented defaults the commands use as written


def _port_free(port: int) -> bool:
    import socket

    with socket.socket() as s:
        try:
            s.bind(("0.0.0.0", port))
        except OSError:
            return False
    return True


BLOCKS = all_blocks()


def _ids(kind: str) -> list[Block]:
    return [b for b in BLOCKS if b.kind == kind]


def test_every_block_is_classified() -> None:
    """A new command block without a marker fails here, so no page silently escapes."""
    unmarked = [f"{b.id}: {b.text.splitlines()[0][:60]!r}" for b in BLOCKS if b.kind is None]
    assert not unmarked, (
        "code blocks without a doc-test marker (see docs/design/README.md):\n" + "\n".join(unmarked)
    )


def test_the_pages_are_found() -> None:
    names = {str(p.relative_to(REPO)) for p in pages()}
    assert {"README.md", "docs/install.md", "docs/design/README.md"} <= names
    assert len(_ids("run")) >= 10


def test_markers_are_checked(tmp_path: Path) -> None:
    """The parser refuses an unknown kind, a skip without a reason, a stray marker."""
    page = tmp_path / "probe.md"
    for bad in (
        "<!-- doc-test: runn -->\n\n    stiction devices\n",
        "<!-- doc-test: skip -->\n\n    stiction devices\n",
        "<!-- doc-test: run\n     frobnicate `stiction`: why -->\n\n    stiction devices\n",
        "<!-- doc-test: run -->\n\nsome prose, no block\n",
    ):
        page.write_text(bad)
        with pytest.raises(MarkerError):
            parse_page(page)


@pytest.mark.parametrize("block", _ids("toml"), ids=lambda b: b.id)
def test_toml_blocks_parse(block: Block) -> None:
    tomllib.loads(block.text)


@pytest.mark.parametrize("block", _ids("json"), ids=lambda b: b.id)
def test_json_blocks_parse(block: Block) -> None:
    json.loads(block.text)


@pytest.mark.parametrize("block", _ids("output"), ids=lambda b: b.id)
def test_output_blocks_are_copied_from_their_file(block: Block) -> None:
    """Figures shown on a page come from the committed results, never typed by hand.

    Compared with runs of white space made one (a page may re-wrap a long line).
    """
    source = REPO / block.arg
    assert source.is_file(), f"{block.id}: {block.arg} does not exist"
    have = " ".join(source.read_text().split())
    shown = " ".join(block.text.split())
    assert shown and shown in have, f"{block.id}: the block is not an excerpt of {block.arg}"


def _help(argv: list[str]) -> str:
    """--help of the deepest sub-command the words name (`stiction hid decode` ...)."""
    parser = stiction_parser() if argv[0] == "stiction" else stictiond_parser()
    for word in argv[1:]:
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not subs or word not in subs[0].choices:
            break
        parser = subs[0].choices[word]
    return parser.format_help()


@pytest.mark.parametrize("block", _ids("synopsis"), ids=lambda b: b.id)
def test_synopsis_flags_exist(block: Block) -> None:
    """Every --flag a usage line shows is one the command's --help knows."""
    usages: list[str] = []
    for line in block.text.splitlines():  # a usage may wrap onto indented lines
        if re.match(r"\s*(\S*/)?stictiond?\b", line) or not usages:
            usages.append(line.strip())
        else:
            usages[-1] += " " + line.strip()
    for cmd in usages:
        words = shlex.split(
            cmd.replace("[", " ").replace("]", " ").replace("|", " "), comments=True
        )
        if words and words[0].endswith("/stiction"):
            words[0] = "stiction"
        assert words[0] in ("stiction", "stictiond"), f"{block.id}: {cmd!r}"
        text = _help(words)
        for flag in (w for w in words if w.startswith("--")):
            flag = flag.split("=", 1)[0]
            assert re.search(rf"{re.escape(flag)}\b", text), (
                f"{block.id}: {flag} of `{cmd}` is not in `{' '.join(words[:2])} --help`"
            )


@pytest.fixture(scope="module")
def session(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[dict[str, Any]]]:
    """One run of every `run` block, in order, in one private network namespace.

    Where namespaces are not allowed (a locked-down container), the commands
    run on this machine's loopback instead, provided the documented ports are
    free: a CI runner has nothing else on them.
    """
    scratch = tmp_path_factory.mktemp("docs")
    out = scratch.parent / f"{scratch.name}-results.json"
    argv = [sys.executable, str(RUNNER), str(scratch), str(out)]
    probe = subprocess.run(["unshare", "-rn", "true"], capture_output=True, text=True)
    if shutil.which("unshare") is not None and probe.returncode == 0:
        argv = ["unshare", "-rn", *argv]
    else:
        busy = [port for port in DOC_PORTS if not _port_free(port)]
        if busy:
            pytest.skip(
                f"no private network namespace (unshare -rn: {probe.stderr.strip()}) and the "
                f"documented ports {busy} are in use here"
            )
        argv.append("--host-network")
    run = subprocess.run(argv, capture_output=True, text=True, timeout=900)
    assert run.returncode == 0, run.stderr[-4000:]
    result: dict[str, list[dict[str, Any]]] = json.loads(out.read_text())
    return result


@pytest.mark.slow
@pytest.mark.parametrize("block", _ids("run"), ids=lambda b: b.id)
def test_run_block(block: Block, session: dict[str, list[dict[str, Any]]]) -> None:
    results = session[block.id]
    failed = [r for r in results if r["status"] in ("fail", "xpassed")]
    assert not failed, "\n\n".join(
        f"{block.id}: `{r['cmd']}` "
        + ("passes now: remove its xfail directive" if r["status"] == "xpassed" else "failed")
        + f"\n{r['detail']}"
        for r in failed
    )
    xfailed = [r for r in results if r["status"] == "xfailed"]
    if xfailed:
        pytest.xfail("; ".join(f"`{r['cmd']}`: {r['detail'].splitlines()[0]}" for r in xfailed))
    if all(r["status"] == "skip" for r in results):
        pytest.skip("; ".join(r["detail"] for r in results))


def test_the_runner_fails_a_failing_command_and_changed_output(tmp_path: Path) -> None:
    """The checks behind test_run_block can fail: exit status, output, xfail that passes."""
    import doc_runner

    block = Block("probe.md", 1, "$ echo one\ntwo\n$ false\n$ true\n", None, kind="run")
    block.directives = [Directive("xfail", "true", "a known bug")]
    got = [r["status"] for r in doc_runner.run_block(block, tmp_path / "s", {})]
    assert got == ["fail", "fail", "xpassed"]
    block = Block("probe.md", 1, "$ printf 'a\\nb\\nc\\n'\na\n...\nc\n", None, kind="run")
    assert [r["status"] for r in doc_runner.run_block(block, tmp_path / "s", {})] == ["ok"]

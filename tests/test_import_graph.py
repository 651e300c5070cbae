"""The package's import graph: downward only, no cycles, nothing imports a command.

Every module under src/stiction is parsed (ast, so imports inside functions
and under TYPE_CHECKING count too: a lazy import is still a dependency).
A module belongs to a unit: its top-level sub-package (``daemon``,
``scene``, ...) or top-level module (``protocol``), except that command-line
modules -- `stiction.cli`'s COMMAND_MODULES, any ``cli.py`` or ``*_cli.py``,
``__main__`` and the [project.scripts] entry points -- form the unit ``cli``
on top, whichever folder they sit in. The rules, from
docs/design/architecture.md:

- a unit imports only units of a lower layer in LAYERS (no upward and no
  sideways edge: units of one layer are independent of each other);
- hence no cycle between units; and within each package, no cycle between
  its modules (a package's __init__ and its own submodules excepted);
- no module outside the ``cli`` unit imports a command-line module.

An edge that must stay is declared in EXCEPTIONS with the reason.
"""

from __future__ import annotations

import ast
import tomllib
from collections import defaultdict
from collections.abc import Iterator
from functools import cache
from pathlib import Path

import pytest

from stiction.cli import COMMAND_MODULES

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"

LAYERS: tuple[frozenset[str], ...] = (
    frozenset({"errors", "lazy", "xdg"}),
    frozenset({"userfiles"}),
    frozenset({"argtypes", "protocol", "keyfiles", "tomlcheck", "__init__"}),
    frozenset({"sim", "drivers"}),
    frozenset({"scene"}),
    frozenset({"daemon", "clients"}),
    frozenset({"setup"}),
    frozenset({"bench", "experiment"}),
    frozenset({"cli"}),
)
"""Lowest first. userfiles (reading a path a user named) sits below the other
helpers because key files, like scenes and recordings, are read through it.
The simulator knows nothing of devices and the drivers
nothing of the simulator; a scene maps device samples (drivers' PenSample)
through the simulator; the daemon runs scenes; tools sit on the daemon and
clients; commands on everything."""

EXCEPTIONS: dict[tuple[str, str], str] = {
    ("stiction.sim.batch_kernel", "stiction.sim.batch"): (
        "a function-level import: the compiled kernel's warm-up builds its rows with "
        "batch.py's helpers, while batch.py loads the kernel only on first use (numba is "
        "optional). The simulator is being reworked for speed in parallel; moving the "
        "row helpers into their own module belongs to that work."
    ),
}
"""(importing module, imported module) -> why this edge may break the rules."""


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(SRC).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


@cache
def modules() -> dict[str, Path]:
    return {_module_name(p): p for p in sorted((SRC / "stiction").rglob("*.py"))}


def _imported(name: str, path: Path) -> Iterator[str]:
    """Every stiction module `name` imports, anywhere in the file."""
    known = modules()
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                module = ".".join([*base, node.module] if node.module else base)
            else:
                module = node.module or ""
            # `from pkg import sub` imports the module pkg.sub; `from m import f` imports m
            subs = [f"{module}.{a.name}" for a in node.names if f"{module}.{a.name}" in known]
            targets = subs if subs and len(subs) == len(node.names) else [module, *subs]
        else:
            continue
        for target in targets:
            while target and target not in known:  # `import a.b.c` names a.b.c or a parent
                target = target.rpartition(".")[0]
            if target.startswith("stiction") and target != name:
                yield target


@cache
def edges() -> dict[str, set[str]]:
    return {name: set(_imported(name, path)) for name, path in modules().items()}


@cache
def cli_modules() -> frozenset[str]:
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    entry = {target.partition(":")[0] for target in scripts.values()}
    named = {
        name
        for name in modules()
        if name.rpartition(".")[2] in ("cli", "__main__") or name.endswith("_cli")
    }
    return frozenset({*COMMAND_MODULES, *entry, *named})


def unit(module: str) -> str:
    if module in cli_modules():
        return "cli"
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def layer(u: str) -> int:
    for i, units in enumerate(LAYERS):
        if u in units:
            return i
    raise AssertionError(f"unit {u!r} is in no layer of LAYERS: add it where it belongs")


def _allowed(src: str, dst: str) -> bool:
    return (src, dst) in EXCEPTIONS


def test_every_unit_has_a_layer() -> None:
    for name in modules():
        layer(unit(name))


def test_the_parser_sees_function_level_and_relative_imports() -> None:
    assert "stiction.drivers.discovery" in edges()["stiction.daemon.devices"]  # in a function
    assert "stiction.daemon.options" in edges()["stiction.daemon.config"]
    assert "stiction.daemon.ops" in edges()["stiction.daemon.service"]


def test_imports_go_downward_only() -> None:
    wrong = []
    for src, targets in sorted(edges().items()):
        for dst in sorted(targets):
            a, b = unit(src), unit(dst)
            if a == b or a == "cli" or _allowed(src, dst):
                continue
            if layer(b) >= layer(a):
                wrong.append(f"{src} ({a}) -> {dst} ({b})")
    assert not wrong, "upward or sideways imports:\n" + "\n".join(wrong)


def test_nothing_imports_a_command_line_module() -> None:
    wrong = [
        f"{src} -> {dst}"
        for src, targets in sorted(edges().items())
        for dst in sorted(targets)
        if dst in cli_modules() and unit(src) != "cli" and not _allowed(src, dst)
    ]
    assert not wrong, "command-line modules imported by library code:\n" + "\n".join(wrong)


def _cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One cycle of `graph` as a path [a, ..., a], or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(n: str) -> list[str] | None:
        state[n] = 1
        stack.append(n)
        for m in sorted(graph.get(n, ())):
            if state.get(m) == 1:
                return [*stack[stack.index(m) :], m]
            if m not in state and (found := visit(m)):
                return found
        stack.pop()
        state[n] = 2
        return None

    for n in sorted(graph):
        if n not in state and (found := visit(n)):
            return found
    return None


def test_no_cycle_between_units() -> None:
    graph: dict[str, set[str]] = defaultdict(set)
    for src, targets in edges().items():
        for dst in targets:
            if unit(src) != unit(dst) and not _allowed(src, dst):
                graph[unit(src)].add(unit(dst))
    assert _cycle(graph) is None


@pytest.mark.parametrize("package", sorted({unit(m) for m in modules()} - {"cli", "__init__"}))
def test_no_cycle_between_the_modules_of_a_package(package: str) -> None:
    prefix = f"stiction.{package}"

    def related(a: str, b: str) -> bool:  # a package and its own submodules
        return a.startswith(b + ".") or b.startswith(a + ".")

    graph = {
        src: {
            d
            for d in targets
            if d.startswith(prefix) and not related(src, d) and not _allowed(src, d)
        }
        for src, targets in edges().items()
        if src.startswith(prefix) and src not in cli_modules()
    }
    assert _cycle(graph) is None


def test_a_cycle_and_an_upward_edge_would_be_found() -> None:
    """The checks can fail: a made-up graph with both is caught."""
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None
    assert layer("protocol") < layer("daemon")
    assert unit("stiction.sim.cli") == "cli" and unit("stiction.sim.step") == "sim"


def test_exceptions_are_still_needed() -> None:
    stale = [f"{a} -> {b}" for a, b in EXCEPTIONS if b not in edges().get(a, set())]
    assert not stale, "exceptions for imports that are gone:\n" + "\n".join(stale)

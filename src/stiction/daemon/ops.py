"""The control ops: what each request does, apart from the socket and the loop.

`OpTable` maps an op name to its handler. A query (`ping`, `stats`, ...) is
answered on the loop thread at a tick boundary. A change (`set_scene`,
`set_params`) has a slow part -- reading and compiling a scene, checking
that everything it will publish can be encoded -- that runs on the control
thread first (`prepare`), and a swap that runs on the loop thread (the
returned `apply`). Handlers see the daemon only through `Controlled`, the
narrow interface below, so the op table can be tested with a stand-in and
the control transport (daemon/control.py) knows nothing of either.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol

from stiction import protocol
from stiction.errors import ProtocolError


class Controlled(Protocol):
    """What the control ops may ask of and do to the daemon (daemon/service.py's Daemon)."""

    @property
    def generation(self) -> int:
        """Counts pipeline swaps: a prepared change made against an older one is redone."""
        ...

    def ping(self) -> protocol.PingReply: ...
    def scene_wire(self) -> protocol.SceneWire: ...
    def scene_text(self) -> str: ...
    def params_reply(self) -> protocol.ParamsReply: ...
    def devices(self) -> list[protocol.DeviceWire]: ...
    def stats(self) -> protocol.StatsWire: ...
    def snapshot(self) -> protocol.SnapshotReply: ...
    def load_scene_text(self, text: str, source: str) -> Any: ...
    def load_scene_file(self, path: Path) -> Any: ...
    def prepare_scene(self, scene: Any) -> Any: ...
    def prepare_params(self, values: dict[str, Any], material: str | None) -> tuple[Any, Any]: ...
    def apply_pipeline(self, pipeline: Any, defaults: Any = None) -> None: ...
    def log_params(self, values: dict[str, Any], material: str | None) -> None: ...


Apply = Callable[[], protocol.Reply]
"""A prepared change: swaps it in (loop thread) and returns the reply."""
Query = Callable[[Controlled, dict[str, Any]], protocol.Reply]
Change = Callable[[Controlled, dict[str, Any]], Apply]


def only(args: dict[str, Any], allowed: set[str], op: str) -> None:
    """Refuse arguments an op does not take, naming them."""
    extra = sorted(set(args) - allowed)
    if extra:
        raise ProtocolError(f"{op} does not take {', '.join(extra)}")


# --- queries (loop thread) ------------------------------------------------------


def _ping(d: Controlled, args: dict[str, Any]) -> protocol.Reply:
    return d.ping()


def _get_scene(d: Controlled, args: dict[str, Any]) -> protocol.Reply:
    return protocol.scene_reply(d.scene_wire(), d.scene_text())


def _get_params(d: Controlled, args: dict[str, Any]) -> protocol.Reply:
    only(args, set(), "get_params")
    return d.params_reply()


def _devices(d: Controlled, args: dict[str, Any]) -> protocol.Reply:
    return protocol.devices_reply(d.devices())


def _stats(d: Controlled, args: dict[str, Any]) -> protocol.Reply:
    return protocol.stats_reply(d.stats())


def _snapshot(d: Controlled, args: dict[str, Any]) -> protocol.Reply:
    return d.snapshot()


# --- changes (prepared on the control thread, applied on the loop thread) -------


def _set_scene(d: Controlled, args: dict[str, Any]) -> Apply:
    only(args, {"toml", "path"}, "set_scene")
    if ("toml" in args) == ("path" in args):
        raise ProtocolError("set_scene needs exactly one of 'toml' or 'path'")
    if "toml" in args:
        text = args["toml"]
        if not isinstance(text, str):
            raise ProtocolError("set_scene 'toml' must be a string")
        scene = d.load_scene_text(text, "<control>")
    else:
        path = args["path"]
        if not isinstance(path, str):
            raise ProtocolError("set_scene 'path' must be a string")
        if not path:  # Path("") is ".": the error would name a directory nobody gave
            raise ProtocolError("set_scene 'path' is empty; give the scene file's path")
        scene = d.load_scene_file(Path(path))
    pipeline = d.prepare_scene(scene)

    def apply() -> protocol.Reply:
        d.apply_pipeline(pipeline)
        return protocol.scene_reply(d.scene_wire())

    return apply


def _set_params(d: Controlled, args: dict[str, Any]) -> Apply:
    material = args.pop("material", None)
    if material is not None and not isinstance(material, str):
        raise ProtocolError("set_params 'material' must be a string")
    base = d.generation
    pipeline, defaults = d.prepare_params(args, material)

    def apply() -> protocol.Reply:
        if d.generation == base:
            d.apply_pipeline(pipeline, defaults)
        else:  # the scene changed meanwhile: apply the change to the new one
            d.apply_pipeline(*d.prepare_params(args, material))
        d.log_params(args, material)
        return d.params_reply()

    return apply


QUERIES: dict[protocol.ControlOp, Query] = {
    "ping": _ping,
    "get_scene": _get_scene,
    "get_params": _get_params,
    "devices": _devices,
    "stats": _stats,
    "snapshot": _snapshot,
}
CHANGES: dict[protocol.ControlOp, Change] = {
    "set_scene": _set_scene,
    "set_params": _set_params,
}


class OpTable:
    """The ops of one daemon: `prepare` off the loop, `answer` on it."""

    def __init__(self, target: Controlled) -> None:
        self.target = target

    def prepare(self, op: protocol.ControlOp, args: dict[str, Any]) -> Apply | None:
        """The slow part of a change (control thread); None for a query."""
        change = CHANGES.get(op)
        return None if change is None else change(self.target, args)

    def answer(self, op: protocol.ControlOp, args: dict[str, Any]) -> protocol.Reply:
        """Answer a query (loop thread)."""
        query = QUERIES.get(op)
        if query is None:
            raise ProtocolError(f"op {op!r} is not served")
        return query(self.target, args)

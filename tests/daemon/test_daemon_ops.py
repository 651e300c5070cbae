"""The op table on its own: a stand-in daemon, no sockets, no loop."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from stiction import protocol
from stiction.daemon.ops import CHANGES, QUERIES, OpTable
from stiction.errors import ProtocolError

SCENE: protocol.SceneWire = {"name": "s", "source": "<x>", "display": [10, 10], "effects": [],
                             "outside": "pass-through", "materials": {}, "regions": []}  # fmt: skip


class StandIn:
    """Records what the ops did; each prepared pipeline is a string naming its origin."""

    def __init__(self) -> None:
        self.generation = 0
        self.applied: list[tuple[Any, Any]] = []
        self.prepared: list[tuple[dict[str, Any], str | None]] = []

    def ping(self) -> protocol.PingReply:
        return protocol.ping_reply(4, "x", 100.0, 1.0)

    def scene_wire(self) -> protocol.SceneWire:
        return SCENE

    def scene_text(self) -> str:
        return "toml"

    def params_reply(self) -> protocol.ParamsReply:
        return protocol.params_reply({"k": 1.0}, "default", {})

    def devices(self) -> list[protocol.DeviceWire]:
        return []

    def stats(self) -> protocol.StatsWire:
        raise AssertionError("not asked here")

    def snapshot(self) -> protocol.SnapshotReply:
        return protocol.snapshot_reply(4, SCENE, {}, 1.0)

    def load_scene_text(self, text: str, source: str) -> Any:
        return f"scene:{text}"

    def load_scene_file(self, path: Path) -> Any:
        return f"file:{path}"

    def prepare_scene(self, scene: Any) -> Any:
        return f"pipeline({scene})"

    def prepare_params(self, values: dict[str, Any], material: str | None) -> tuple[Any, Any]:
        self.prepared.append((dict(values), material))
        return f"params@{self.generation}", {"k": values.get("k")}

    def apply_pipeline(self, pipeline: Any, defaults: Any = None) -> None:
        self.applied.append((pipeline, defaults))
        self.generation += 1

    def log_params(self, values: dict[str, Any], material: str | None) -> None:
        pass


def test_every_op_has_exactly_one_handler() -> None:
    assert set(QUERIES) | set(CHANGES) == set(protocol.CONTROL_OPS)
    assert not set(QUERIES) & set(CHANGES)


def test_queries_are_not_prepared_and_changes_are() -> None:
    ops = OpTable(StandIn())
    assert ops.prepare("ping", {}) is None
    assert ops.answer("get_scene", {}) == protocol.scene_reply(SCENE, "toml")
    with pytest.raises(ProtocolError, match="not served"):
        ops.answer("set_scene", {})


def test_set_scene_applies_only_when_applied() -> None:
    d = StandIn()
    apply = OpTable(d).prepare("set_scene", {"toml": "x = 1"})
    assert apply is not None and d.applied == []
    assert apply() == protocol.scene_reply(SCENE)
    assert d.applied == [("pipeline(scene:x = 1)", None)]


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ({}, "exactly one of"),
        ({"toml": "a", "path": "b"}, "exactly one of"),
        ({"toml": 3}, "'toml' must be a string"),
        ({"what": 1}, "does not take what"),
    ],
)
def test_set_scene_refuses_bad_arguments(args: dict[str, Any], message: str) -> None:
    with pytest.raises(ProtocolError, match=message):
        OpTable(StandIn()).prepare("set_scene", args)


def test_set_params_is_redone_when_the_scene_changed_meanwhile() -> None:
    d = StandIn()
    ops = OpTable(d)
    apply = ops.prepare("set_params", {"k": 2.0, "material": "rubber"})
    assert apply is not None
    d.apply_pipeline("someone else's scene")
    apply()
    assert d.applied[-1] == ("params@1", {"k": 2.0})
    assert d.prepared == [({"k": 2.0}, "rubber")] * 2
    unchanged = ops.prepare("set_params", {"k": 3.0})
    assert unchanged is not None
    unchanged()
    assert d.applied[-1] == ("params@2", {"k": 3.0})
    assert len(d.prepared) == 3

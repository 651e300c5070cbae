"""Pass-through in published frames: the pointer glides back, then follows the touch.

docs/protocol.md ("Phases") and docs/scenes.md promise the same thing: a
contact that leaves a material for a pass-through area is reported as
`slip` on "pass-through" with pointer != touch and tension > 0 while the
pointer glides back (critically damped), then pointer = touch
and tension 0; one that touches down on pass-through has pointer = touch and
tension 0 from the start. These frames come from the real daemon loop,
through its publisher socket, on the virtual clock.
"""

from __future__ import annotations

import itertools
from pathlib import Path
from typing import Any

import zmq
from daemon_support import ListSource, drain, make_daemon, subscribe

from stiction import protocol
from stiction.drivers.sample import PenSample

SCENE = """
[scene]
name = "half rubber"
display = [1000, 500]
outside = "pass-through"
effects = ["stick_slip", "string"]

[materials.rubber]
mu_s = 0.9
mu_k = 0.4

[[regions]]
shape = "rect"
rect = [0, 0, 500, 500]
material = "rubber"
"""

DT = 0.004


def pen_path(xs: list[float]) -> list[PenSample]:
    """Touch down at xs[0] (metres on a 0.2 x 0.1 m surface, 5000 px/m), move through xs, lift."""
    out = [PenSample(t=i * DT, x=x, y=0.05, tip=True) for i, x in enumerate(xs)]
    t = len(xs) * DT
    out.append(PenSample(t=t, x=xs[-1], y=0.05, tip=False, in_range=False))
    return out


def frames_for(tmp_path: Path, samples: list[PenSample]) -> list[dict[str, Any]]:
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    eps = (f"ipc://{tmp_path}/pub", f"ipc://{tmp_path}/ctl")
    d = make_daemon(eps, {"replay:pen": ListSource(samples)}, clock="virtual", scene=scene)
    sub = subscribe(zmq.Context.instance(), d, eps[0])
    try:
        assert d.run() == 0
    finally:
        d.close()
    msgs = drain(sub)
    sub.close()
    return [m for _, m in msgs if m.get("kind") == "frame" and m.get("contacts")]


def test_leaving_a_material_glides_back_then_follows(tmp_path: Path) -> None:
    # Drag from 60 to 140 mm (300 -> 700 px: rubber ends at 500 px), then hold still.
    xs = [0.06 + 0.0008 * i for i in range(100)] + [0.14] * 100
    contacts = [f["contacts"][0] for f in frames_for(tmp_path, pen_path(xs))]
    on_rubber = [c for c in contacts if c["material"] == "rubber"]
    assert any(c["phase"] == "stick" for c in on_rubber)
    through = [c for c in contacts if c["material"] == protocol.PASS_THROUGH and c["phase"] != "up"]
    assert through and all(c["phase"] == "slip" for c in through)
    gap = [abs(c["touch_px"][0] - c["pointer_px"][0]) for c in through]
    # The glide: it starts behind the touch, pulled (tension > 0, a string)...
    assert gap[0] > 1.0 and through[0]["tension"] > 0 and through[0]["string"]["length_px"] > 0
    # ... pulled all the way: tension > 0 as long as pointer != touch ...
    assert all(c["tension"] > 0 for c, g in zip(through, gap, strict=True) if g > 0)
    # ... and, once the touch holds still, closing in without friction. A pointer
    # still catching up when the touch stops carries its speed past it once (a
    # mass on a critically damped spring overshoots only from such a start)
    # and comes back: the gap then shrinks every tick.
    still = [i for i, c in enumerate(through) if c["touch_px"][0] == through[-1]["touch_px"][0]]
    peak = max(still, key=lambda i: gap[i])
    tail = gap[peak:]
    assert all(b <= a for a, b in itertools.pairwise(tail)), tail
    # ... and ends: pointer = touch, tension 0, for the rest of the hold.
    settled = [i for i, c in enumerate(through) if c["pointer_px"] == c["touch_px"]]
    assert settled, gap[-5:]
    for c in through[settled[0] :]:
        assert c["pointer_px"] == c["touch_px"] and c["tension"] == 0.0
    # The glide took a few time constants (sqrt(m/k) = 32 ms with the defaults), not one tick.
    assert 3 <= settled[0] <= 100


def test_touching_down_on_pass_through_follows_from_the_start(tmp_path: Path) -> None:
    xs = [0.15 + 0.0005 * i for i in range(50)]  # 750 px onward: pass-through
    contacts = [f["contacts"][0] for f in frames_for(tmp_path, pen_path(xs))]
    down = [c for c in contacts if c["phase"] != "up"]
    assert down and all(c["material"] == protocol.PASS_THROUGH for c in down)
    for c in down:
        assert c["phase"] == "slip" and c["pointer_px"] == c["touch_px"] and c["tension"] == 0.0

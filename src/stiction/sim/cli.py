"""`stiction simulate`: replay a trace CSV through the simulator (docs/design/architecture.md)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any


def register(sub: argparse._SubParsersAction[Any]) -> None:
    p = sub.add_parser(
        "simulate",
        help="run a trace CSV through the stick-slip simulator",
        description=(
            "Replay TRACE.csv (header t,x,y,contact[,pressure]; seconds, surface metres) "
            "through the simulator at a fixed rate, following every sample between ticks, "
            "and write the state at every tick to OUT.csv."
        ),
    )
    p.add_argument(
        "trace",
        metavar="TRACE.csv",
        help="a trace CSV (`stiction trace` makes one from any recording), or example:NAME "
        "for one shipped with stiction (example:demo, example:stroke, example:circles)",
    )
    p.add_argument("--out", required=True, metavar="OUT.csv", help="output CSV ('-' = stdout)")
    p.add_argument("--integrator", default="default", help="explicit-euler, semi-implicit-euler, "
                   "rk4, implicit-projection, exact or default (default: %(default)s)")  # fmt: skip
    p.add_argument("--substeps", type=int, default=1, help="substeps per tick (default: 1)")
    p.add_argument("--rate", type=float, default=None, help="tick rate in Hz (default: 100)")
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="model parameter k, m, g, mu_s, mu_k or C_l (repeatable)",
    )
    p.add_argument(
        "--events",
        choices=("auto", "on", "off"),
        default="auto",
        help="sub-tick event location (auto: on for exact, off for the fixed-step ones)",
    )
    p.add_argument(
        "--scene",
        metavar="SCENE.toml",
        help="take the material, string and pressure-load settings from a scene file "
        "(its 'outside' material: a trace has no display mapping to place regions)",
    )
    p.set_defaults(func=_simulate)


def _parse_params(pairs: list[str]) -> dict[str, str]:
    from stiction.errors import ParamError

    out: dict[str, str] = {}
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or not name.strip():
            raise ParamError(f"--param wants NAME=VALUE, got {pair!r}")
        out[name.strip()] = value
    return out


def _simulate(args: argparse.Namespace) -> int:
    from stiction.errors import ParamError
    from stiction.sim.contact import ContactSim
    from stiction.sim.integrators import MAX_SUBSTEPS
    from stiction.sim.params import Params
    from stiction.sim.trace import TraceSample, open_trace, resolve_trace, simulate, write_states

    values: dict[str, Any] = {}
    string = True
    passthrough = False
    gain = None
    if args.scene:
        from stiction.scene.load import load_scene
        from stiction.scene.model import PRESSURE_LOAD, STICK_SLIP, STRING

        scene = load_scene(args.scene)
        string = STRING in scene.effects
        if scene.outside is None or STICK_SLIP not in scene.effects:
            passthrough = True
            why = (
                "has no 'stick_slip' effect"
                if STICK_SLIP not in scene.effects
                else "has no 'outside' material (a trace has no display, so its regions "
                "cannot be placed; simulate uses the outside material)"
            )
            print(
                f"stiction: warning: scene {args.scene} {why}: the output has no friction "
                "(pointer = touch, tension 0)",
                file=sys.stderr,
            )
        else:
            values.update(scene.materials[scene.outside].overrides())
        if PRESSURE_LOAD in scene.effects:
            gain = scene.pressure_load.gain
    values.update(_parse_params(args.param))
    if args.rate is not None:
        values["rate"] = args.rate
    params = Params.from_mapping(values)
    events = {"auto": None, "on": True, "off": False}[args.events]
    if not 1 <= args.substeps <= MAX_SUBSTEPS:
        raise ParamError(f"--substeps must be >= 1 and <= {MAX_SUBSTEPS}, got {args.substeps}")
    sim = ContactSim(params, args.integrator, args.substeps, events, string=string)
    path = resolve_trace(args.trace)
    touched = [False]

    def watch(samples: Iterator[TraceSample]) -> Iterator[TraceSample]:
        for s in samples:
            touched[0] = touched[0] or s.tip
            yield s

    with open_trace(path) as samples:
        states = simulate(watch(samples), sim, gain, passthrough)
        if args.out == "-":
            write_states(states, sys.stdout)
        else:
            _write_atomically(Path(args.out), states)
    if not touched[0]:
        print(
            f"stiction: warning: {path}: no sample has contact = 1, so every output row is "
            "'up'. The contact column is the touch state (1 = touching, 0 = not), "
            "not a contact id.",
            file=sys.stderr,
        )
    return 0


def _write_atomically(out: Path, states: Iterator[Any]) -> None:
    from stiction.errors import ParamError
    from stiction.sim.trace import write_states

    tmp = out.with_name(out.name + ".part")
    try:
        with tmp.open("w", encoding="utf-8", newline="") as f:
            write_states(states, f)
        tmp.replace(out)
    except OSError as exc:
        tmp.unlink(missing_ok=True)
        raise ParamError(f"{out}: cannot write: {exc.strerror or exc}") from None
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise

"""`stiction demo`: the whole thing on any machine, in one command.

Starts stictiond on the synthetic pen with the demo scene (sticky and
slippery regions), serves the web renderer for it, and prints the address to
open. The daemon talks to the renderer over ipc:// sockets in a private
directory, so the demo never clashes with a stictiond already running on the
default ports and never listens on the network. Ctrl-C (or SIGTERM, or
``--seconds``) stops the renderer and the daemon; the daemon is always
terminated and waited for, also when something fails on the way.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from stiction.argtypes import port, seconds
from stiction.daemon.spawn import daemon_command
from stiction.errors import StictionError

# asyncio, subprocess and the rest are imported where the demo runs, not when
# `stiction --help` builds the parser from register() below.
if TYPE_CHECKING:
    import subprocess

DEMO_SCENE = Path(__file__).resolve().parent / "scene" / "examples" / "demo.toml"
DEFAULT_PORT = 8765


def _wait_ready(proc: subprocess.Popen[bytes], control: str, timeout: float) -> dict[str, Any]:
    """Ping the control endpoint until the daemon answers or dies."""
    from stiction.clients import control as control_mod

    end = time.monotonic() + timeout
    while True:
        if proc.poll() is not None:
            err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
            tail = " | ".join(err.strip().splitlines()[-3:])
            raise StictionError(f"stictiond exited with status {proc.returncode}: {tail}")
        try:
            return control_mod.request(control, "ping", timeout=0.5)
        except control_mod.ControlUnavailable:
            if time.monotonic() >= end:
                raise StictionError(
                    f"stictiond did not answer on {control} within {timeout:g} s"
                ) from None


def _interrupt(signum: int, frame: object) -> None:
    """SIGTERM before the renderer runs ends the demo like Ctrl-C: cleanly."""
    raise KeyboardInterrupt


def _stop(proc: subprocess.Popen[bytes]) -> None:
    import subprocess

    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


async def _serve(pub: str, control: str, port: int, seconds: float | None) -> dict[str, Any]:
    import asyncio

    from stiction.clients.web import server
    from stiction.clients.web.bridge import Bridge

    bridges: list[Bridge] = []
    ready: asyncio.Future[str] = asyncio.get_running_loop().create_future()
    task = asyncio.ensure_future(
        server.run(
            pub, control, "127.0.0.1", port, seconds, ready=ready, bridges=bridges, announce=False
        )
    )
    waiters: set[asyncio.Future[Any]] = {task, ready}
    done, _ = await asyncio.wait(waiters, return_when=asyncio.FIRST_COMPLETED)
    if ready in done:
        print(
            f"stiction demo: open {ready.result()} in a browser "
            f"({'Ctrl-C to stop' if seconds is None else f'running for {seconds:g} s'})",
            flush=True,
        )
    await task
    return bridges[0].summary() if bridges else {}


def run_demo(
    *,
    port: int = DEFAULT_PORT,
    fallback_port: bool = False,
    seconds: float | None = None,
    scene: Path = DEMO_SCENE,
    device: str = "synthetic:demo",
) -> int:
    import asyncio
    import contextlib
    import shutil
    import signal
    import subprocess
    import tempfile

    from stiction.clients.web.errors import PortInUse

    if not scene.exists():
        raise StictionError(f"scene file {scene} not found")
    if not scene.is_file():  # a directory or a FIFO: stictiond would refuse it, in other words
        raise StictionError(f"{scene}: not a regular file; a scene must be a file")
    workdir = Path(tempfile.mkdtemp(prefix="stiction-demo-"))
    pub, control = f"ipc://{workdir}/pub", f"ipc://{workdir}/control"
    cmd = [
        *daemon_command(),
        *("--device", device, "--scene", str(scene), "--clock", "real", "--no-hotplug"),
        *("--pub", pub, "--control", control),
    ]
    # Ctrl-C in a terminal reaches the whole process group; the daemon gets its
    # own session so it is stopped by us, in order, after the renderer.
    proc = subprocess.Popen(
        cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True
    )
    previous = signal.getsignal(signal.SIGTERM)
    summary: dict[str, Any] = {}
    try:
        signal.signal(signal.SIGTERM, _interrupt)
        info = _wait_ready(proc, control, timeout=20)
        print(
            f"stiction demo: stictiond {info.get('version', '')} (pid {proc.pid}) on {device} "
            f"with scene {scene.name}",
            flush=True,
        )
        with contextlib.suppress(KeyboardInterrupt):
            try:
                summary = asyncio.run(_serve(pub, control, port, seconds))
            except PortInUse:
                if not fallback_port:
                    raise
                print(f"stiction demo: port {port} is taken; using a free port instead", flush=True)
                summary = asyncio.run(_serve(pub, control, 0, seconds))
    finally:
        signal.signal(signal.SIGTERM, previous)
        _stop(proc)
        shutil.rmtree(workdir, ignore_errors=True)
    if summary:
        print(
            f"stiction demo: stopped; the renderer received {summary.get('frames', 0)} frames "
            f"and {summary.get('scenes', 0)} scene(s), skipped {summary.get('errors', 0)} bad",
            flush=True,
        )
        if seconds is not None and not summary.get("frames"):
            print("stiction demo: no frames arrived from the daemon", file=sys.stderr)
            return 1
    return 0


def _handle(args: argparse.Namespace) -> int:
    return run_demo(
        port=DEFAULT_PORT if args.port is None else args.port,
        # `make demo` must not fail because 8765 is busy; an explicit --port must be honoured.
        fallback_port=args.port is None,
        seconds=args.seconds,
        scene=Path(args.scene),
        device=args.device,
    )


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add `stiction demo`."""
    p = sub.add_parser(
        "demo",
        help="run the daemon on a synthetic pen and show it in the browser",
        description="Start stictiond on the synthetic pen with the demo scene and the web "
        "renderer; prints the address to open. Runs until Ctrl-C, or --seconds.",
    )
    p.add_argument(
        "--port",
        type=port,
        help=f"web page port (default {DEFAULT_PORT}, or a free one if it is taken; 0: any)",
    )
    p.add_argument("--seconds", type=seconds, help="stop after S seconds (headless runs, tests)")
    p.add_argument("--scene", default=str(DEMO_SCENE), help="scene file (default: the demo scene)")
    p.add_argument("--device", default="synthetic:demo", help="device spec for stictiond")
    p.set_defaults(func=_handle)

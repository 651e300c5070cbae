"""A real stictiond, started on the steered synthetic pen under the virtual clock, in lockstep.

The simulated participant writes pen states into the daemon's stdin
(``--device synthetic:stdin``, stiction.drivers.fake.feed) and reads the
frames the daemon publishes. Under ``--clock virtual`` the daemon ticks as
far as the input it has, and no further: after samples up to time T it has
published exactly the frames of the deadlines before T and then waits for
more input. So the participant can write a few milliseconds of pen, read
precisely the frames they produced, react, and write more: a closed loop at
full speed, and the same every run.

The daemon's clock moves only with samples, and a tablet sends samples only
while the pen is in range; so between strokes the pen hovers at a parking
spot in a corner instead of leaving range, which keeps time moving. Control
requests are answered between ticks; while one is outstanding the pen hovers
and time is moved on until the reply comes.
"""

from __future__ import annotations

import contextlib
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import zmq

from stiction import protocol
from stiction.daemon.spawn import daemon_command
from stiction.drivers.fake.feed import format_state
from stiction.drivers.fake.strokes import DT, PenState
from stiction.errors import StictionError

FrameHook = Callable[[dict[str, Any]], None]
RATE = 100.0
PARK_M = (0.01, 0.01)
"""Where the pen hovers between stimuli: a corner, far from the dot."""


class SteeredDaemon:
    """Starts stictiond on synthetic:stdin with a scene file; `close()` stops it."""

    def __init__(self, scene_toml: str, *, log_path: Path | None = None) -> None:
        self.dir = Path(tempfile.mkdtemp(prefix="stiction-exp-"))
        scene = self.dir / "scene.toml"
        scene.write_text(scene_toml, encoding="utf-8")
        self.pub, self.control = f"ipc://{self.dir}/pub", f"ipc://{self.dir}/control"
        self.log_path = log_path or self.dir / "stictiond.log"
        self._log: IO[bytes] = open(self.log_path, "wb")  # noqa: SIM115
        cmd = [
            *daemon_command(),
            *("--device", "synthetic:stdin", "--clock", "virtual", "--scene", str(scene)),
            *("--pub", self.pub, "--control", self.control, "--wait-subscribers", "1"),
            *("--wait-timeout", "60", "--no-hotplug"),
        ]
        self.proc = subprocess.Popen(
            cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=self._log
        )
        assert self.proc.stdin is not None
        self._in = self.proc.stdin
        self.ctx = zmq.Context()
        self.sub = self.ctx.socket(zmq.SUB)
        self.sub.setsockopt(zmq.LINGER, 0)
        self.sub.setsockopt(zmq.RCVHWM, 0)
        self.sub.setsockopt(zmq.SUBSCRIBE, b"frame.")
        self.sub.connect(self.pub)
        self.t = 0.0
        self.last_x, self.last_y = 0.0, 0.0
        self.frames = 0
        self.on_frame: FrameHook | None = None
        self._write([PenState(0.0, *PARK_M, False, True, 0.0)])

    # ------------------------------------------------------------ input
    def _write(self, states: list[PenState]) -> None:
        try:
            self._in.write("".join(format_state(s) for s in states).encode())
            self._in.flush()
        except BrokenPipeError:
            raise StictionError(f"stictiond exited: {self.log_tail()}") from None
        last = states[-1]
        self.t, self.last_x, self.last_y = last.t, last.x, last.y

    def _drain_until(self, t: float, timeout_s: float = 60.0) -> None:
        """Read frames until the one for the last deadline before `t` has arrived."""
        want = t - 1.0 / RATE - 1e-6
        while True:
            if not self.sub.poll(int(timeout_s * 1000)):
                raise StictionError(
                    f"no frame from stictiond for {timeout_s:g} s (virtual t={t:.3f}); "
                    f"{self.log_tail()}"
                )
            _topic, payload = self.sub.recv_multipart()
            frame = protocol.decode(payload)
            self.frames += 1
            if self.on_frame is not None:
                self.on_frame(frame)
            if float(frame["t"]) >= want:
                return

    def step(self, states: list[PenState]) -> None:
        """Send pen states (times after the last ones) and take the frames they produce."""
        if states:
            self._write(states)
            self._drain_until(self.t)

    def idle(self, seconds: float) -> None:
        """The pen hovering at the parking spot for `seconds` (between stimuli)."""
        n = max(1, round(seconds / DT))
        base = self.t
        states = [PenState(base + (i + 1) * DT, *PARK_M, False, True, 0.0) for i in range(n)]
        self.step(states)

    # ------------------------------------------------------------ control
    def request(self, op: protocol.ControlOp, **args: Any) -> dict[str, Any]:
        """A control request, answered while the pen idles (time must move for the loop)."""
        sock = self.ctx.socket(zmq.REQ)
        sock.setsockopt(zmq.LINGER, 0)
        sock.connect(self.control)
        try:
            sock.send(protocol.make_request(op, **args))
            for _ in range(2000):
                self.idle(0.01)
                if sock.poll(5):
                    return protocol.parse_reply(sock.recv())
            raise StictionError(f"no reply to {op!r} from stictiond; {self.log_tail()}")
        finally:
            sock.close()

    # ------------------------------------------------------------ lifetime
    def log_tail(self) -> str:
        self._log.flush()
        try:
            text = self.log_path.read_text(errors="replace")
        except OSError:
            return ""
        return " | ".join(text.strip().splitlines()[-3:])

    def close(self) -> int | None:
        """End the input (the daemon then exits on its own) and clean up."""
        with contextlib.suppress(OSError):
            self._in.close()
        try:
            code = self.proc.wait(20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            code = self.proc.wait(5)
        self.sub.close()
        self.ctx.term()
        self._log.close()
        shutil.rmtree(self.dir, ignore_errors=True)
        return code

    def __enter__(self) -> SteeredDaemon:
        return self

    def __exit__(self, *exc: object) -> None:
        if self.proc.poll() is None and exc[0] is not None:
            self.proc.kill()
        self.close()

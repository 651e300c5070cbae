"""Runs the docs' `run` blocks inside a private network namespace; writes one result per command.

Started by test_doc_commands.py as `unshare -rn python doc_runner.py SCRATCH OUT.json`
(or, where namespaces are not allowed, with `--host-network` and no unshare).
The namespace has its own loopback, so the commands run exactly as the page
writes them, on the documented default endpoints (tcp://127.0.0.1:5556 and
5557, port 8765), without meeting any other daemon on the machine and without
any substitution of ports. What the runner does provide, and the convention
documents: a scratch folder as working directory and $HOME, with `src`,
`clients`, `bench` and `docs` of the checkout linked in, `.venv/bin/` holding
this environment's `stiction`, `stictiond` and `python`, and the placeholder
files named in PLACEHOLDERS.
"""

from __future__ import annotations

import fcntl
import json
import os
import re
import shutil
import signal
import socket
import struct
import subprocess
import sys
import threading
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from doc_blocks import REPO, Block, all_blocks, commands, directive_for, strip_comment

SHARED = REPO.parent / "shared" / "data"
PLACEHOLDERS = {
    "FILE.hid": SHARED / "hid" / "xp-pen-deco-03.hid",
    "REC.evemu": SHARED / "evdev" / "wacom-cintiq-13hd-touch-pen.evemu",
    "my-scene.toml": REPO / "src" / "stiction" / "scene" / "examples" / "demo.toml",
}
READY_TIMEOUT = 30.0  # a background command must show life within this
COMMAND_TIMEOUT = 60.0


def loopback_up() -> None:
    """`ip link set lo up` without needing iproute2 (SIOCGIFFLAGS / SIOCSIFFLAGS)."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    req = struct.pack("16sH14x", b"lo", 0)
    flags = struct.unpack("16sH", fcntl.ioctl(s, 0x8913, req)[:18])[1]
    fcntl.ioctl(s, 0x8914, struct.pack("16sH14x", b"lo", flags | 0x1))
    s.close()


def prepare(scratch: Path) -> dict[str, str]:
    """(Re)build the scratch folder a reader's checkout would be; return the environment."""
    scratch.mkdir(parents=True, exist_ok=True)
    for name in ("src", "clients", "bench", "docs", "udev", "tools"):
        link = scratch / name
        if not link.exists():
            link.symlink_to(REPO / name)
    venv_bin = scratch / ".venv" / "bin"
    venv_bin.mkdir(parents=True, exist_ok=True)
    bindir = Path(sys.executable).parent
    for name, target in (
        ("python", Path(sys.executable)),
        ("stiction", bindir / "stiction"),
        ("stictiond", bindir / "stictiond"),
    ):
        link = venv_bin / name
        if not link.exists():
            link.symlink_to(target)
    for name, source in PLACEHOLDERS.items():
        if not (scratch / name).exists() and source.is_file():
            shutil.copyfile(source, scratch / name)
    home = scratch / "home"
    home.mkdir(exist_ok=True)
    env = {k: v for k, v in os.environ.items() if not k.startswith("XDG_")}
    env.update(
        HOME=str(home),
        XDG_CACHE_HOME=str(home / ".cache"),
        PATH=f"{bindir}:{env.get('PATH', '/usr/bin:/bin')}",
        PYTHONUNBUFFERED="1",
        NO_COLOR="1",
    )
    env.pop("STICTION_BENCH_RESULTS", None)
    return env


class Background:
    """A command left running (a daemon, a server, a recorder) until its block ends."""

    def __init__(self, cmd: str, cwd: Path, env: dict[str, str], until: str = "") -> None:
        self.cmd = cmd
        self.until = until  # ready once the output holds this; "" = any first line
        self.out: list[str] = []
        self.ready = threading.Event()
        self.before = {p.name: p.stat().st_size for p in cwd.iterdir()}
        self.cwd = cwd
        self.proc = subprocess.Popen(
            ["bash", "-c", f"exec {cmd}"],
            cwd=cwd,
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            start_new_session=True,
        )
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for line in self.proc.stdout:
            self.out.append(line)
            if self.until in line:
                self.ready.set()
        self.ready.set()  # it ended: that is news too

    def wait_ready(self) -> str | None:
        """Wait for its first line of output (or the `until` text, or its end); None when ready."""
        # A recorder prints nothing until it stops; it shows life by writing a
        # file, and has data once that file grows past its first size.
        while not self.ready.wait(0.05):
            if not self.until and self._new_file():
                break
            if self.proc.poll() is not None:
                break
            if self._waited() > READY_TIMEOUT:
                return f"no output within {READY_TIMEOUT:.0f} s"
        if self.proc.poll() is not None and self.proc.returncode != 0:
            self.reader.join(5)
            return f"exited {self.proc.returncode} at once:\n{''.join(self.out)[-2000:]}"
        return None

    _t0: float | None = None

    def _waited(self) -> float:
        import time

        now = time.monotonic()
        if self._t0 is None:
            self._t0 = now
        return now - self._t0

    _first_sizes: dict[str, int] | None = None

    def _new_file(self) -> bool:
        sizes = {
            p.name: p.stat().st_size
            for p in self.cwd.iterdir()
            if p.name not in self.before and p.is_file()
        }
        if self._first_sizes is None:
            if sizes:
                self._first_sizes = sizes
            return False
        return any(size > self._first_sizes.get(n, 0) for n, size in sizes.items())

    def stop(self) -> str | None:
        """Ctrl-C, as a reader would; None when it ends cleanly."""
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
                return "did not stop within 30 s of Ctrl-C"
        self.reader.join(5)
        text = "".join(self.out)
        if self.proc.returncode not in (0, 130, -signal.SIGINT) or "Traceback" in text:
            return f"exit {self.proc.returncode} after Ctrl-C:\n{text[-2000:]}"
        return None


def handles_sigterm(pid: int) -> str | None:
    """None once stictiond has installed its SIGTERM/SIGINT handlers, that is, runs its loop.

    Its "started" line comes just before it installs them; a Ctrl-C in that
    instant is a race no reader meets, so the test waits for the handlers
    (SigCgt in /proc/PID/status: Python catches SIGTERM only once told to).
    """
    status = Path(f"/proc/{pid}/status")
    for _ in range(600):
        try:
            lines = status.read_text().splitlines()
            caught = next(int(x.split()[1], 16) for x in lines if x.startswith("SigCgt:"))
        except (OSError, StopIteration):
            return "it ended before running its loop"
        if caught & (1 << (signal.SIGTERM - 1)):
            return None
        threading.Event().wait(0.05)
    return "its signal handlers were not installed within 30 s"


def _key(cmd: str) -> str:
    """Two background commands with the same key are alternatives: the later replaces."""
    words = strip_comment(cmd).split()
    return " ".join(words[:2]) if words[:1] == ["stiction"] else words[0]


def _matches(expected: list[str], got: list[str]) -> bool:
    """The page's output lines against the command's; a `...` line stands for any lines."""
    if not expected:
        return True
    if expected[0] == "...":
        rest = expected[1:]
        return any(_matches(rest, got[i:]) for i in range(len(got) + 1))
    return bool(got) and got[0] == expected[0] and _matches(expected[1:], got[1:])


def run_block(block: Block, scratch: Path, running: dict[str, Background]) -> list[dict[str, str]]:
    env = prepare(scratch)
    results = []
    for cmd, expected in commands(block):
        d = directive_for(block, cmd)
        res = {"cmd": cmd, "status": "ok", "detail": ""}
        results.append(res)
        if d is not None and d.verb == "skip":
            res.update(status="skip", detail=d.reason)
            continue
        if d is not None and d.verb == "background":
            key = _key(cmd)
            if key in running:
                problem = running.pop(key).stop()
                if problem:
                    res.update(status="fail", detail=f"stopping the previous {key}: {problem}")
                    continue
            until = re.fullmatch(r'until "(.*)"', d.reason)
            bg = Background(cmd, scratch, env, until.group(1) if until else "")
            problem = bg.wait_ready()
            if problem is None and key == "stictiond":
                problem = handles_sigterm(bg.proc.pid)
            running[key] = bg
            if problem:
                res.update(status="fail", detail=problem)
            continue
        try:
            run = subprocess.run(
                ["bash", "-c", cmd],
                cwd=scratch,
                env=env,
                capture_output=True,
                text=True,
                timeout=COMMAND_TIMEOUT,
                stdin=subprocess.DEVNULL,
            )
            ok = run.returncode == 0 and "Traceback" not in run.stderr
            detail = (
                f"exit {run.returncode}\nstdout: {run.stdout[-1500:]}\nstderr: {run.stderr[-1500:]}"
            )
            if ok and expected:
                got = [x.rstrip() for x in run.stdout.rstrip("\n").split("\n")]
                if not _matches(expected, got):
                    ok = False
                    detail = "output differs from the page:\n" + "\n".join(
                        ["page:", *expected, "now:", *got]
                    )
        except subprocess.TimeoutExpired:
            ok, detail = False, f"still running after {COMMAND_TIMEOUT:.0f} s"
        if d is not None and d.verb == "xfail":
            res.update(status="xfailed" if not ok else "xpassed", detail=f"{d.reason}\n{detail}")
        elif not ok:
            res.update(status="fail", detail=detail)
    return results


def stop_all(running: dict[str, Background], results: list[dict[str, str]]) -> None:
    for key, bg in list(running.items()):
        problem = bg.stop()
        if problem:
            results.append({"cmd": bg.cmd, "status": "fail", "detail": f"on stopping: {problem}"})
        del running[key]


def main() -> int:
    scratch, out = Path(sys.argv[1]), Path(sys.argv[2])
    if "--host-network" not in sys.argv[3:]:  # else: no namespace allowed, ports checked free
        loopback_up()
    blocks = [b for b in all_blocks() if b.kind == "run"]
    report: dict[str, list[dict[str, str]]] = {}
    running: dict[str, Background] = {}
    for i, block in enumerate(blocks):
        results = run_block(block, scratch, running)
        nxt = blocks[i + 1] if i + 1 < len(blocks) else None
        if nxt is None or not nxt.cont:
            stop_all(running, results)
        report[block.id] = results
    out.write_text(json.dumps(report, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

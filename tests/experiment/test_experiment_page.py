"""`stiction experiment run` with a person's page in real headless Chromium.

The daemon is real (live clock) on the steered synthetic pen; the test plays
the participant: it strokes the pen (written to the daemon's stdin) when the
page asks for a stimulus and clicks the answer buttons. The page must work,
the rows must land on disk, the experimenter must be able to pause, and
nothing the page shows or receives may name the condition.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "clients"))

from stiction.clients import control
from stiction.drivers.fake.feed import format_state
from stiction.drivers.fake.strokes import DT, PenState, _min_jerk
from stiction.experiment import data
from stiction.experiment.live import LiveRunner, serve
from stiction.experiment.observer import SURFACE_M
from stiction.experiment.runner import Session
from stiction.experiment.stimulus import scene_toml
from stiction.experiment.study import Study, load_study

DAEMON = [
    sys.executable,
    "-c",
    "import sys; from stiction.daemon.main import main; sys.exit(main())",
]

pytestmark = pytest.mark.browser
pytest_plugins = ["clients_fixtures"]  # the headless Chromium `browser` of the client tests

PARK = (0.01, 0.01)
WAIT_MS = 30_000


class Pen:
    """The participant's hand: pen states written to the daemon's stdin, in real time."""

    def __init__(self, stdin: IO[bytes]) -> None:
        self.stdin = stdin
        self.t0 = time.monotonic()
        self.t = 0.0
        self.write([PenState(0.0, *PARK, False, True, 0.0)])

    def write(self, states: list[PenState]) -> None:
        self.stdin.write("".join(format_state(s) for s in states).encode())
        self.stdin.flush()
        self.t = states[-1].t

    def stroke(self) -> None:
        """Hover to the dot, touch, drag 25 mm right, lift and go back to park."""
        t = max(self.t, time.monotonic() - self.t0) + DT
        cx, cy = SURFACE_M[0] / 2, SURFACE_M[1] / 2
        out: list[PenState] = []

        def add(x: float, y: float, tip: bool) -> None:
            nonlocal t
            out.append(PenState(t, x, y, tip, True, 0.4 if tip else 0.0))
            t += DT

        for i in range(20):
            add(PARK[0] + (cx - PARK[0]) * i / 19, PARK[1] + (cy - PARK[1]) * i / 19, False)
        for _ in range(30):
            add(cx, cy, True)
        for i in range(1, 161):
            add(cx + 0.025 * _min_jerk(i / 160), cy, True)
        for _ in range(10):
            add(cx + 0.025, cy, False)
        for _ in range(10):
            add(*PARK, False)
        self.write(out)


class Runner:
    """`stiction experiment run`'s server in a thread with its own event loop."""

    def __init__(self, runner: LiveRunner) -> None:
        self.runner = runner
        self.loop = asyncio.new_event_loop()
        self.ready: asyncio.Future[str] = self.loop.create_future()
        self.task: asyncio.Task[None] | None = None
        self.thread = threading.Thread(target=self._main, daemon=True)
        self.thread.start()
        self.url = asyncio.run_coroutine_threadsafe(self._url(), self.loop).result(60)

    async def _url(self) -> str:
        return await self.ready

    def _main(self) -> None:
        asyncio.set_event_loop(self.loop)
        self.task = self.loop.create_task(
            serve(self.runner, "127.0.0.1", 0, ready=self.ready, announce=False)
        )
        with contextlib.suppress(asyncio.CancelledError):
            self.loop.run_until_complete(self.task)
        self.loop.close()

    def experimenter(self, action: str) -> dict[str, Any]:
        url = f"{self.url}experimenter?token={self.runner.token}&action={action}"
        req = urllib.request.Request(url, method="POST")
        with urllib.request.urlopen(req, timeout=10) as r:
            return dict(json.loads(r.read()))

    def stop(self) -> None:
        if self.task is not None:
            self.loop.call_soon_threadsafe(self.task.cancel)
        self.thread.join(30)


@contextlib.contextmanager
def experiment(study: Study, out: Path) -> Iterator[tuple[Pen, Runner, Session]]:
    d = Path(tempfile.mkdtemp(prefix="stc-"))
    pub, ctl = f"ipc://{d}/pub", f"ipc://{d}/ctl"
    scene = d / "scene.toml"
    scene.write_text(scene_toml(study, study.standard_mu_s, True))
    log = (d / "stictiond.log").open("wb")
    cmd = [*DAEMON,
           "--device", "synthetic:stdin", "--clock", "real", "--scene", str(scene),
           "--pub", pub, "--control", ctl, "--no-hotplug"]  # fmt: skip
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.DEVNULL, stderr=log)
    session = Session(study, "P01", out)
    runner: Runner | None = None
    try:
        for _ in range(120):
            try:
                control.request(ctl, "ping", timeout=0.5)
                break
            except control.ControlUnavailable:
                assert proc.poll() is None, "stictiond exited"
        # The daemon releases the pen's samples at their time stamps counted from the
        # first one; written only now, that one arrives when it is written, so from
        # here on a time stamp is the time since the pen was created.
        assert proc.stdin is not None
        pen = Pen(proc.stdin)
        runner = Runner(LiveRunner(session, pub, ctl))
        yield pen, runner, session
    finally:
        if runner is not None:
            runner.stop()
        session.close()
        if proc.stdin is not None:
            with contextlib.suppress(OSError):
                proc.stdin.close()
        proc.terminate()
        proc.wait(30)
        log.close()
        shutil.rmtree(d, ignore_errors=True)


def _wait_view(page: Any, condition: str) -> None:
    page.wait_for_function(
        f"() => {{ const v = window.experiment.view; return v && ({condition}); }}",
        timeout=WAIT_MS,
    )


def _stimulus(page: Any, pen: Pen, n: int) -> None:
    _wait_view(page, f"v.state === 'stimulus' && v.stimulus === {n} && v.ready")
    pen.stroke()


def test_a_2afc_trial_through_the_page(browser: Any, tmp_path: Path) -> None:
    study = load_study("paper-study1").with_repetitions(1)
    with experiment(study, tmp_path) as (pen, runner, session):
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        received: list[str] = []
        page.on("websocket", lambda ws: ws.on("framereceived", lambda p: received.append(str(p))))
        page.goto(runner.url)
        page.get_by_role("button", name="Start").click()
        _stimulus(page, pen, 1)
        page.wait_for_function("() => window.experiment.drawn > 2", timeout=WAIT_MS)
        _stimulus(page, pen, 2)
        _wait_view(page, "v.state === 'answer'")
        assert page.locator("#buttons button").all_inner_texts() == [
            "First surface",
            "Second surface",
        ]
        shown = page.inner_text("body")
        assert "Trial 1 of 12" in shown and "more frictional" in shown
        page.get_by_role("button", name="First surface").click()
        _wait_view(page, "v.trial === 2 && v.state === 'stimulus'")
        rows = data.read_trials([tmp_path / "P01.csv"])
        assert len(rows) == 1
        first = session.schedule[0]
        assert rows[0]["chose_comparison"] == int(first.comparison_first)
        assert rows[0]["response_time_s"] > 0
        # the experimenter pauses; the participant sees it and cannot answer
        assert runner.experimenter("pause")["state"] == "paused"
        _wait_view(page, "v.state === 'paused'")
        assert "Paused by the experimenter" in page.inner_text("body")
        assert page.locator("#buttons button").count() == 0
        assert runner.experimenter("resume")["state"] == "stimulus"
        _wait_view(page, "v.state === 'stimulus' && v.trial === 2")
        # a reloaded page picks up where the session is
        page.reload()
        _wait_view(page, "v.state === 'stimulus' && v.trial === 2")
        page.close()
    traffic = " ".join(received)
    assert '"view"' in traffic and '"pointer"' in traffic
    for word in ("mu_s", "mu0", "material", "nostring", "scene", "block", "comparison"):
        assert word not in traffic, word


def test_ratio_buttons_through_the_page(browser: Any, tmp_path: Path) -> None:
    study = load_study("paper-study2").with_repetitions(1)
    with experiment(study, tmp_path) as (pen, runner, _session):
        page = browser.new_page(viewport={"width": 1280, "height": 800})
        page.goto(runner.url)
        page.get_by_role("button", name="Start").click()
        _stimulus(page, pen, 1)
        _stimulus(page, pen, 2)
        _wait_view(page, "v.state === 'answer'")
        assert page.inner_text("#ratio") == "1.00"
        page.get_by_role("button", name="increase (+0.10)", exact=True).click()
        page.get_by_role("button", name="increase (+0.10)", exact=True).click()
        page.get_by_role("button", name="slightest decrease (-0.01)").click()
        _wait_view(page, "v.ratio === 1.19")
        assert page.inner_text("#ratio") == "1.19"
        page.get_by_role("button", name="Confirm").click()
        _wait_view(page, "v.trial === 2")
        (row,) = data.read_trials([tmp_path / "P01.csv"])
        assert row["ratio"] == pytest.approx(1.19)
        assert row["adjustments"] == "+0.10 +0.10 -0.01"
        page.close()

"""`stiction experiment simulate`: a whole study with simulated participants, headless.

Each participant gets their own real stictiond on the steered synthetic pen
(steered.py) and a `Session` exactly like a person's (runner.py): the
session asks for each stimulus's scene, which is applied through the
control socket between stimuli; the observer (observer.py) strokes the pen
until the session says the stimulus is over, and answers through
`Session.press`, the call the participant page makes. The files written are
those of `stiction experiment run`.

Time is virtual throughout: the daemon's clock follows the pen's sample
times, and the session's clock is that time plus the observer's simulated
thinking time, so response times are modelled, not measured.
"""

from __future__ import annotations

import hashlib
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

from stiction.errors import StictionError
from stiction.experiment.observer import Observer, ObserverParams, discrepancy
from stiction.experiment.runner import Session, step_label
from stiction.experiment.steered import SteeredDaemon
from stiction.experiment.stimulus import scene_toml
from stiction.experiment.study import Study

log = logging.getLogger("stiction.experiment.simulate")
MAX_STROKE_S = 10.0
STEP_SAMPLES = 4
"""Pen samples written per round trip (20 ms at 200 Hz): the observer's reaction grain."""


def _seed(*parts: object) -> int:
    text = "\0".join(str(p) for p in parts).encode()
    return int.from_bytes(hashlib.sha256(text).digest()[:8], "big")


def participant_ids(n: int) -> list[str]:
    width = max(2, len(str(n)))
    return [f"sim{i:0{width}d}" for i in range(1, n + 1)]


class _Clock:
    """The session's clock: the daemon's virtual time plus the observer's thinking."""

    def __init__(self, daemon: SteeredDaemon) -> None:
        self.daemon = daemon
        self.thinking = 0.0

    def __call__(self) -> float:
        return self.daemon.t + self.thinking


def _stimulus(daemon: SteeredDaemon, session: Session, observer: Observer) -> float:
    """Stroke until the session ends the current stimulus; the discrepancy shown."""
    st = session.stimulus
    assert st is not None
    shown: list[dict[str, Any]] = []
    for _attempt in range(5):
        stroke = observer.stroke(daemon.t)
        start = daemon.t
        shown.clear()

        def hook(frame: dict[str, Any], stroke: Any = stroke) -> None:
            if stroke.ended_at is None:
                shown.append(frame)
                if session.on_frame(frame):
                    stroke.end()

        daemon.on_frame = hook
        while not stroke.lifted:
            if stroke.ended_at is None and daemon.t - start > MAX_STROKE_S:
                stroke.end()  # never started (touched down off the dot): try again
            daemon.step([stroke.next() for _ in range(STEP_SAMPLES)])
        daemon.on_frame = None
        daemon.idle(0.2)
        if session.stimulus is not st or session.state != "stimulus":
            return discrepancy(shown)
    raise StictionError(
        f"the simulated participant could not complete a stimulus of {session.participant}"
    )


def _answer(session: Session, observer: Observer, shown: list[float], clock: _Clock) -> None:
    trial = session.trial
    assert trial is not None
    if session.study.method == "2afc":
        first = observer.choose_first(shown[0], shown[1], trial.string)
        clock.thinking += observer.response_time(1)
        session.press("first" if first else "second")
        return
    s_comp = shown[0 if trial.comparison_first else 1]
    s_std = shown[1 if trial.comparison_first else 0]
    target = observer.felt_ratio(s_std, s_comp)
    presses = observer.presses(target, session.study.ratio_start, session.study.steps)
    clock.thinking += observer.response_time(len(presses) + 1)
    for step in presses:
        session.press(step_label(step))
    session.press("confirm")


def simulate_participant(
    study: Study,
    participant: str,
    out: Path,
    *,
    seed: int,
    params: ObserverParams,
    record: bool = False,
    progress: Callable[[str], None] | None = None,
) -> Path:
    """Run (or continue) one simulated participant; returns their CSV path."""
    first = scene_toml(study, study.standard_mu_s, study.strings[0])
    with SteeredDaemon(first) as daemon:
        clock = _Clock(daemon)
        session = Session(
            study, participant, out, seed=_seed("schedule", seed, participant), clock=clock,
            record=record,
        )  # fmt: skip
        observer = Observer(params, _seed("observer", seed, participant))
        try:
            ping = daemon.request("ping")
            devices = daemon.request("devices")["devices"]
            dev = devices[0] if devices else {}
            session.describe(
                daemon_version=ping.get("version"),
                rate_hz=ping.get("rate"),
                device=dev.get("name"),
                device_spec=dev.get("spec"),
                device_size_m=dev.get("surface_m"),
                mapping=dev.get("mapping"),
                scene=daemon.request("get_scene")["scene"],
                clock="virtual",
                simulated=True,
                observer={k: getattr(params, k) for k in params.__slots__},
            )
            if session.state == "instructions":
                session.press("start")
            shown = [0.0, 0.0]
            while session.state != "done":
                scene = session.pending_scene()
                if scene is not None:
                    daemon.request("set_scene", toml=scene)
                    session.scene_applied()
                    continue
                if session.state == "stimulus":
                    assert session.stimulus is not None
                    index = session.stimulus.index
                    shown[index] = _stimulus(daemon, session, observer)
                elif session.state == "answer":
                    _answer(session, observer, shown, clock)
                    if progress is not None and session.position % 10 == 0:
                        progress(f"{participant}: {session.position}/{len(session.schedule)}")
                else:
                    raise StictionError(f"unexpected session state {session.state!r}")
        finally:
            session.close()
    return session.csv


def simulate_study(
    study: Study,
    out: Path,
    participants: int,
    *,
    seed: int = 0,
    params: ObserverParams | None = None,
    record: bool = False,
    progress: Callable[[str], None] | None = None,
) -> list[Path]:
    """Every participant in turn; already complete participants are left as they are."""
    if participants < 1:
        raise StictionError(f"--participants must be at least 1, got {participants}")
    p = params or ObserverParams()
    return [
        simulate_participant(study, pid, out, seed=seed, params=p, record=record, progress=progress)
        for pid in participant_ids(participants)
    ]

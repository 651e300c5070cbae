"""One participant's session: the state machine between the daemon's frames and the answers.

The session knows nothing about sockets or pages. A driver (live.py for a
person at a real device, simulate.py for the simulated observer) applies
the scene the session asks for, hands it every frame, and relays the
presses of answer buttons; both drivers therefore run the very same
protocol, and the simulated participant answers through the same `press`
a person's page calls.

States: ``instructions`` -> (``stimulus`` 1, ``stimulus`` 2, ``answer``) per
trial -> ``done``; ``paused`` from anywhere until resumed. A trial's row is
written (and flushed) when its answer is confirmed; a pause, a crash or a
closed page loses at most the trial in progress, which starts over.
"""

from __future__ import annotations

import datetime
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stiction import __version__
from stiction.errors import StictionError
from stiction.experiment import data
from stiction.experiment.schedule import Trial, make_schedule, participant_index, participant_seed
from stiction.experiment.stimulus import StimulusMonitor, scene_toml
from stiction.experiment.study import Study

PARTICIPANT_CHARS = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789-_.")


class AnswerError(StictionError):
    """A button that does not exist, or is not offered now."""


def check_participant(pid: str) -> str:
    if not pid or len(pid) > 64 or not set(pid) <= PARTICIPANT_CHARS or pid.startswith("."):
        raise StictionError(
            f"participant ID {pid!r}: use 1-64 letters, digits, '-', '_' or '.' (it names files)"
        )
    return pid


def _now_iso() -> str:
    return datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds")


def step_label(step: float) -> str:
    return f"{step:+.2f}"


@dataclass
class Stimulus:
    """The stimulus being shown: which one of the trial, and its monitor."""

    index: int  # 0 or 1: first or second of the trial
    comparison: bool
    monitor: StimulusMonitor
    applied: bool = False


class Session:
    """The protocol of one participant, resumable from their files."""

    def __init__(
        self,
        study: Study,
        participant: str,
        out: Path,
        *,
        seed: int | None = None,
        clock: Callable[[], float] = time.monotonic,
        record: bool = False,
    ) -> None:
        self.study = study
        self.participant = check_participant(participant)
        self.out = out
        self.clock = clock
        self.record = record
        out.mkdir(parents=True, exist_ok=True)
        self.csv = data.csv_path(out, participant)
        self.sidecar_file = data.sidecar_path(out, participant)
        self.sidecar = self._open_sidecar(seed)
        self.seed = int(self.sidecar["seed"])
        self.schedule = make_schedule(study, participant, self.seed)
        self.position = data.completed(self.csv)
        if self.position > len(self.schedule):
            raise data.DataError(
                f"{self.csv}: {self.position} trials, more than the study's {len(self.schedule)}"
            )
        self.writer = data.TrialWriter(self.csv)
        self.state = "instructions" if self.position < len(self.schedule) else "done"
        self._paused_from: str | None = None
        self.stimulus: Stimulus | None = None
        self.measures: list[dict[str, float | None]] = []
        self.ratio = study.ratio_start
        self.adjustments: list[str] = []
        self.answer_t = 0.0
        self.frames_file = out / f"{participant}.frames.jsonl" if record else None

    # ------------------------------------------------------------ files
    def _open_sidecar(self, seed: int | None) -> dict[str, Any]:
        if self.sidecar_file.exists():
            old = data.read_sidecar(self.sidecar_file)
            if old.get("study") != self.study.name:
                raise data.DataError(
                    f"{self.sidecar_file}: belongs to study {old.get('study')!r}, "
                    f"not {self.study.name!r}; use another --out folder"
                )
            if seed is not None and int(old.get("seed", -1)) != seed:
                raise data.DataError(
                    f"{self.sidecar_file}: recorded seed {old.get('seed')} differs from --seed "
                    f"{seed}; a resumed session keeps its seed"
                )
            old.setdefault("resumed", []).append(_now_iso())
            old["end_time"] = None
            data.write_sidecar(self.sidecar_file, old)
            return old
        info: dict[str, Any] = {
            "software": f"stiction {__version__}",
            "study": self.study.name,
            "study_file": self.study.source,
            "method": self.study.method,
            "participant": self.participant,
            "counterbalance_index": participant_index(self.participant),
            "seed": participant_seed(self.study, self.participant) if seed is None else seed,
            "repetitions": self.study.repetitions,
            "trials": self.study.n_trials,
            "display": list(self.study.display),
            "params": dict(self.study.params),
            "start_time": _now_iso(),
            "end_time": None,
            "resumed": [],
        }
        data.write_sidecar(self.sidecar_file, info)
        return info

    def describe(self, **environment: Any) -> None:
        """Add what the driver knows (daemon version, device and size, scene) to the sidecar."""
        self.sidecar.update(environment)
        data.write_sidecar(self.sidecar_file, self.sidecar)

    def close(self) -> None:
        self.writer.close()

    # ------------------------------------------------------------ protocol
    @property
    def trial(self) -> Trial | None:
        return self.schedule[self.position] if self.position < len(self.schedule) else None

    def _begin_stimulus(self, index: int) -> None:
        trial = self.trial
        assert trial is not None
        w, h = self.study.display
        monitor = StimulusMonitor(
            (w / 2, h / 2), self.study.start_tolerance_px, self.study.travel_px, self.record
        )
        comparison = trial.comparison_first == (index == 0)
        self.stimulus = Stimulus(index, comparison, monitor)
        self.state = "stimulus"

    def _begin_trial(self) -> None:
        self.measures = []
        self.ratio = self.study.ratio_start
        self.adjustments = []
        self._begin_stimulus(0)

    def pending_scene(self) -> str | None:
        """The scene to apply before the current stimulus, or None (applied, or none due)."""
        st = self.stimulus
        trial = self.trial
        if self.state != "stimulus" or st is None or st.applied or trial is None:
            return None
        mu = trial.comparison_mu_s if st.comparison else self.study.standard_mu_s
        return scene_toml(self.study, mu, trial.string)

    def scene_applied(self) -> None:
        if self.stimulus is not None:
            self.stimulus.applied = True

    @property
    def awaiting_pen(self) -> bool:
        """A stimulus is armed: the participant should stroke now."""
        return self.state == "stimulus" and self.stimulus is not None and self.stimulus.applied

    def on_frame(self, frame: dict[str, Any]) -> bool:
        """Take a frame; True when it ended the current stimulus."""
        st = self.stimulus
        if not self.awaiting_pen or st is None:
            return False
        if not st.monitor.feed(frame):
            return False
        self._save_frames(st)
        self.measures.append(st.monitor.measures())
        if st.index == 0:
            self._begin_stimulus(1)
        else:
            self.state = "answer"
            self.answer_t = self.clock()
        return True

    def _save_frames(self, st: Stimulus) -> None:
        if self.frames_file is None or self.trial is None:
            return
        import json

        with open(self.frames_file, "a", encoding="utf-8") as f:
            for fr in st.monitor.frames:
                line = {"trial": self.trial.number, "stimulus": st.index + 1, "frame": fr}
                f.write(json.dumps(line) + "\n")

    def buttons(self) -> list[str]:
        if self.state == "instructions":
            return ["start"]
        if self.state != "answer":
            return []
        if self.study.method == "2afc":
            return ["first", "second"]
        return [step_label(s) for s in self.study.steps] + ["confirm"]

    def press(self, button: str) -> None:
        """A participant's button press (from the page, or the simulated observer)."""
        offered = self.buttons()
        if button not in offered:
            now = ", ".join(offered) or "none"
            raise AnswerError(f"button {button!r} is not offered now (state {self.state}; {now})")
        if self.state == "instructions":
            self._begin_trial()
        elif button == "confirm":
            self._finish(None)
        elif self.study.method == "ratio":
            step = float(button)
            self.ratio = max(0.0, round(self.ratio + step, 6))
            self.adjustments.append(button)
        else:
            self._finish(button == "first")

    def _finish(self, chose_first: bool | None) -> None:
        trial = self.trial
        assert trial is not None
        rt = self.clock() - self.answer_t
        comp = self.measures[0 if trial.comparison_first else 1]
        std = self.measures[1 if trial.comparison_first else 0]
        p = self.study.params
        row: dict[str, Any] = {
            "participant": self.participant,
            "study": self.study.name,
            "method": self.study.method,
            "trial": trial.number,
            "block": trial.block,
            "condition": trial.condition,
            "string": trial.string,
            "standard_mu_s": self.study.standard_mu_s,
            "comparison_mu_s": trial.comparison_mu_s,
            "mu_k": p["mu_k"],
            "k": p["k"],
            "c_l": p["C_l"],
            "comparison_first": trial.comparison_first,
            "chose_comparison": None
            if chose_first is None
            else chose_first == trial.comparison_first,
            "ratio": round(self.ratio, 4) if self.study.method == "ratio" else None,
            "adjustments": " ".join(self.adjustments),
            "response_time_s": rt,
        }
        row.update(comp)
        row.update({f"std_{k}": v for k, v in std.items()})
        self.writer.write(row)
        self.position += 1
        if self.position >= len(self.schedule):
            self.state = "done"
            self.stimulus = None
            self.sidecar["end_time"] = _now_iso()
            data.write_sidecar(self.sidecar_file, self.sidecar)
        else:
            self._begin_trial()

    # ------------------------------------------------------------ experimenter
    def pause(self) -> None:
        if self.state in ("paused", "done"):
            return
        self._paused_from = self.state
        self.state = "paused"

    def resume(self) -> None:
        """Back from a pause; a trial interrupted mid-stimulus starts over (its first half
        would otherwise be compared with a second half seen minutes later)."""
        if self.state != "paused":
            return
        was, self._paused_from = self._paused_from, None
        if was == "stimulus":
            self._begin_trial()
        elif was == "answer":
            self.state = "answer"
        else:
            self.state = was or "instructions"

    def view(self) -> dict[str, Any]:
        """What the participant's page shows. Never the condition: no mu_s, no block name."""
        st = self.stimulus
        v: dict[str, Any] = {
            "state": self.state,
            "trial": min(self.position + 1, len(self.schedule)),
            "trials": len(self.schedule),
            "buttons": self.buttons(),
        }
        if self.state == "instructions":
            v["text"] = self.study.instructions
        elif self.state == "stimulus" and st is not None:
            v["stimulus"] = st.index + 1
            v["ready"] = st.applied
        elif self.state == "answer":
            v["question"] = self.study.question
            if self.study.method == "ratio":
                v["ratio"] = round(self.ratio, 2)
        elif self.state == "done":
            v["text"] = "Thank you. The session is complete."
        elif self.state == "paused":
            v["text"] = "Paused by the experimenter. Please wait."
        return v

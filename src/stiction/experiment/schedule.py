"""The order of a participant's trials: random, reproducible from a seed, counterbalanced.

Why this shape:

- **Reproducible.** Everything random comes from one `random.Random(seed)`;
  the seed is written to the participant's sidecar, so a resumed session
  (or an auditor) rebuilds exactly the same list.
- **Counterbalanced across participants.** Blocks (one per string
  condition) follow a Latin-square rotation by the participant's index, so
  with two blocks half the participants start with the string and half
  without. With an odd number of repetitions, which half of a condition's
  trials gets the extra comparison-first presentation alternates with the
  index too.
- **Random within a block, but spread.** Each repetition is a shuffled round
  of every comparison value, so a value never bunches at the start or end of
  a block (a common way to keep fatigue from confounding a condition).
"""

from __future__ import annotations

import hashlib
import random
import re
from dataclasses import dataclass

from stiction.experiment.study import Study


@dataclass(frozen=True, slots=True)
class Trial:
    number: int  # 1-based over the whole session
    block: int  # 1-based
    string: bool
    comparison_mu_s: float
    comparison_first: bool

    @property
    def condition(self) -> str:
        return condition_id(self.comparison_mu_s, self.string)


def condition_id(mu_s: float, string: bool) -> str:
    return f"mu{mu_s:g}-{'string' if string else 'nostring'}"


def participant_index(participant: str) -> int:
    """The counterbalancing index: the ID's trailing number (P07 -> 7), else a stable hash.

    Numbered IDs are the usual practice and make the rotation visible to the
    experimenter; the hash keeps any other ID deterministic.
    """
    m = re.search(r"(\d+)$", participant)
    if m:
        return int(m.group(1))
    return int.from_bytes(hashlib.sha256(participant.encode()).digest()[:4], "big")


def participant_seed(study: Study, participant: str) -> int:
    """The seed of one participant's order, derived from the study's seed and the ID."""
    text = f"{study.name}\0{study.seed}\0{participant}".encode()
    return int.from_bytes(hashlib.sha256(text).digest()[:8], "big")


def block_order(study: Study, index: int) -> list[bool]:
    """The string conditions in the order this participant meets them."""
    blocks = list(study.strings)
    if study.block_order == "fixed":
        return blocks
    shift = index % len(blocks)
    return blocks[shift:] + blocks[:shift]


def _first_flags(study: Study, index: int, rng: random.Random) -> list[bool]:
    n = study.repetitions
    if study.comparison_first == "always":
        return [True] * n
    if study.comparison_first == "never":
        return [False] * n
    half = n // 2 + (n % 2 if index % 2 == 0 else 0)
    flags = [True] * half + [False] * (n - half)
    rng.shuffle(flags)
    return flags


def make_schedule(study: Study, participant: str, seed: int | None = None) -> list[Trial]:
    """Every trial of one participant, in order. Same inputs, same list."""
    index = participant_index(participant)
    rng = random.Random(participant_seed(study, participant) if seed is None else seed)
    trials: list[Trial] = []
    for b, string in enumerate(block_order(study, index), start=1):
        flags = {mu: _first_flags(study, index, rng) for mu in study.comparison_mu_s}
        for rep in range(study.repetitions):
            round_ = list(study.comparison_mu_s)
            rng.shuffle(round_)
            for mu in round_:
                trials.append(Trial(len(trials) + 1, b, string, mu, flags[mu][rep]))
    return trials

"""Trial order: the same from the same seed, random across seeds, counterbalanced."""

from __future__ import annotations

from collections import Counter

from stiction.experiment.schedule import make_schedule, participant_index
from stiction.experiment.study import load_study


def test_same_participant_same_order() -> None:
    s = load_study("paper-study1")
    assert make_schedule(s, "P01") == make_schedule(s, "P01")
    assert make_schedule(s, "P01", seed=5) == make_schedule(s, "P01", seed=5)


def test_seed_changes_the_order_but_not_the_content() -> None:
    s = load_study("paper-study1")
    a, b = make_schedule(s, "P01", seed=1), make_schedule(s, "P01", seed=2)
    assert [t.condition for t in a] != [t.condition for t in b]
    assert Counter(t.condition for t in a) == Counter(t.condition for t in b)


def test_every_condition_repeated_as_the_study_says() -> None:
    s = load_study("paper-study1")
    trials = make_schedule(s, "P01")
    assert len(trials) == 120
    assert [t.number for t in trials] == list(range(1, 121))
    counts = Counter(t.condition for t in trials)
    assert set(counts.values()) == {10} and len(counts) == 12
    # each repetition is a round of every value: no value twice before all have come
    block1 = [t.comparison_mu_s for t in trials if t.block == 1]
    for r in range(10):
        assert sorted(block1[6 * r : 6 * r + 6]) == sorted(s.comparison_mu_s)


def test_blocks_are_counterbalanced_across_participants() -> None:
    s = load_study("paper-study1")
    firsts = Counter(make_schedule(s, f"P{i:02d}")[0].string for i in range(1, 11))
    assert firsts == {True: 5, False: 5}
    for pid in ("P01", "P02"):
        trials = make_schedule(s, pid)
        assert {t.string for t in trials if t.block == 1} != {
            t.string for t in trials if t.block == 2
        }


def test_presentation_order_is_balanced() -> None:
    s = load_study("paper-study1")
    for pid in ("P01", "P02"):
        trials = make_schedule(s, pid)
        per = Counter((t.condition, t.comparison_first) for t in trials)
        assert all(n == 5 for n in per.values())
    odd = s.with_repetitions(5)
    extra = [
        sum(t.comparison_first for t in make_schedule(odd, pid) if t.condition == "mu0.4-string")
        for pid in ("P01", "P02")
    ]
    assert sorted(extra) == [2, 3]  # the extra presentation alternates between participants


def test_study2_always_shows_the_standard_first() -> None:
    s = load_study("paper-study2")
    trials = make_schedule(s, "P03")
    assert len(trials) == 35 and not any(t.comparison_first for t in trials)


def test_participant_index_uses_the_ids_number() -> None:
    assert participant_index("P07") == 7
    assert participant_index("sim12") == 12
    assert participant_index("anna") == participant_index("anna")

"""The figures docs/experiments.md derives from the paper's A, B and JND are right."""

from __future__ import annotations

from pathlib import Path

from stiction.experiment import psychometric as ps

PAGE = Path(__file__).resolve().parents[2] / "docs" / "experiments.md"
# As printed in the paper (User study 1, Results).
PAPER = {"string": (0.068, 4.9, 0.29), "no string": (0.25, 2.1, 0.77)}


def _words() -> str:
    return " ".join(PAGE.read_text().split())


def test_jnd_implied_by_the_printed_slopes() -> None:
    text = _words()
    for a, _, jnd in PAPER.values():
        assert f"{ps.LN3 / a:.3g}" in text  # the JND the printed slope implies
        assert f"{ps.LN3 / jnd:.3g}" in text  # the slope the printed JND needs


def test_printed_curves_over_the_tested_range() -> None:
    text = _words()
    for label, (a, b, _) in PAPER.items():
        lo, hi = (float(ps.logistic(x, a, b)) for x in (0.0, 1.0))
        assert f"from {lo:.3f} to {hi:.3f}" in text, label


def test_no_common_rescaling_reconciles_them() -> None:
    text = _words()
    slope_ratio = PAPER["no string"][0] / PAPER["string"][0]
    jnd_ratio = PAPER["string"][2] / PAPER["no string"][2]
    # A rescaled axis x = c mu_s + d scales both JNDs by 1/c: their ratio stays
    # A_without/A_with, which the page sets against the printed JNDs' ratio.
    assert f"A_without/A_with = {slope_ratio:.3g}" in text
    assert f"{PAPER['string'][2]}/{PAPER['no string'][2]} = {jnd_ratio:.3g}" in text

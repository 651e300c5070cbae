"""Study files: the presets are the paper's studies, and bad files are clear errors (exit 2)."""

from __future__ import annotations

from pathlib import Path

import pytest

from stiction.cli import main
from stiction.experiment.study import PRESETS, StudyError, load_study, parse_study

PAPER = Path(__file__).resolve().parents[2].parent / "shared" / "seeds"


def test_study1_preset_is_the_papers_first_study() -> None:
    s = load_study("paper-study1")
    assert s.method == "2afc"
    assert s.standard_mu_s == 0.0
    assert s.comparison_mu_s == (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
    assert set(s.strings) == {True, False}
    assert s.repetitions == 10
    assert s.trials_per_block == 60  # "60 trials with and without the virtual string"
    assert s.travel_px == 70.0
    assert s.params["k"] == 0.1 and s.params["mu_k"] == 0.1
    assert s.params["C_l"] == 2000.0 and s.params["g"] == 9.8
    assert s.display == (2880, 1800)
    assert s.comparison_first == "balanced"


def test_study2_preset_is_the_papers_second_study() -> None:
    s = load_study("paper-study2")
    assert s.method == "ratio"
    assert s.standard_mu_s == 0.7
    assert s.comparison_mu_s == (0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
    assert s.strings == (True,)
    assert s.n_trials == 35
    assert s.ratio_start == 1.0
    assert s.steps == (-0.10, -0.05, -0.01, 0.01, 0.05, 0.10)
    assert s.comparison_first == "never"  # "initially ... standard, subsequently ... comparison"


def test_presets_quote_the_papers_numbers() -> None:
    """The preset values are the paper's text, not a copy of these tests."""
    tex = (PAPER / "static-friction-pseudo-haptics.tex").read_text()
    assert "0.0, 0.2, 0.4, 0.6, 0.8, or 1.0" in tex
    assert "0.4, 0.5, 0.6, 0.7, 0.8, 0.9, or 1.0" in tex
    assert "moved 70 pixels from the center" in tex
    assert "$g = 9.8 m/s^2$, $k = 0.1 N/m$, $\\mu_k = 0.1$, and $C_l = 2000$" in tex
    assert set(PRESETS) == {"paper-study1", "paper-study2"}


MINIMAL = """
[study]
method = "2afc"
repetitions = 2
[standard]
mu_s = 0.0
[comparison]
mu_s = [0.0, 0.5]
"""


def test_minimal_study_takes_the_papers_defaults() -> None:
    s = parse_study(MINIMAL, "mine.toml")
    assert s.name == "mine"
    assert s.params == {"k": 0.1, "mu_k": 0.1, "C_l": 2000.0, "m": 1e-4, "g": 9.8}
    assert s.n_trials == 4


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[study\n", "not valid TOML"),
        (MINIMAL.replace('"2afc"', '"3afc"'), "study.method: must be one of 2afc, ratio"),
        (MINIMAL.replace("repetitions = 2", "repetitions = 0"), "study.repetitions"),
        (
            MINIMAL.replace("repetitions = 2", 'repetitions = "2"'),
            "study.repetitions: must be a int",
        ),
        (MINIMAL + "[params]\nk = -1\n", "params.k: must be at least"),
        (MINIMAL + "[params]\nkk = 1\n", "params.kk: unknown key"),
        (MINIMAL + "[bogus]\n", "bogus: unknown table"),
        (MINIMAL.replace("[0.0, 0.5]", "[]"), "comparison.mu_s: needs at least one value"),
        (MINIMAL.replace("[0.0, 0.5]", "[0.5, 0.5]"), "comparison.mu_s: has repeated values"),
        (MINIMAL.replace("[0.0, 0.5]", "[0.0, -1]"), "comparison.mu_s[1]: must be between"),
        (MINIMAL + "[task]\ndisplay = [10]\n", "task.display"),
        (MINIMAL + "[conditions]\nstring = [1]\n", "conditions.string"),
        (MINIMAL + "[order]\ncomparison_first = 'often'\n", "order.comparison_first"),
        (MINIMAL + "[answer]\nsteps = [0.1]\n", "belong to method 'ratio'"),
        (MINIMAL.replace("[standard]\nmu_s = 0.0\n", ""), "standard: missing table"),
    ],
)
def test_bad_study_is_one_clear_error(text: str, message: str) -> None:
    with pytest.raises(StudyError) as info:
        parse_study(text, "bad.toml")
    assert str(info.value).startswith("bad.toml")
    assert message in str(info.value)


def test_cli_exits_2_on_a_bad_study(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(MINIMAL.replace('"2afc"', '"3afc"'))
    assert main(["experiment", "check", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("stiction: error: ")
    assert "study.method" in err and "Traceback" not in err
    assert main(["experiment", "check", str(tmp_path / "none.toml")]) == 2
    assert "no such study file" in capsys.readouterr().err
    assert main(["experiment", "check", str(tmp_path)]) == 2  # a directory
    assert "not a regular file" in capsys.readouterr().err


def test_cli_check_shows_a_preset(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["experiment", "check", "paper-study1", "--repetitions", "3"]) == 0
    out = capsys.readouterr().out
    assert "18 trials per block, 36 in all" in out


def test_the_docs_show_the_preset_as_it_is() -> None:
    """docs/experiments.md quotes paper-study2's file in full; the quote must not drift."""
    import re

    doc = (Path(__file__).resolve().parents[2] / "docs" / "experiments.md").read_text()
    (block,) = [b for b in re.findall(r"```toml\n(.*?)```", doc, re.S) if "paper-study2" in b]
    quoted = parse_study(block, "paper-study2")
    assert quoted == load_study("paper-study2")


def test_a_study_error_names_the_line_and_the_key_it_meant() -> None:
    text = MINIMAL + "[params]\nkk = 1\n"
    line = text.count("\n")  # kk is the last line
    with pytest.raises(StudyError) as info:
        parse_study(text, "bad.toml")
    assert str(info.value).startswith(f"bad.toml:{line}: params.kk: unknown key; did you mean 'k'?")


def test_a_study_nested_thousands_deep_is_one_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    deep = tmp_path / "deep.toml"  # tomllib recursed until RecursionError: a traceback
    deep.write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    assert main(["experiment", "check", str(deep)]) == 2
    err = capsys.readouterr().err
    assert "nested too deeply" in err and "Traceback" not in err


def test_repetitions_from_the_command_line_have_the_files_bound(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """--repetitions bypassed MAX_TRIALS: a study of 1.2e12 trials was 'checked' fine."""
    assert main(["experiment", "check", "paper-study1", "--repetitions", "99999999999"]) == 2
    assert "at most 10000" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # an argument error: argparse exits 2 itself
        main(["experiment", "simulate", "paper-study1", "--participants", "99999", "--out", "x"])
    assert "argument --participants: must be at most 1000" in capsys.readouterr().err

"""`stiction experiment analyze` and `power`: the --json schema, the report, and clear errors.

The commands are registered by the experiment CLI through
`stats_cli.register(sub)`; these tests build the same subparsers and run
them with stiction.cli's error handling (a `StictionError` is one line on
stderr and exit status 2; argparse errors exit 2 as well).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import pytest
from expstats_synth import COLUMNS, study1, study2

from stiction.errors import StictionError
from stiction.experiment import stats_cli


def run(argv: list[str], capsys: pytest.CaptureFixture[str]) -> tuple[int, str, str]:
    parser = argparse.ArgumentParser(prog="stiction experiment")
    sub = parser.add_subparsers(dest="command")
    stats_cli.register(sub)
    try:
        args = parser.parse_args(argv)
        code = int(args.func(args) or 0)
    except StictionError as exc:
        print(f"stiction: error: {exc}", file=__import__("sys").stderr)
        code = 2
    except SystemExit as exc:  # argparse
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def data(tmp_path_factory: pytest.TempPathFactory) -> Path:
    d = tmp_path_factory.mktemp("data")
    study1(d, pse=0.2, jnd=0.1, participants=4, reps=6, lapse=0.02)
    study2(d, k=1.1, beta=0.2, participants=5, reps=3)
    return d


def test_analyze_json_schema_and_report(
    data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, out, err = run(
        ["analyze", str(data), "--out", str(tmp_path / "rep"), "--json", "--bootstrap", "100"],
        capsys,
    )
    assert code == 0, err
    results: list[dict[str, Any]] = json.loads(out)
    s1 = [r for r in results if r["method"] == "2afc"]
    s2 = [r for r in results if r["method"] == "ratio"]
    assert sorted(r["string"] for r in s1) == [0, 1]
    for r in s1:
        assert r["study"] == "paper-study1"
        for key in ("pse", "jnd", "a", "b"):
            assert isinstance(r[key], float)
            lo, hi = r[f"{key}_ci"]
            assert lo <= r[key] <= hi
    (r2,) = s2
    assert set(r2["anova"]) >= {"f", "df1", "df2", "p"}
    assert (r2["anova"]["df1"], r2["anova"]["df2"]) == (6, 24) or r2["anova"]["correction"]
    assert set(r2["stevens"]) >= {"k", "beta"}
    report = (tmp_path / "rep" / "report.md").read_text()
    assert "JND" in report and "Mauchly" in report and "Stevens" in report
    pngs = sorted(p.name for p in (tmp_path / "rep").glob("*.png"))
    assert len(pngs) == 2
    for name in pngs:
        assert f"]({name})" in report
        assert (tmp_path / "rep" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert json.loads((tmp_path / "rep" / "results.json").read_text()) == results


def test_analyze_text_summary_names_the_report(
    data: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    csv = sorted(data.glob("p*.csv"))[0]
    code, out, _ = run(["analyze", str(csv), "--out", str(tmp_path), "--bootstrap", "20"], capsys)
    assert code == 0
    assert "JND" in out and f"report: {tmp_path / 'report.md'}" in out


def _bad(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


GOOD_ROW = dict.fromkeys(COLUMNS, "") | {
    "participant": "p1",
    "study": "s",
    "method": "2afc",
    "string": "1",
    "comparison_mu_s": "0.4",
    "chose_comparison": "1",
}


def _csv(rows: list[dict[str, str]], header: list[str] = COLUMNS) -> str:
    lines = [",".join(header)]
    lines += [",".join(str(r.get(c, "")) for c in header) for r in rows]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "empty file"),
        (_csv([], ["participant", "study", "method"]), "missing column(s) string, comparison_mu_s"),
        (_csv([]), "a header but no trial rows"),
        (_csv([GOOD_ROW | {"comparison_mu_s": "abc"}]), "comparison_mu_s must be a number"),
        (_csv([GOOD_ROW | {"comparison_mu_s": "nan"}]), "comparison_mu_s must be finite"),
        (_csv([GOOD_ROW | {"chose_comparison": "2"}]), "chose_comparison must be 0 or 1"),
        (_csv([GOOD_ROW | {"string": "yes"}]), "string must be 0 or 1"),
        (_csv([GOOD_ROW | {"method": "staircase"}]), "method must be one of 2afc, ratio"),
        (_csv([GOOD_ROW | {"method": "ratio", "ratio": "-1"}]), "ratio must be positive"),
        (_csv([GOOD_ROW]) + "p1,s\n", "columns in the header, not in this row"),
        (_csv([GOOD_ROW] * 3), "at least 3"),
        ("\x00\x01garbage\n\x02", "missing column"),
    ],
)
def test_malformed_csv_is_one_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    path = _bad(tmp_path, "bad.csv", text)
    code, _, err = run(["analyze", str(path), "--out", str(tmp_path / "o")], capsys)
    assert code == 2
    assert err.startswith("stiction: error: ") and message in err
    assert "Traceback" not in err and err.count("\n") == 1


def test_a_spreadsheet_saved_csv_is_read(data: Path, tmp_path: Path) -> None:
    # Byte-order mark and CRLF line ends, as spreadsheet programs save CSV.
    from stiction.experiment.trials import read_file

    src = sorted(data.glob("p*.csv"))[0]
    saved = tmp_path / "saved.csv"
    saved.write_bytes(b"\xef\xbb\xbf" + src.read_bytes().replace(b"\n", b"\r\n"))
    assert read_file(saved) == read_file(src)


def test_missing_paths_and_empty_directories_are_clear_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run(["analyze", str(tmp_path / "nope"), "--out", str(tmp_path)], capsys)
    assert code == 2 and "no such file or directory" in err
    (tmp_path / "p01.json").write_text("{}")
    code, _, err = run(["analyze", str(tmp_path / "p01.json"), "--out", str(tmp_path)], capsys)
    assert code == 2 and "a session sidecar, not trial data" in err
    (tmp_path / "empty").mkdir()
    code, _, err = run(["analyze", str(tmp_path / "empty"), "--out", str(tmp_path)], capsys)
    assert code == 2 and "no .csv trial files" in err


def test_ratio_study_with_a_missing_level_is_a_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    paths = study2(tmp_path, k=1.1, beta=0.2, participants=4, reps=1)
    text = paths[0].read_text().splitlines()
    paths[0].write_text("\n".join(line for line in text if ",0.4," not in line) + "\n")
    code, _, err = run(["analyze", str(tmp_path), "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and "lack some mu_s level" in err


def test_power_json_schema(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(
        [
            "power",
            "paper-study1",
            "--participants",
            "2,10",
            "--repetitions",
            "5",
            "--simulations",
            "100",
            "--json",
        ],
        capsys,
    )
    assert code == 0, err
    res = json.loads(out)
    assert res["levels"] == [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    assert res["observer"] == {"pse": 0.2, "jnd": 0.1, "guess": 0.0, "lapse": 0.02}
    rows = res["design"]
    assert [(r["participants"], r["repetitions"]) for r in rows] == [(2, 5), (10, 5)]
    # More participants, smaller error: the simulation must see the difference.
    assert rows[0]["jnd_error95"] is None or rows[0]["jnd_error95"] > rows[1]["jnd_error95"]
    assert res["compare"] == []


def test_power_compare_reports_every_method(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = run(
        [
            "power",
            "paper-study1",
            "--participants",
            "10",
            "--repetitions",
            "10",
            "--simulations",
            "50",
            "--compare",
            "--max-trials",
            "12",
            "--quest-simulations",
            "2",
            "--json",
        ],
        capsys,
    )
    assert code == 0, err
    curves = json.loads(out)["compare"]
    assert [c["method"] for c in curves] == [
        "constant stimuli, ML fit",
        "constant stimuli, Bayes",
        "QUEST+",
    ]
    assert all(c["trials"] == [6, 12] for c in curves)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["power", "no-such-study"], "no such study file (or preset; presets: paper-study1"),
        (["power", "paper-study2"], "this one is ratio"),
        (["power", "paper-study1", "--jnd", "0"], "must be a positive number"),
        (["power", "paper-study1", "--lapse", "0.7"], "must be in [0, 0.5)"),
        (["power", "paper-study1", "--participants", "0,3"], "at least 1"),
    ],
)
def test_power_bad_input_is_a_clear_error(
    capsys: pytest.CaptureFixture[str], argv: list[str], message: str
) -> None:
    code, _, err = run(argv, capsys)
    assert code == 2 and message in err and "Traceback" not in err


def test_power_reads_a_study_toml(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # The study-file schema of docs/experiments.md ("Protocols"), its required part.
    path = tmp_path / "mine.toml"
    path.write_text(
        '[study]\nmethod = "2afc"\nrepetitions = 8\n'
        "[standard]\nmu_s = 0.0\n[comparison]\nmu_s = [0.0, 0.1, 0.2, 0.3]\n"
    )
    code, out, err = run(
        ["power", str(path), "--participants", "3", "--simulations", "20", "--json"], capsys
    )
    assert code == 0, err
    res = json.loads(out)
    assert res["study"] == "mine" and res["levels"] == [0.0, 0.1, 0.2, 0.3]
    assert sorted({r["repetitions"] for r in res["design"]}) == [5, 8, 16]


def test_missing_extra_says_what_to_install(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(stats_cli, "EXTRA_MODULES", ("numpy", "no_such_module_for_expstats"))
    code, _, err = run(["analyze", str(tmp_path), "--out", str(tmp_path / "o")], capsys)
    assert code == 2
    assert "no_such_module_for_expstats" in err and "stiction[experiment]" in err


def test_a_binary_file_named_csv_is_one_clear_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """csv raised its own error from the header row: a traceback."""
    path = tmp_path / "junk.csv"
    path.write_bytes(b"\x00\xfe\rab\ncd\r\x00")
    code, _, err = run(["analyze", str(path), "--out", str(tmp_path / "o")], capsys)
    assert code == 2 and f"{path}:1: not valid CSV" in err
    assert "Traceback" not in err and err.count("\n") == 1


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        # numpy was asked for 3.6 TiB: a MemoryError traceback
        (["power", "paper-study1", "--simulations", "99999999999"], "at most 20000000"),
        (["power", "paper-study1", "--participants", "10,99999999"], "at most 20000000"),
    ],
)
def test_power_refuses_a_design_too_large_to_simulate(
    argv: list[str], words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run(argv, capsys)
    assert code == 2 and words in err and "Traceback" not in err


@pytest.mark.parametrize(
    ("argv", "flag"),
    [
        (["power", "paper-study1", "--pse", "nan"], "--pse"),
        (["power", "paper-study1", "--quest-simulations", "99999999"], "--quest-simulations"),
        (["power", "paper-study1", "--max-trials", "99999999"], "--max-trials"),
        (["analyze", "x.csv", "--out", "o", "--bootstrap", "99999999999"], "--bootstrap"),
    ],
)
def test_power_and_analyze_flags_have_bounds(
    argv: list[str], flag: str, capsys: pytest.CaptureFixture[str]
) -> None:
    code, _, err = run(argv, capsys)
    assert code == 2 and f"argument {flag}: " in err

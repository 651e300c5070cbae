"""`stiction experiment analyze` and `stiction experiment power`.

Registered by the experiment CLI through `register(sub)`, `sub` being its
subparsers action. The handlers import numpy, scipy, pingouin and questplus
only when run, so `stiction --help` stays fast and works without the
``experiment`` extra; without it they say what to install.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from stiction.argtypes import (
    finite_float,
    int_range,
    non_negative_float,
    non_negative_int,
    positive_float,
    positive_int,
)
from stiction.errors import StictionError
from stiction.experiment.study import MAX_TRIALS

EXTRA_MODULES = ("numpy", "scipy", "pandas", "pingouin", "matplotlib", "questplus")
EXTRA_HINT = "pip install 'stiction[experiment]'"

PAPER_PARTICIPANTS = 10  # both user studies had 10 participants


def _need_extra() -> None:
    missing = [m for m in EXTRA_MODULES if importlib.util.find_spec(m) is None]
    if missing:
        raise StictionError(f"this command needs {', '.join(missing)}: {EXTRA_HINT}")


def _int_list(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected whole numbers separated by commas, got {text!r}"
        ) from None
    if not values or min(values) < 1:
        raise argparse.ArgumentTypeError(f"expected counts of at least 1, got {text!r}")
    return values


MAX_POWER_DRAWS = 20_000_000
"""Simulations x participants x levels in one `power` design: 160 MB per float64
array. The default (500 x 20 x 5) is 50,000; 5,000 simulations took 0.5 s."""

MAX_BOOTSTRAP = 100_000
"""Bootstrap resamples of one fit: the default is 1,000."""

MAX_QUEST_SIMULATIONS = 1000
"""QUEST+ runs per method in --compare; each trial costs about 50 ms."""


def _unit(text: str) -> float:
    """A guess or lapse rate: 0 <= rate < 0.5 (at 0.5 and above the curve cannot rise)."""
    value = non_negative_float(text)
    if value >= 0.5:
        raise argparse.ArgumentTypeError(f"must be in [0, 0.5), got {text}")
    return value


@dataclass(frozen=True)
class Design:
    """What `power` needs of a study: its method, comparison levels and repetitions."""

    name: str
    method: str
    levels: list[float]
    repetitions: int


def load_design(name_or_path: str) -> Design:
    """The study's design, read (and checked completely) by the study loader."""
    from stiction.experiment.study import load_study

    loaded = load_study(name_or_path)
    return Design(
        str(loaded.name),
        str(loaded.method),
        [float(v) for v in loaded.comparison_mu_s],
        int(loaded.repetitions),
    )


def _analyze(args: argparse.Namespace) -> int:
    _need_extra()
    from stiction.experiment import analysis, report

    results = analysis.analyze(args.paths, seed=args.seed, bootstrap=args.bootstrap)
    path = report.write(results, Path(args.out))
    if args.json:
        json.dump(report.jsonable(results), sys.stdout, indent=1, allow_nan=False)
        print()
    else:
        for r in results:
            if r["method"] == "2afc":
                print(
                    f"{r['study']} string={r['string']}: PSE {r['pse']:.3g} "
                    f"[{r['pse_ci'][0]:.3g}, {r['pse_ci'][1]:.3g}], JND {r['jnd']:.3g} "
                    f"[{r['jnd_ci'][0]:.3g}, {r['jnd_ci'][1]:.3g}] (mu_s)"
                )
            else:
                a = r["anova"]
                print(
                    f"{r['study']} string={r['string']}: F({a['df1']:.3g}, {a['df2']:.3g}) = "
                    f"{a['f']:.3g}, p = {a['p']:.3g}; k = {r['stevens']['k']:.3g}, "
                    f"beta = {r['stevens']['beta']:.3g}"
                )
        print(f"report: {path}")
    return 0


def _power(args: argparse.Namespace) -> int:
    _need_extra()
    from stiction.experiment import power

    design = load_design(args.study)
    if design.method != "2afc":
        raise StictionError(
            f"{design.name}: power estimates the JND of a 2afc study; this one is {design.method}"
        )
    observer = power.Observer(args.pse, args.jnd, args.guess, args.lapse)
    people = args.participants or [5, PAPER_PARTICIPANTS, 2 * PAPER_PARTICIPANTS]
    reps = args.repetitions or sorted({5, design.repetitions, 2 * design.repetitions})
    draws = args.simulations * max(people) * len(design.levels)
    if draws > MAX_POWER_DRAWS:  # 1e11 simulations asked numpy for 3.6 TiB: MemoryError
        raise StictionError(
            f"--simulations {args.simulations} x {max(people)} participants x "
            f"{len(design.levels)} levels = {draws} simulated observers' answers; at most "
            f"{MAX_POWER_DRAWS} (fewer --simulations or --participants)"
        )
    table = power.design_table(
        observer,
        design.levels,
        args.precision,
        people,
        reps,
        args.simulations,
        args.seed,
        args.pse_sd,
    )
    best = power.cheapest(table)
    curves = (  # QUEST+ costs tens of ms a trial; constant stimuli is vectorised
        power.compare_methods(
            observer,
            design.levels,
            args.precision,
            args.max_trials,
            args.quest_simulations,
            args.seed,
            mcs_simulations=args.simulations,
        )
        if args.compare
        else []
    )
    out = {
        "study": design.name,
        "levels": design.levels,
        "observer": power.as_dict(observer),
        "precision": args.precision,
        "cover": power.COVER,
        "simulations": args.simulations,
        "seed": args.seed,
        "pse_sd": args.pse_sd,
        "design": power.as_dict(table),
        "cheapest": power.as_dict(best) if best else None,
        "compare": power.as_dict(curves),
        "quest_simulations": args.quest_simulations if args.compare else 0,
    }
    if args.json:
        json.dump(out, sys.stdout, indent=1, allow_nan=False)
        print()
        return 0
    print(
        f"{design.name}: observer PSE {args.pse} JND {args.jnd} guess {args.guess} "
        f"lapse {args.lapse} (mu_s); precision: 95% of {args.simulations} simulated "
        f"studies within +-{args.precision} of the true JND"
    )
    print(f"{'participants':>12}{'reps':>6}{'trials/person':>15}{'JND error95':>13}  meets")
    for row in table:
        print(
            f"{row.participants:>12}{row.repetitions:>6}{row.trials_per_participant:>15}"
            f"{row.jnd_error95:>13.4f}  {'yes' if row.meets else 'no'}"
        )
    if best:
        print(
            f"cheapest design meeting it: {best.participants} participants x "
            f"{best.repetitions} repetitions ({best.participants * best.trials_per_participant}"
            " trials in all)"
        )
    else:
        print("no design tried meets it: try more participants or repetitions")
    if curves:
        print(
            f"\none participant; JND error95 by trials; QUEST+ {args.quest_simulations} "
            f"simulated runs, constant stimuli {args.simulations}"
        )
        print(f"{'trials':>7}" + "".join(f"{c.method:>26}" for c in curves))
        errors = [dict(zip(c.trials, c.jnd_error95, strict=True)) for c in curves]
        for t in sorted({t for c in curves for t in c.trials}):
            cells = [f"{e[t]:>26.3f}" if t in e else f"{'':>26}" for e in errors]
            print(f"{t:>7}" + "".join(cells))
        print(f"trials needed for +-{args.precision} (from then on, every count meets it):")
        for c in curves:
            n = c.trials_needed
            print(f"  {c.method:<26}{n if n is not None else f'more than {args.max_trials}'}")
        by = {c.method: c.trials_needed for c in curves}
        same, qp = by.get("constant stimuli, Bayes"), by.get("QUEST+")
        if same and qp:
            print(f"constant stimuli / QUEST+, same estimator: {same / qp:.2f}x the trials")
    return 0


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add `analyze` and `power` to the `stiction experiment` subcommands."""
    an = sub.add_parser(
        "analyze",
        help="analyse trial CSVs: psychometric fits, ANOVA, Stevens' law, report",
        description="Analyse the trial CSVs of `stiction experiment run`/`simulate` (files, or "
        "directories of them): study 1 (2afc) psychometric fits with bootstrap intervals, "
        "study 2 (ratio) Shapiro-Wilk, Mauchly, repeated-measures ANOVA, Tukey and Stevens' "
        "power function. Writes report.md, PNG figures and results.json into --out.",
    )
    an.add_argument("paths", nargs="+", metavar="DIR|CSV", help="trial CSV files or directories")
    an.add_argument("--out", required=True, metavar="DIR", help="folder for the report")
    an.add_argument("--json", action="store_true", help="print the results as JSON")
    an.add_argument("--seed", type=non_negative_int, default=0, help="bootstrap seed (0)")
    an.add_argument(
        "--bootstrap",
        type=int_range(1, MAX_BOOTSTRAP),
        default=1000,
        metavar="N",
        help="resamples (1000)",
    )
    an.set_defaults(func=_analyze)

    pw = sub.add_parser(
        "power",
        help="participants, repetitions and trials a 2afc study needs for a JND precision",
        description="Simulate a psychometric observer (logistic in mu_s with the given PSE, "
        "JND, guess and lapse rates; not the stroke-level simulated participant) in the "
        "study's constant-stimuli design, and report how far the pooled JND estimate falls "
        "from the truth (the 95th percentile of the error) for each participants x "
        "repetitions. --compare adds QUEST+ (questplus) against constant stimuli for one "
        "participant: the trials each needs for the same precision.",
    )
    pw.add_argument("study", metavar="STUDY", help="study TOML, or paper-study1")
    pw.add_argument("--pse", type=finite_float, default=0.2, help="observer's PSE in mu_s (0.2)")
    pw.add_argument("--jnd", type=positive_float, default=0.1, help="observer's JND (0.1)")
    pw.add_argument("--guess", type=_unit, default=0.0, help="guess rate (0)")
    pw.add_argument("--lapse", type=_unit, default=0.02, help="lapse rate (0.02)")
    pw.add_argument(
        "--precision",
        type=positive_float,
        default=0.03,
        help="target: 95%% of estimates within +-this of the true JND (0.03)",
    )
    pw.add_argument(
        "--pse-sd",
        type=non_negative_float,
        default=0.0,
        help="spread (SD) of the participants' PSEs around --pse (0)",
    )
    pw.add_argument("--participants", type=_int_list, metavar="N,N,...", help="counts to try")
    pw.add_argument("--repetitions", type=_int_list, metavar="N,N,...", help="per level")
    pw.add_argument("--simulations", type=positive_int, default=500, help="per design (500)")
    pw.add_argument("--seed", type=non_negative_int, default=1, help="simulation seed (1)")
    pw.add_argument("--compare", action="store_true", help="also QUEST+ vs constant stimuli")
    pw.add_argument(
        "--max-trials",
        type=int_range(1, MAX_TRIALS),
        default=120,
        help="--compare: trials per run (120)",
    )
    pw.add_argument(
        "--quest-simulations",
        type=int_range(1, MAX_QUEST_SIMULATIONS),
        default=40,
        help="--compare: simulated runs per method (40; QUEST+ costs ~50 ms a trial)",
    )
    pw.add_argument("--json", action="store_true", help="print the results as JSON")
    pw.set_defaults(func=_power)

"""`stiction experiment`: check, run and simulate studies (analyze and power come from stats_cli).

Heavy imports (aiohttp, zmq, the simulator) happen inside the handlers so
that `stiction --help` stays fast.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from stiction.argtypes import count_up_to, endpoint, int_range, port, positive_int

DEFAULT_PORT = 8766

MAX_SIMULATED = 1000
"""Simulated participants in one run: each takes about 10 s on paper-study1
(`stiction experiment simulate paper-study1 --participants 2`: 19 s), so this
is some three hours; 1e11 was a run that never ends."""


def _study(args: argparse.Namespace) -> Any:
    from stiction.experiment.study import load_study

    study = load_study(args.study)
    if getattr(args, "repetitions", None) is not None:
        study = study.with_repetitions(args.repetitions)
    return study


_participants = count_up_to(MAX_SIMULATED)
_seed = int_range(0, 2**63 - 1)


def _check(args: argparse.Namespace) -> int:
    from stiction.experiment.schedule import make_schedule, participant_seed

    study = _study(args)
    strings = ", ".join("with string" if s else "without string" for s in study.strings)
    print(f"study {study.name} ({study.source}): method {study.method}")
    print(
        f"  standard mu_s {study.standard_mu_s:g}; comparison mu_s "
        f"{', '.join(f'{m:g}' for m in study.comparison_mu_s)}; {strings}"
    )
    print(
        f"  {study.repetitions} repetitions: {study.trials_per_block} trials per block, "
        f"{study.n_trials} in all"
    )
    p = study.params
    print(
        f"  k {p['k']:g} N/m, mu_k {p['mu_k']:g}, C_l {p['C_l']:g}, m {p['m']:g} kg, "
        f"g {p['g']:g} m/s^2; display {study.display[0]} x {study.display[1]} px; "
        f"a stimulus ends after {study.travel_px:g} px"
    )
    if args.participant:
        seed = participant_seed(study, args.participant) if args.seed is None else args.seed
        trials = make_schedule(study, args.participant, seed)
        print(f"participant {args.participant}: seed {seed}; first trials:")
        for t in trials[: args.show]:
            order = "comparison first" if t.comparison_first else "standard first"
            print(f"  {t.number:4d}  block {t.block}  {t.condition:<16} {order}")
    return 0


def _run(args: argparse.Namespace) -> int:
    from stiction.experiment.live import run_live
    from stiction.experiment.runner import Session, check_participant

    study = _study(args)
    check_participant(args.participant)
    out = Path(args.out) if args.out else Path("experiment-data") / study.name
    session = Session(study, args.participant, out, seed=args.seed, record=args.record)
    if session.state == "done":
        session.close()
        print(
            f"stiction experiment: {args.participant} has completed {study.name} "
            f"({session.csv}); nothing to do",
            file=sys.stderr,
        )
        return 0
    if session.position:
        print(
            f"stiction experiment: resuming {args.participant} at trial {session.position + 1} "
            f"of {len(session.schedule)}",
            file=sys.stderr,
        )
    return run_live(
        session,
        pub=args.pub,
        control=args.control,
        host=args.host,
        port=args.port,
        device=args.device,
    )


def _simulate(args: argparse.Namespace) -> int:
    from stiction.experiment.simulate import simulate_study

    study = _study(args)
    out = Path(args.out)
    paths = simulate_study(
        study,
        out,
        args.participants,
        seed=args.seed if args.seed is not None else 0,
        record=args.record,
        progress=(lambda m: print(m, file=sys.stderr, flush=True)) if args.verbose else None,
    )
    print(
        f"stiction experiment: simulated {len(paths)} participant(s) of {study.name} "
        f"({study.n_trials} trials each) into {out}"
    )
    return 0


def register(sub: argparse._SubParsersAction[Any]) -> None:
    """Add `stiction experiment` and its subcommands."""
    from stiction import protocol

    exp = sub.add_parser(
        "experiment",
        help="psychophysics studies: check, run with a person, simulate, analyze",
        description="Run the paper's user studies (presets paper-study1, paper-study2) or your "
        "own study file on a running stictiond, or simulate them headless "
        "(docs/experiments.md).",
    )
    esub = exp.add_subparsers(dest="experiment_command", metavar="SUBCOMMAND", required=True)

    def study_arg(p: argparse.ArgumentParser) -> None:
        p.add_argument("study", metavar="STUDY", help="study TOML file, or paper-study1/2")
        p.add_argument("--repetitions", type=positive_int, help="override the study's repetitions")
        p.add_argument("--seed", type=_seed, help="order seed (default: from study and ID)")

    c = esub.add_parser("check", help="validate a study and show a participant's order")
    study_arg(c)
    c.add_argument("--participant", metavar="ID", help="show this participant's first trials")
    c.add_argument("--show", type=positive_int, default=8, help="how many trials (default 8)")
    c.set_defaults(func=_check)

    r = esub.add_parser(
        "run",
        help="run a study with a participant on a running stictiond",
        description="Drive a running stictiond through its control socket and serve the "
        "participant's page. Rerun with the same --participant and --out to resume.",
    )
    study_arg(r)
    r.add_argument("--participant", required=True, metavar="ID", help="participant ID")
    r.add_argument("--out", metavar="DIR", help="data folder (default experiment-data/STUDY)")
    r.add_argument(
        "--pub", type=endpoint, default=protocol.DEFAULT_PUB, help="daemon publisher endpoint"
    )
    r.add_argument(
        "--control",
        type=endpoint,
        default=protocol.DEFAULT_CONTROL,
        help="daemon control endpoint",
    )
    r.add_argument("--device", help="the device to follow (default: the first one)")
    r.add_argument("--host", default="127.0.0.1", help="page address (default loopback)")
    r.add_argument("--port", type=port, default=DEFAULT_PORT, help=f"page port ({DEFAULT_PORT})")
    r.add_argument("--record", action="store_true", help="also save every stimulus's frames")
    r.set_defaults(func=_run)

    s = esub.add_parser(
        "simulate",
        help="run a study headless with simulated participants",
        description="Each simulated participant strokes a synthetic pen through a real "
        "stictiond (virtual clock) and answers like a person; writes the files of `run`.",
    )
    study_arg(s)
    s.add_argument("--participants", type=_participants, required=True, metavar="N")
    s.add_argument("--out", required=True, metavar="DIR", help="data folder")
    s.add_argument("--record", action="store_true", help="also save every stimulus's frames")
    s.set_defaults(func=_simulate)

    from stiction.experiment import stats_cli  # analyze and power: the statistics half

    stats_cli.register(esub)

"""What accuracy costs: every integrator setting on 1-D and 2-D strokes.

Run as ``stiction bench accuracy [--json] [--quick]``. Prints, per setting:
RMS and max pointer error in pixels at 220 ppi (worst stroke), the largest
stick-release time error in ms, microseconds per one-contact step (ContactSim,
min of repeats) and its ratio to explicit Euler in the same run, and
nanoseconds per contact-step for BatchSim at 10,000 contacts. References: the
exact integrator's closed form on straight (1-D) strokes, a converged
256-substep solution on 2-D strokes (checked against 512 substeps and against
RK4 with 256 substeps; both differences are printed). Also shows what
following every input sample buys over tick endpoints only, and writes
accuracy.{json,txt,png} in the results folder (--save: bench/results/).
"""

import argparse
import json
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from stiction.bench._support import progress, results_dir
from stiction.sim import BatchSim, ContactSim, ContactState, Params, Touch
from stiction.sim.integrators import DEFAULT_INTEGRATOR

PX = 0.0254 / 220.0  # one pixel at 220 ppi, in metres
RATE_IN = 200.0  # tablet report rate: two samples per 100 Hz tick
UNIT = 5e-6  # one device unit of a 200 lines/mm tablet (sensor noise)

Path2 = Callable[[float], tuple[float, float]]
Ticks = list[tuple[float, list[Touch]]]  # (tick time, samples since the last tick)


@dataclass(frozen=True)
class Stroke:
    name: str
    samples: tuple[Touch, ...]
    straight: bool


def _line(v: float, t_end: float) -> Path2:
    """A straight stroke at v m/s that stops at t_end."""
    return lambda t: (0.05 + v * min(t, t_end), 0.05)


def _circle(f: float, r: float) -> Path2:
    """A circle of radius r m at f turns per second."""
    return lambda t: (
        0.05 + r * math.cos(2 * math.pi * f * t),
        0.05 + r * math.sin(2 * math.pi * f * t),
    )


def _sampled(fn: Path2, t1: float, rate: float = RATE_IN) -> list[Touch]:
    return [Touch(i / rate, *fn(i / rate)) for i in range(round(t1 * rate) + 1)]


def strokes() -> list[Stroke]:
    """The paper's task and the ways people really move a pen (surface metres)."""
    d70 = 70 * PX  # the paper's 70 px task, 8.1 mm at 220 ppi
    out = []
    for v in (0.005, 0.02, 0.08):  # slow, medium, fast drags
        travel = 6.86e-3 + d70 + 0.002  # past the stick travel mu_s*m*g/k, then 70 px
        t_move = travel / v
        out.append(
            Stroke(
                f"paper70 {v * 1000:g}mm/s",
                tuple(_sampled(_line(v, t_move), t_move + 0.4)),
                True,
            )
        )

    def stop_go(t: float) -> tuple[float, float]:
        w = 3 * math.pi
        return 0.05 + 0.02 * t - 0.02 * math.sin(w * t) / w, 0.05

    out.append(Stroke("stop-and-go", tuple(_sampled(stop_go, 2.0)), True))
    out.append(
        Stroke(
            "reversals",
            tuple(_sampled(lambda t: (0.05 + 0.015 * math.sin(2 * math.pi * t), 0.05), 2.0)),
            True,
        )
    )
    for f, r in ((0.5, 0.01), (1.5, 0.01)):
        out.append(
            Stroke(
                f"circle {f:g}Hz",
                tuple(_sampled(_circle(f, r), 2.0)),
                False,
            )
        )
    # A curved slow drag, where friction dominates the pen's momentum.
    out.append(
        Stroke(
            "slow curve",
            tuple(_sampled(lambda t: (0.05 + 0.004 * t, 0.05 + 0.002 * math.sin(2 * t)), 3.0)),
            False,
        )
    )
    # Pen lifts: stroke, lift, set down elsewhere, stroke on.
    lift: list[Touch] = []
    for s in _sampled(lambda t: (0.05 + 0.03 * t, 0.05 + 0.01 * t), 1.6):
        if 0.7 <= s.t < 0.9:
            lift.append(Touch(s.t, s.x + 0.02, s.y - 0.01, False))
        elif s.t >= 0.9:
            lift.append(Touch(s.t, s.x + 0.02, s.y - 0.01, True))
        else:
            lift.append(s)
    out.append(Stroke("pen lifts", tuple(lift), False))
    # Sensor noise: one device unit of jitter on a 2-D drag with a pause.
    rng = np.random.default_rng(7)
    noisy = [
        Touch(s.t, s.x + UNIT * rng.integers(-1, 2), s.y + UNIT * rng.integers(-1, 2))
        for s in _sampled(lambda t: (0.05 + 0.015 * min(t, 1.0), 0.05 + 0.006 * min(t, 1.0)), 1.6)
    ]
    out.append(Stroke("sensor noise", tuple(noisy), False))
    return out


@dataclass(frozen=True)
class Setting:
    integrator: str
    substeps: int
    events: bool

    @property
    def label(self) -> str:
        ev = "+events" if self.events else ""
        return f"{self.integrator} x{self.substeps}{ev}"

    @property
    def is_default(self) -> bool:
        return (self.integrator, self.substeps, self.events) == (DEFAULT_INTEGRATOR, 1, True)


def settings(quick: bool) -> list[Setting]:
    subs = (1, 4) if quick else (1, 4, 16)
    out = []
    for name in ("explicit-euler", "semi-implicit-euler", "rk4", "implicit-projection", "exact"):
        for n in subs:
            out.append(Setting(name, n, name in ("rk4", "exact")))
        out.append(Setting(name, 1, name not in ("rk4", "exact")))
    return out


def ticks(
    stroke: Stroke, dt: float, endpoints_only: bool = False
) -> list[tuple[float, list[Touch]]]:
    """(tick time, samples since the previous tick), as the daemon hands them over."""
    s = stroke.samples
    out = []
    i = 0
    n = round(s[-1].t / dt)
    for k in range(n + 1):
        t = k * dt
        batch = []
        while i < len(s) and s[i].t <= t + 1e-9:
            batch.append(Touch(min(s[i].t, t), s[i].x, s[i].y, s[i].tip))
            i += 1
        if endpoints_only and batch:
            batch = [batch[-1]]
        out.append((t, batch))
    return out


@dataclass
class Run:
    states: list[ContactState]
    releases: list[float] = field(default_factory=list)


def simulate(sim: ContactSim, tk: list[tuple[float, list[Touch]]]) -> Run:
    run = Run([])
    seen = 0
    for t, batch in tk:
        run.states.append(sim.advance(t, batch))
        if sim.releases != seen:
            seen = sim.releases
            run.releases.append(sim.last_release)
    return run


def errors(a: Run, ref: Run) -> tuple[float, float, float]:
    """RMS px, max px, worst release-time error (ms) of a against ref."""
    d = [
        math.hypot(x.pointer_x - y.pointer_x, x.pointer_y - y.pointer_y)
        for x, y in zip(a.states, ref.states, strict=True)
    ]
    rms = math.sqrt(sum(e * e for e in d) / len(d)) / PX
    worst = 0.0
    for r in ref.releases:
        near = min((abs(c - r) for c in a.releases), default=math.inf)
        worst = max(worst, near)
    if len(a.releases) != len(ref.releases):
        worst = max(worst, math.inf if not a.releases else worst)
    return rms, max(d) / PX, worst * 1000.0


def time_per_step(
    sets: Sequence[Setting],
    params: Params,
    all_ticks: list[Ticks],
    repeats: int,
    done: Callable[[str], None] = lambda _msg: None,
) -> list[float]:
    """us per ContactSim step for each setting: repeats interleaved round-robin
    (so load from other processes hits every setting alike), minimum kept."""
    n = sum(len(tk) for tk in all_ticks)
    best = [math.inf] * len(sets)
    for _ in range(repeats):
        for j, st in enumerate(sets):
            sims = [ContactSim(params, st.integrator, st.substeps, st.events) for _ in all_ticks]
            t0 = time.perf_counter()
            for sim, tk in zip(sims, all_ticks, strict=True):
                adv = sim.advance
                for t, batch in tk:
                    adv(t, batch)
            best[j] = min(best[j], time.perf_counter() - t0)
        done("timing")
    return [b / n * 1e6 for b in best]


def slide_cost(names: Sequence[str], params: Params, repeats: int) -> dict[str, float]:
    """us per step while sliding steadily (no events): the bare cost of one step.

    Runs alternate between the integrators and the minimum is kept, so that
    load from other processes on the machine hits them alike.
    """
    v = 0.02
    samples = [Touch(i / RATE_IN, v * i / RATE_IN, 0.0) for i in range(round(4.0 * RATE_IN) + 1)]
    tk = ticks(Stroke("slide", tuple(samples), True), params.dt)
    warm, timed = tk[:100], tk[100:]  # released at 0.34 s, steady by 1 s
    best = dict.fromkeys(names, math.inf)
    for _ in range(repeats):
        for name in names:
            sim = ContactSim(params, name)
            for t, batch in warm:
                sim.advance(t, batch)
            assert sim.mode == 1  # sliding
            adv = sim.advance
            t0 = time.perf_counter()
            for t, batch in timed:
                adv(t, batch)
            best[name] = min(best[name], time.perf_counter() - t0)
    return {k: v / len(timed) * 1e6 for k, v in best.items()}


def batch_cost(
    setting: Setting,
    params: Params,
    sts: Sequence[Stroke],
    contacts: int,
    nticks: int,
    repeats: int,
) -> float | None:
    """ns per contact-step for BatchSim, each contact on a stroke at its own phase."""
    try:
        BatchSim(1, params, setting.integrator, setting.substeps, setting.events)
    except Exception:
        return None
    xs, ys, tips = _batch_inputs(params, sts, contacts, nticks)
    best = math.inf
    for _ in range(repeats):
        b = BatchSim(contacts, params, setting.integrator, setting.substeps, setting.events)
        b.advance(0.0, xs[0], ys[0], tips[0])
        t0 = time.perf_counter()
        for k in range(1, nticks):
            b.advance(k * params.dt, xs[k], ys[k], tips[k])
        best = min(best, time.perf_counter() - t0)
    return best / ((nticks - 1) * contacts) * 1e9


_inputs_cache: dict[tuple[int, int], tuple[np.ndarray, np.ndarray, np.ndarray]] = {}


def _batch_inputs(
    params: Params, sts: Sequence[Stroke], contacts: int, nticks: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    key = (contacts, nticks)
    if key in _inputs_cache:
        return _inputs_cache[key]
    dt = params.dt
    per = []
    for s in sts:  # tick-endpoint positions of each stroke, looped
        tk = [b[-1] for _, b in ticks(s, dt) if b]
        per.append(tk)
    rng = np.random.default_rng(1)
    which = rng.integers(0, len(per), contacts)
    phase = rng.integers(0, 10_000, contacts)
    xs = np.empty((nticks, contacts))
    ys = np.empty((nticks, contacts))
    tips = np.empty((nticks, contacts), dtype=bool)
    for i in range(contacts):
        tk = per[which[i]]
        idx = (phase[i] + np.arange(nticks)) % len(tk)
        xs[:, i] = [tk[j].x for j in idx]
        ys[:, i] = [tk[j].y for j in idx]
        tips[:, i] = [tk[j].tip for j in idx]
    _inputs_cache[key] = (xs, ys, tips)
    return xs, ys, tips


def loop_cost(params: Params, sts: Sequence[Stroke], contacts: int, nticks: int) -> float:
    """The naive alternative to BatchSim: a Python loop over ContactSims (ns per contact-step)."""
    xs, ys, tips = _batch_inputs(params, sts, 10_000, 150)
    sims = [ContactSim(params) for _ in range(contacts)]
    for i, s in enumerate(sims):
        s.advance(0.0, [Touch(0.0, xs[0, i], ys[0, i], bool(tips[0, i]))])
    t0 = time.perf_counter()
    for k in range(1, nticks):
        t = k * params.dt
        for i, s in enumerate(sims):
            s.advance(t, [Touch(t, float(xs[k, i]), float(ys[k, i]), bool(tips[k, i]))])
    return (time.perf_counter() - t0) / ((nticks - 1) * contacts) * 1e9


LOAD = 0.0


def main(argv: list[str]) -> int:
    global LOAD
    LOAD = os.getloadavg()[0]
    ap = argparse.ArgumentParser(prog="stiction bench accuracy", description=__doc__)
    ap.add_argument("--json", action="store_true", help="one JSON object per setting")
    ap.add_argument("--quick", action="store_true", help="fewer settings and repeats")
    ap.add_argument("--contacts", type=int, default=10_000, help="BatchSim contacts")
    args = ap.parse_args(argv)
    params = Params()
    sts = strokes()
    sets = settings(args.quick)
    repeats = 2 if args.quick else 15
    dt = params.dt
    all_ticks = [ticks(s, dt) for s in sts]
    # One step per stroke reference, setting, timing repeat and batch run: the
    # references and timings take minutes in a full run.
    n_batch = sum(1 for st in sets if st.substeps == 1)
    bar = progress(len(sts) + len(sets) + repeats + n_batch + 3, "accuracy", "step")

    def step(msg: str) -> None:
        bar.set_postfix_str(msg)
        bar.update(1)

    # References, and how much they can be trusted.
    refs: list[Run] = []
    ref_check: list[tuple[str, float, float]] = []
    for s, tk in zip(sts, all_ticks, strict=True):
        if s.straight:
            refs.append(simulate(ContactSim(params, "exact"), tk))
        else:
            ref = simulate(ContactSim(params, "exact", 256), tk)
            finer = simulate(ContactSim(params, "exact", 512), tk)
            rk = simulate(ContactSim(params, "rk4", 256, events=True), tk)
            ref_check.append((s.name, errors(ref, finer)[1], errors(rk, ref)[1]))
            refs.append(ref)
        step(f"reference {s.name}")

    rows: list[dict[str, Any]] = []
    for st in sets:
        per = []
        for s, tk, ref in zip(sts, all_ticks, refs, strict=True):
            sim = ContactSim(params, st.integrator, st.substeps, st.events)
            per.append((s.name, *errors(simulate(sim, tk), ref)))
        rows.append({"setting": st, "per": per})
        step(st.label)
    for r, us in zip(rows, time_per_step(sets, params, all_ticks, repeats, step), strict=True):
        r["us"] = us
    euler_us = next(r["us"] for r in rows if r["setting"] == Setting("explicit-euler", 1, False))

    slide = slide_cost(("explicit-euler", "exact"), params, 30 if args.quick else 100)
    step("slide")
    contacts = args.contacts
    nticks = 60 if args.quick else 150
    for r in rows:
        st = r["setting"]
        r["ns"] = None
        if st.substeps == 1:
            r["ns"] = batch_cost(st, params, sts, contacts, nticks, max(1, repeats - 2))
            step(f"batch {st.label}")
    naive_ns = loop_cost(params, sts, 300, 30)
    step("loop")

    # Following every sample vs tick endpoints only (default integrator).
    follow = []
    for s, ref in zip(sts, refs, strict=True):
        ends = simulate(ContactSim(params), ticks(s, dt, endpoints_only=True))
        every = simulate(ContactSim(params), ticks(s, dt))
        follow.append((s.name, errors(every, ref)[:2], errors(ends, ref)[:2]))
    step("endpoints")

    records = []
    for r in rows:
        st = r["setting"]
        per = r["per"]
        records.append(
            {
                "integrator": st.integrator,
                "substeps": st.substeps,
                "default": st.is_default,
                "events": st.events,
                "rms_px": max(p[1] for p in per),
                "max_px": max(p[2] for p in per),
                "release_ms": max(p[3] for p in per),
                "us_per_step": r["us"],
                "ratio_to_explicit_euler": r["us"] / euler_us,
                "ns_per_contact_step": r["ns"],
                "strokes": {
                    p[0]: {"rms_px": p[1], "max_px": p[2], "release_ms": p[3]} for p in per
                },
            }
        )
    default = next(x for x in records if x["default"])
    batch_default = default["ns_per_contact_step"]
    targets = {
        "default_rms_px<=0.05": default["rms_px"] <= 0.05,
        "default_max_px<=0.5": default["max_px"] <= 0.5,
        "default_time<=1.5x_explicit_euler": default["ratio_to_explicit_euler"] <= 1.5,
        "batch_ns<=50": batch_default is not None and batch_default <= 50.0,
    }
    bar.close()

    text = _table(records, ref_check, follow, naive_ns, batch_default, targets, contacts, slide)
    (results_dir() / "accuracy.txt").write_text(text)
    (results_dir() / "accuracy.json").write_text(
        json.dumps(
            {
                "settings": records,
                "reference_check": [
                    {"stroke": n, "vs_512_substeps_max_px": a, "rk4x256_vs_ref_max_px": b}
                    for n, a, b in ref_check
                ],
                "follow_every_sample": [
                    {
                        "stroke": n,
                        "every": {"rms_px": e[0], "max_px": e[1]},
                        "endpoints_only": {"rms_px": o[0], "max_px": o[1]},
                    }
                    for n, e, o in follow
                ],
                "batch_contacts": contacts,
                "loop_ns_per_contact_step": naive_ns,
                "steady_slide_us_per_step": slide,
                "load_average_at_start": LOAD,
                "targets": targets,
                "python": sys.version.split()[0],
                "numpy": np.__version__,
            },
            indent=1,
            default=_json_default,
        )
        + "\n"
    )
    _plot(records, results_dir() / "accuracy.png")
    if args.json:
        for x in records:
            print(json.dumps({k: v for k, v in x.items() if k != "strokes"}, default=_json_default))
    else:
        print(text, end="")
    return 0


def _json_default(v: object) -> object:
    if isinstance(v, float) and not math.isfinite(v):
        return None
    raise TypeError(type(v).__name__)


def _fmt(v: float | None, spec: str) -> str:
    if v is None:
        return "-"
    if math.isinf(v):
        return "missed"
    return format(v, spec)


def _table(records, ref_check, follow, naive_ns, batch_default, targets, contacts, slide) -> str:  # type: ignore[no-untyped-def]
    lines = [
        "stiction bench accuracy: pointer error vs reference, worst stroke (220 ppi), "
        "100 Hz ticks, 200 Hz samples",
        f"(times: minimum of interleaved repeats; load average at start {LOAD:.2f} "
        f"on {os.cpu_count()} CPUs)",
        "",
        f"{'setting':34s} {'rms px':>9s} {'max px':>9s} {'release ms':>10s} {'us/step':>8s} "
        f"{'x Euler':>7s} {'batch ns':>9s}",
    ]
    for x in records:
        label = f"{x['integrator']} x{x['substeps']}" + (" +events" if x["events"] else "")
        if x["default"]:
            label += "  [default]"
        lines.append(
            f"{label:34s} {_fmt(x['rms_px'], '9.2e')} {_fmt(x['max_px'], '9.2e')} "
            f"{_fmt(x['release_ms'], '10.3f')} {x['us_per_step']:8.2f} "
            f"{x['ratio_to_explicit_euler']:7.2f} {_fmt(x['ns_per_contact_step'], '9.1f')}"
        )
    lines += [
        "",
        "us/step is ContactSim.advance per tick over all strokes, events and sample handling "
        "included;",
        f"steady sliding only (no events): explicit-euler {slide['explicit-euler']:.2f} us, "
        f"exact {slide['exact']:.2f} us ({slide['exact'] / slide['explicit-euler']:.2f}x)",
    ]
    lines += ["", "reference check (2-D strokes; max px):"]
    for n, a, b in ref_check:
        lines.append(f"  {n:16s} 256 vs 512 substeps {a:.1e}   rk4 x256 vs reference {b:.1e}")
    lines += ["", "following every sample vs tick endpoints only (default integrator; rms/max px):"]
    for n, e, o in follow:
        lines.append(
            f"  {n:18s} every sample {e[0]:8.2e} / {e[1]:8.2e}"
            f"   endpoints {o[0]:8.3f} / {o[1]:8.3f}"
        )
    lines += [
        "",
        f"batch at {contacts} contacts: default {_fmt(batch_default, '.1f')} ns/contact-step; "
        f"a Python loop over ContactSim {naive_ns:.0f} ns/contact-step "
        f"({_fmt(naive_ns / batch_default if batch_default else None, '.1f')}x)",
        "",
        "targets: " + ", ".join(f"{k} {'PASS' if v else 'FAIL'}" for k, v in targets.items()),
        "",
    ]
    return "\n".join(lines)


def _plot(records, path: Path) -> None:  # type: ignore[no-untyped-def]
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5.5), dpi=110)
    pts = []
    for x in records:
        err = max(x["rms_px"], 1e-12)
        pts.append((x["us_per_step"], err, x))
    front: list[tuple[float, float, dict[str, Any]]] = []
    for us, err, x in sorted(pts, key=lambda p: (p[0], p[1])):
        if not front or err < front[-1][1]:
            front.append((us, err, x))
    colors = {
        "explicit-euler": "tab:red",
        "semi-implicit-euler": "tab:orange",
        "rk4": "tab:purple",
        "implicit-projection": "tab:blue",
        "exact": "tab:green",
    }
    for us, err, x in pts:
        ax.scatter(
            us,
            err,
            color=colors[x["integrator"]],
            marker="o" if x["events"] else "s",
            s=70 if x["default"] else 30,
            edgecolors="black" if x["default"] else "none",
        )
        ax.annotate(
            f"{x['integrator'].replace('-euler', '')} x{x['substeps']}",
            (us, err),
            fontsize=6,
            xytext=(3, 2),
            textcoords="offset points",
        )
    ax.plot([p[0] for p in front], [p[1] for p in front], "k--", lw=0.8, label="Pareto front")
    ax.axhline(0.05, color="grey", lw=0.6, ls=":", label="0.05 px RMS target")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("microseconds per one-contact step (ContactSim)")
    ax.set_ylabel("worst-stroke RMS pointer error, px at 220 ppi")
    ax.set_title("stiction: accuracy vs cost (circles: with event location; squares: without)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))

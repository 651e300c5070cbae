"""What a scene costs per tick: only the stages it asks for.

Run as ``stiction bench scene [--json] [--quick]``. For 1, 10 and 1,000
simultaneous contacts (each getting two samples per tick, a 200 Hz tablet),
times one tick of the compiled pipeline (stiction.scene.pipeline) for three
scenes -- pass-through, stick-slip only, stick-slip with the string -- and,
in the same run, the naive alternative: the full simulation with the string
for every contact whatever the scene asks. Prints the median cost per tick
and the ratio naive / compiled, and writes scene.{json,txt,png} in the
results folder (--save: bench/results/).
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import statistics
import time
from typing import Any

from stiction.bench._support import results_dir
from stiction.daemon.mapping import AreaMapping, MappingConfig
from stiction.drivers.sample import PenSample
from stiction.scene.backend import SimulatorBackend
from stiction.scene.load import parse_scene
from stiction.scene.pipeline import DeviceRun, Pipeline

SIZE = (0.2, 0.15)
DISPLAY = (1920, 1080)
SCENES = {
    "pass-through": "[scene]\neffects = []\n",
    "stick-slip": '[scene]\neffects = ["stick_slip"]\noutside = "m"\n'
    "[materials.m]\nmu_s = 0.7\nmu_k = 0.1\n",
    "stick-slip+string": '[scene]\neffects = ["stick_slip", "string"]\noutside = "m"\n'
    "[materials.m]\nmu_s = 0.7\nmu_k = 0.1\n",
}
NAIVE = "stick-slip+string"


def _ticks(contacts: int, ticks: int) -> list[list[PenSample]]:
    """Every contact draws its own circle, two samples per 10 ms tick."""
    out = []
    for n in range(ticks):
        batch = []
        for k in range(2):
            t = (n + (k + 1) / 2) * 0.01
            for c in range(contacts):
                cx = 0.02 + 0.16 * (c % 37) / 37
                cy = 0.02 + 0.11 * (c % 29) / 29
                a = 2 * math.pi * (0.3 * t + c / 7)
                batch.append(
                    PenSample(
                        t=t,
                        x=cx + 0.01 * math.cos(a),
                        y=cy + 0.01 * math.sin(a),
                        tip=True,
                        contact=c,
                    )
                )
        batch.sort(key=lambda s: s.t)
        out.append(batch)
    return out


def _time_once(scene_text: str, ticks: list[list[PenSample]]) -> float:
    """Median seconds per tick over the timed ticks of one fresh pipeline."""
    backend = SimulatorBackend()
    pipe = Pipeline(parse_scene(scene_text, "bench"), backend, backend.defaults())
    dev = DeviceRun(AreaMapping(SIZE, DISPLAY, MappingConfig()))
    costs = []
    prev = -math.inf
    for n, batch in enumerate(ticks):
        t = (n + 1) * 0.01
        t0 = time.perf_counter()
        pipe.step(dev, t, prev, batch)
        costs.append(time.perf_counter() - t0)
        prev = t
    warm = max(1, len(costs) // 10)
    return statistics.median(costs[warm:])


def _time_all(ticks: list[list[PenSample]], repeats: int) -> dict[str, float]:
    """Best of `repeats` for every scene, the scenes interleaved within each repeat.

    The input samples are frozen out of the garbage collector first: freshly
    built, they are young objects that the first scene timed would otherwise
    pay to traverse (that made the first scene look twice as slow)."""
    gc.collect()
    gc.freeze()
    try:
        best = {name: math.inf for name in SCENES}
        for _ in range(repeats):
            for name, text in SCENES.items():
                best[name] = min(best[name], _time_once(text, ticks))
        return best
    finally:
        gc.unfreeze()


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="stiction bench scene", description=__doc__)
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    ap.add_argument("--quick", action="store_true", help="fewer ticks (a smoke run)")
    args = ap.parse_args(argv)

    rows = []
    for contacts in (1, 10, 1000):
        n_ticks = (20 if args.quick else 200) if contacts < 1000 else (5 if args.quick else 30)
        repeats = 1 if args.quick else 3
        ticks = _ticks(contacts, n_ticks)
        best = _time_all(ticks, repeats)
        naive = best[NAIVE]
        for name in SCENES:
            cost = best[name]
            rows.append(
                {
                    "scene": name,
                    "contacts": contacts,
                    "ms_per_tick": cost * 1e3,
                    "us_per_contact": cost * 1e6 / contacts,
                    "naive_ms_per_tick": naive * 1e3,
                    "naive_over_compiled": naive / cost,
                    "fits_10ms_tick": cost < 0.01,
                }
            )

    lines = [
        "scene cost per tick: compiled pipeline vs naive (full sim + string for every contact)",
        f"{'scene':<20}{'contacts':>9}{'ms/tick':>11}{'us/contact':>12}"
        f"{'naive ms':>11}{'naive/compiled':>16}{'< 10 ms':>9}",
    ]
    for r in rows:
        lines.append(
            f"{r['scene']:<20}{r['contacts']:>9}{r['ms_per_tick']:>11.4f}"
            f"{r['us_per_contact']:>12.2f}{r['naive_ms_per_tick']:>11.4f}"
            f"{r['naive_over_compiled']:>15.1f}x{'yes' if r['fits_10ms_tick'] else 'NO':>9}"
        )
    table = "\n".join(lines)
    (results_dir() / "scene.txt").write_text(table + "\n")
    (results_dir() / "scene.json").write_text(
        json.dumps({"rows": rows, "quick": args.quick}, indent=2)
    )
    _plot(rows)
    print(json.dumps({"rows": rows}, indent=2) if args.json else table)
    return 0


def _plot(rows: list[dict[str, Any]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for name in SCENES:
        pts = [(r["contacts"], r["ms_per_tick"]) for r in rows if r["scene"] == name]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=name)
    ax.axhline(10.0, color="grey", linestyle="--", label="10 ms tick (100 Hz)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("simultaneous contacts")
    ax.set_ylabel("ms per tick (median)")
    ax.set_title("stiction scene pipeline: cost per tick")
    ax.legend()
    fig.tight_layout()
    fig.savefig(results_dir() / "scene.png", dpi=100)
    plt.close(fig)

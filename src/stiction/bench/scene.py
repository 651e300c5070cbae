"""What a scene costs per tick: the batch pipeline against the naive per-contact one.

Run as ``stiction bench scene [--json] [--quick]``. For 1, 10 and 1,000
simultaneous contacts (each getting two samples per tick, a 200 Hz tablet),
times one tick of four scenes -- pass-through, stick-slip only, stick-slip
with the string, and stick-slip with the string on four materials in
regions -- three ways, interleaved in the same run:

- ``ms_per_tick``: `Pipeline.step_arrays`, the batch step from sample arrays
  to contact arrays (what a caller with array input gets);
- ``wire_ms_per_tick``: `Pipeline.step`, the daemon's call today: PenSample
  objects in, one protocol dictionary per contact out;
- ``naive_ms_per_tick``: `NaivePipeline.step`, one ContactSim per contact
  (the pipeline before the batch step), same input and output as step.

Prints the median cost per tick, writes scene.{json,txt,png} in the results
folder (--save: bench/results/), and checks the issue's targets.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import statistics
import time
from typing import Any

from stiction.bench._support import results_dir
from stiction.daemon.mapping import AreaMapping, MappingConfig
from stiction.drivers.sample import PenSample
from stiction.scene.backend import SimulatorBackend
from stiction.scene.load import parse_scene
from stiction.scene.pipeline import DeviceRun, NaivePipeline, Pipeline, SampleArrays

SIZE = (0.2, 0.15)
DISPLAY = (1920, 1080)
SCENES = {
    "pass-through": "[scene]\neffects = []\n",
    "stick-slip": '[scene]\neffects = ["stick_slip"]\noutside = "m"\n'
    "[materials.m]\nmu_s = 0.7\nmu_k = 0.1\n",
    "stick-slip+string": '[scene]\neffects = ["stick_slip", "string"]\noutside = "m"\n'
    "[materials.m]\nmu_s = 0.7\nmu_k = 0.1\n",
}
MATERIALS = (
    '[scene]\ndisplay = [1920, 1080]\neffects = ["stick_slip", "string"]\noutside = "paper"\n'
    "[materials.paper]\nmu_s = 0.7\nmu_k = 0.1\n"
    "[materials.glue]\nmu_s = 1.2\nmu_k = 0.3\nk = 0.2\n"
    "[materials.ice]\nmu_s = 0.1\nmu_k = 0.05\n"
    "[materials.rubber]\nmu_s = 0.9\nmu_k = 0.6\nC_l = 1500\n"
    '[[regions]]\nshape = "rect"\nrect = [0, 0, 960, 540]\nmaterial = "glue"\n'
    '[[regions]]\nshape = "circle"\ncenter = [1440, 270]\nradius = 300\nmaterial = "ice"\n'
    '[[regions]]\nshape = "polygon"\npoints = [[200, 600], [900, 650], [500, 1080]]\n'
    'material = "rubber"\n'
    '[[regions]]\nshape = "rect"\nrect = [1200, 700, 300, 300]\nmaterial = "pass-through"\n'
)
SCENES["materials+string"] = MATERIALS
TARGET_SCENE = "materials+string"
TARGETS = {1000: 0.1, 10: 0.015}
"""ms per tick for the batch step of TARGET_SCENE (issue 14)."""


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


def _pipelines(scene_text: str) -> tuple[Pipeline, NaivePipeline]:
    backend = SimulatorBackend()
    scene = parse_scene(scene_text, "bench")
    defaults = backend.defaults()
    return Pipeline(scene, backend, defaults), NaivePipeline(scene, backend, defaults)


def _time_once(scene_text: str, ticks: list[list[PenSample]], way: str) -> float:
    """Median seconds per tick over the timed ticks of one fresh pipeline."""
    batch, naive = _pipelines(scene_text)
    dev = DeviceRun(AreaMapping(SIZE, DISPLAY, MappingConfig()))
    arrays = [SampleArrays.from_samples(b) for b in ticks]
    costs = []
    prev = -math.inf
    for n, samples in enumerate(ticks):
        t = (n + 1) * 0.01
        if way == "batch":
            a = arrays[n]
            t0 = time.perf_counter()
            batch.step_arrays(dev, t, prev, a)
        elif way == "wire":
            t0 = time.perf_counter()
            batch.step(dev, t, prev, samples)
        else:
            t0 = time.perf_counter()
            naive.step(dev, t, prev, samples)
        costs.append(time.perf_counter() - t0)
        prev = t
    warm = max(1, len(costs) // 10)
    return statistics.median(costs[warm:])


WAYS = ("batch", "wire", "naive")


def _time_all(ticks: list[list[PenSample]], repeats: int) -> dict[tuple[str, str], float]:
    """Best of `repeats` for every scene and way, interleaved within each repeat.

    The input samples are frozen out of the garbage collector first: freshly
    built, they are young objects that the first scene timed would otherwise
    pay to traverse (that made the first scene look twice as slow)."""
    gc.collect()
    gc.freeze()
    try:
        best = {(name, way): math.inf for name in SCENES for way in WAYS}
        for _ in range(repeats):
            for name, text in SCENES.items():
                for way in WAYS:
                    best[name, way] = min(best[name, way], _time_once(text, ticks, way))
        return best
    finally:
        gc.unfreeze()


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(prog="stiction bench scene", description=__doc__)
    ap.add_argument("--json", action="store_true", help="print the results as JSON")
    ap.add_argument("--quick", action="store_true", help="fewer ticks (a smoke run)")
    args = ap.parse_args(argv)

    from stiction.sim.batch import load_kernel

    kernel = load_kernel()
    if kernel is not None:
        kernel.warm_up()  # compile (or load) outside the timed ticks
    rows = []
    for contacts in (1, 10, 1000):
        n_ticks = (20 if args.quick else 200) if contacts < 1000 else (5 if args.quick else 30)
        repeats = 1 if args.quick else 3
        ticks = _ticks(contacts, n_ticks)
        best = _time_all(ticks, repeats)
        for name in SCENES:
            cost = best[name, "batch"]
            naive = best[name, "naive"]
            rows.append(
                {
                    "scene": name,
                    "contacts": contacts,
                    "ms_per_tick": cost * 1e3,
                    "us_per_contact": cost * 1e6 / contacts,
                    "wire_ms_per_tick": best[name, "wire"] * 1e3,
                    "naive_ms_per_tick": naive * 1e3,
                    "naive_over_batch": naive / cost,
                    "fits_10ms_tick": best[name, "wire"] < 0.01,
                }
            )
    cost_of = {
        int(r["contacts"]): float(r["ms_per_tick"]) for r in rows if r["scene"] == TARGET_SCENE
    }
    targets = {
        f"{TARGET_SCENE} {n} contacts <= {ms} ms": cost_of[n] <= ms for n, ms in TARGETS.items()
    }
    load = os.getloadavg()[0]
    lines = [
        "scene cost per tick: batch step (arrays), batch step with PenSamples and dicts (wire),",
        "naive per-contact pipeline (one ContactSim per contact), same run; median of ticks, best",
        f"of repeats; load average at start {load:.2f} on {os.cpu_count()} CPUs"
        + (" (quick run)" if args.quick else ""),
        "",
        f"{'scene':<20}{'contacts':>9}{'ms/tick':>10}{'us/contact':>12}"
        f"{'wire ms':>10}{'naive ms':>10}{'naive/batch':>13}",
    ]
    for r in rows:
        lines.append(
            f"{r['scene']:<20}{r['contacts']:>9}{r['ms_per_tick']:>10.4f}"
            f"{r['us_per_contact']:>12.3f}{r['wire_ms_per_tick']:>10.4f}"
            f"{r['naive_ms_per_tick']:>10.4f}{r['naive_over_batch']:>12.1f}x"
        )
    lines.append("")
    lines.append(
        "targets: " + ", ".join(f"{k} {'PASS' if ok else 'FAIL'}" for k, ok in targets.items())
    )
    table = "\n".join(lines)
    (results_dir() / "scene.txt").write_text(table + "\n")
    (results_dir() / "scene.json").write_text(
        json.dumps({"rows": rows, "targets": targets, "quick": args.quick}, indent=2)
    )
    _plot(rows)
    if args.json:
        for r in rows:
            print(json.dumps(r))
    else:
        print(table)
    return 0


def _plot(rows: list[dict[str, Any]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for name in SCENES:
        pts = [(r["contacts"], r["ms_per_tick"]) for r in rows if r["scene"] == name]
        ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=f"{name} (batch)")
    pts = [(r["contacts"], r["naive_ms_per_tick"]) for r in rows if r["scene"] == TARGET_SCENE]
    ax.plot([p[0] for p in pts], [p[1] for p in pts], "k:", marker="x", label="naive, materials")
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

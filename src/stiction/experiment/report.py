"""The analysis report: report.md with figures in the paper's form (PNG) and results.json.

Every number in the text comes from the result dicts of `analysis.analyze`,
and each section says how it was computed, so that a reader can redo any of
it from the CSV files without the toolkit.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from stiction.experiment import psychometric as ps
from stiction.experiment.trials import AnalysisError


def _f(v: float, digits: int = 3) -> str:
    if v is None or math.isnan(v):
        return "n/a"
    return f"{v:.{digits}g}"  # inf for an unbounded interval end


def _ci(pair: list[float]) -> str:
    return f"[{_f(pair[0])}, {_f(pair[1])}]"


def _pval(v: float) -> str:
    return "< 0.0001" if v < 1e-4 else f"{v:.4f}"


def _p(v: float) -> str:
    """'p' followed by this: '= 0.0123' or '< 0.0001'."""
    return "< 0.0001" if v < 1e-4 else f"= {v:.4f}"


def _label(r: dict[str, Any]) -> str:
    return "with string" if r["string"] else "without string"


def _figure_study1(results: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.0, 3.6), dpi=120)
    for r, marker in zip(results, ("o", "s", "^", "D"), strict=False):
        x = np.array(r["levels"])
        line = ax.errorbar(
            x,
            r["proportion_mean"],
            yerr=r["proportion_se"],
            fmt=marker,
            capsize=3,
            label=f"{_label(r)} (mean ± SE)",
        )
        if math.isfinite(r["a"]):
            xs = np.linspace(x.min(), x.max(), 200)
            ax.plot(xs, ps.logistic(xs, r["a"], r["b"]), color=line[0].get_color(), lw=1)
    ax.set_xlabel("static friction coefficient $\\mu_s$ of the comparison")
    ax.set_ylabel("P(comparison more frictional)")
    ax.set_ylim(-0.02, 1.02)
    ax.axhline(0.5, color="0.8", lw=0.8, zorder=0)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _figure_study2(r: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.0, 3.6), dpi=120)
    x = np.array(r["levels"])
    ax.errorbar(x, r["mean"], yerr=r["se"], fmt="o", capsize=3, label="mean ± SE")
    xs = np.linspace(x.min(), x.max(), 200)
    k, beta = r["stevens"]["k"], r["stevens"]["beta"]
    ax.plot(xs, k * xs**beta, lw=1, label=f"$\\phi = {k:.3g}\\,\\mu_s^{{{beta:.3g}}}$")
    ax.set_xlabel("static friction coefficient $\\mu_s$ of the comparison")
    ax.set_ylabel("ratio comparison / standard")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def _study1_text(study: str, results: list[dict[str, Any]], figure: str) -> list[str]:
    out = [f"## {study}: two-alternative forced choice", "", f"![{study}]({figure})", ""]
    first = results[0]
    out += [
        f"Participants: {first['participants']}; bootstrap: {first['bootstrap']['n']} "
        f"resamples of {first['bootstrap']['resample']}, percentile 95% intervals.",
        "",
        "Points: per comparison mu_s, the mean over participants of each participant's "
        "proportion of 'comparison more frictional', with its standard error "
        "(sample SD over participants / sqrt(participants)). Curves: the paper's logistic "
        "f(x) = 1/(1 + exp(-A (x - B))) fitted to the pooled answers by maximum likelihood "
        "(logistic regression of the answers on mu_s). PSE = B; JND = the 75% point minus "
        "the PSE = ln(3)/A; all on the mu_s axis.",
        "",
        "| condition | trials | A (1/mu_s) | B = PSE (mu_s) | JND (mu_s) | no finite fit in |",
        "|---|---|---|---|---|---|",
    ]
    for r in results:
        out.append(
            f"| {_label(r)} | {r['trials']} | {_f(r['a'])} {_ci(r['a_ci'])} | "
            f"{_f(r['pse'])} {_ci(r['pse_ci'])} | {_f(r['jnd'])} {_ci(r['jnd_ci'])} | "
            f"{r['bootstrap']['failed']} of {r['bootstrap']['n']} resamples |"
        )
    out += [
        "",
        "With guess and lapse rates: psi(x) = gamma + (1 - gamma - lambda) f(x), "
        "gamma in [0, 0.5], lambda in [0, 0.1], by maximum likelihood (a grid over gamma and "
        "lambda with the slope and PSE fitted at each point, then L-BFGS-B; the bootstrap "
        "uses the grid, steps 0.05 and 0.01). PSE and JND are those of the inner f.",
        "",
        "| condition | A | PSE | JND | guess gamma | lapse lambda |",
        "|---|---|---|---|---|---|",
    ]
    for r in results:
        g = r["guess_lapse"]
        out.append(
            f"| {_label(r)} | {_f(g['a'])} {_ci(g['a_ci'])} | {_f(g['pse'])} {_ci(g['pse_ci'])} "
            f"| {_f(g['jnd'])} {_ci(g['jnd_ci'])} | {_f(g['guess'])} {_ci(g['guess_ci'])} "
            f"| {_f(g['lapse'])} {_ci(g['lapse_ci'])} |"
        )
    out += [
        "",
        "Per participant (the paper's logistic; intervals from resampling that participant's "
        "trials within each level; a fit of perfectly separated answers has no finite slope "
        "and is reported as n/a, as is the JND of a curve that does not rise):",
        "",
        "| condition | participant | PSE | JND | A | guess/lapse fit: PSE | JND | gamma | lambda |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in results:
        for p in r["per_participant"]:
            g = p["guess_lapse"]
            out.append(
                f"| {_label(r)} | {p['participant']} | {_f(p['pse'])} {_ci(p['pse_ci'])} | "
                f"{_f(p['jnd'])} {_ci(p['jnd_ci'])} | {_f(p['a'])} | {_f(g['pse'])} "
                f"{_ci(g['pse_ci'])} | {_f(g['jnd'])} {_ci(g['jnd_ci'])} | {_f(g['guess'])} "
                f"| {_f(g['lapse'])} |"
            )
    return [*out, ""]


def _study2_text(r: dict[str, Any], figure: str) -> list[str]:
    a = r["anova"]
    m = r["mauchly"]
    st = r["stevens"]
    out = [
        f"## {r['study']}: ratio estimation ({_label(r)})",
        "",
        f"![{r['study']}]({figure})",
        "",
        f"Participants: {r['participants']}; trials: {r['trials']}. Each participant's ratios "
        "are averaged per mu_s first; points are the means of those over participants with "
        "their standard error.",
        "",
        "| mu_s | " + " | ".join(_f(v) for v in r["levels"]) + " |",
        "|---" * (len(r["levels"]) + 1) + "|",
        "| mean ratio | " + " | ".join(_f(v) for v in r["mean"]) + " |",
        "| SE | " + " | ".join(_f(v, 2) for v in r["se"]) + " |",
        "| Shapiro-Wilk p | " + " | ".join(_pval(s["p"]) for s in r["shapiro"]) + " |",
        "",
        "Shapiro-Wilk (pingouin.normality) on the participant means at each level. "
        f"Mauchly's sphericity test (pingouin.sphericity): W = {_f(m['w'])}, "
        f"chi2({m['dof']}) = {_f(m['chi2'])}, p {_p(m['p'])}: sphericity "
        f"{'holds' if m['spherical'] else 'is rejected'} at alpha 0.05.",
        "",
        "One-way repeated-measures ANOVA of the ratio on mu_s (pingouin.rm_anova): "
        f"F({_f(a['df1'])}, {_f(a['df2'])}) = {_f(a['f'])}, p {_p(a['p'])}"
        + (
            f", Greenhouse-Geisser corrected (epsilon = {_f(a['eps_gg'])}; uncorrected "
            f"p {_p(a['p_uncorrected'])})."
            if a["correction"]
            else f" (sphericity holds, no correction; Greenhouse-Geisser epsilon would be "
            f"{_f(a['eps_gg'])}, p {_p(a['p_gg'])})."
        ),
        "",
        "Tukey HSD post-hoc comparisons (pingouin.pairwise_tukey on the participant means; "
        "it treats the levels as independent groups, as a between-subjects Tukey test does), "
        "pairs with p < 0.05:",
        "",
    ]
    sig = [t for t in r["tukey"] if t["p"] < 0.05]
    out += [
        f"- mu_s {_f(t['a'])} vs {_f(t['b'])}: difference {_f(t['diff'])}, p {_p(t['p'])}"
        for t in sig
    ] or ["- none"]
    out += [
        "",
        "Stevens' power function phi = k mu_s^beta, least squares on the level means "
        f"(scipy.optimize.curve_fit): k = {_f(st['k'])} (SE {_f(st['k_se'], 2)}, "
        f"95% interval {_ci(st['k_ci'])}), beta = {_f(st['beta'])} "
        f"(SE {_f(st['beta_se'], 2)}, 95% interval {_ci(st['beta_ci'])}). The standard errors "
        f"are the fit's (from the scatter of the {len(r['levels'])} means about the curve); "
        "the intervals are "
        "the percentile bootstrap over participants and their trials, as for study 1.",
        "",
    ]
    return out


def jsonable(obj: Any) -> Any:
    """`obj` with NaN and infinities as null: JSON has no NaN, and a missing fit is 'no value'."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v) for v in obj]
    return obj


def write(results: list[dict[str, Any]], out: Path) -> Path:
    """Write report.md, its PNG figures and results.json into `out`; return report.md's path."""
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise AnalysisError(f"{out}: cannot create the report folder: {exc.strerror}") from None
    lines = [
        "# Analysis report",
        "",
        "Generated by `stiction experiment analyze`; all numbers below are in results.json "
        "too. The mu_s axis is the comparison's static friction coefficient as set.",
        "",
    ]
    studies1: dict[str, list[dict[str, Any]]] = {}
    for r in results:
        if r["method"] == "2afc":
            studies1.setdefault(r["study"], []).append(r)
    index = 0
    for study, rs in studies1.items():
        index += 1
        name = f"study1-{index}.png"
        _figure_study1(rs, out / name)
        lines += _study1_text(study, rs, name)
    for r in results:
        if r["method"] == "ratio":
            index += 1
            name = f"study2-{index}.png"
            _figure_study2(r, out / name)
            lines += _study2_text(r, name)
    report = out / "report.md"
    report.write_text("\n".join(lines))
    (out / "results.json").write_text(
        json.dumps(jsonable(results), indent=1, allow_nan=False) + "\n"
    )
    return report

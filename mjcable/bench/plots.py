"""Plots and tables of sweep results: work-precision plots, Pareto fronts, the stiffness-effect grid, stability maps.

All functions take rows as :func:`mjcable.bench.results.read_rows` returns them and write PNG (matplotlib, Agg;
atomically, :mod:`mjcable.io`) or return Markdown.
"""

from __future__ import annotations

import json
import math
import os
from typing import Dict, Iterable, List, Optional, Sequence

import numpy as np

from mjcable.bench import case as case_mod
from mjcable.bench.outcome import OUTCOMES
from mjcable.io import atomic_write

__all__ = [
    "pareto_front",
    "work_precision",
    "pareto_markdown",
    "cheapest_markdown",
    "stiffness_grid_png",
    "stiffness_grid_markdown",
    "stability_map",
    "outcome_markdown",
    "OUTCOME_COLORS",
]

_COLORS = {"stable": "#3a9d4a", "tunneled": "#e0a030", "diverged": "#d03c30", "rejected": "#9a9a9a"}
OUTCOME_COLORS = {o: _COLORS[o] for o in OUTCOMES}  # a new outcome without a colour fails here, at import
_MARKERS = "osD^vP*Xph"  # one per model label, in label order (mjcable.bench.case.labels)
_DPI = 110


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(plt, fig, path) -> None:
    """Write ``fig`` to ``path`` atomically (:func:`mjcable.io.atomic_write`; format from the suffix, PNG by
    default) and close it."""
    try:
        with atomic_write(path, "wb") as f:
            fig.savefig(f, format=os.path.splitext(str(path))[1][1:] or "png", dpi=_DPI)
    finally:
        plt.close(fig)


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and math.isfinite(v)


def _usable(rows: Iterable[dict]) -> List[dict]:
    return [r for r in rows if r.get("outcome") == "stable" and _finite(r.get("error"))
            and _finite(r.get("wall_per_sim_s")) and r["wall_per_sim_s"] > 0]


def _models(rows: Iterable[dict]) -> List[str]:
    """The model labels of ``rows`` in label order (labels no longer registered last, by name)."""
    return sorted({r["model"] for r in rows}, key=lambda m: (case_mod.rank(m), m))


def _style(model: str, plt) -> tuple:
    """``(colour, marker)`` of a model label, the same in every plot."""
    rank = case_mod.rank(model)
    return plt.get_cmap("tab10")(rank % 10), _MARKERS[rank % len(_MARKERS)]


def pareto_front(rows: Iterable[dict]) -> List[dict]:
    """Rows not dominated in (cost ``wall_per_sim_s``, ``error``), sorted by cost: each is cheaper than, or more
    accurate than, every other; only ``stable`` rows with a finite error count."""
    front, best = [], math.inf
    for r in sorted(_usable(rows), key=lambda r: (r["wall_per_sim_s"], r["error"])):
        if r["error"] < best:
            front.append(r)
            best = r["error"]
    return front


def _settings_label(r: dict) -> str:
    parts = [f"dt={r['dt']:g}"]
    for k in ("substeps", "iterations"):
        if _finite(r.get(k)):
            parts.append(f"{k}={int(r[k])}")
    if _finite(r.get("n_segments")) and int(r["n_segments"]) != 50:
        parts.append(f"n={int(r['n_segments'])}")
    return ", ".join(parts)


def work_precision(rows: Sequence[dict], scenario: str, path: str, *, title: Optional[str] = None) -> bool:
    """Write the log-log work-precision plot of one scenario: error against wall time per simulated second, all
    stable runs as faint markers and each model's Pareto front as a line.

    Returns:
      True when the plot was written (False: no stable run with a finite error).
    """
    rows = [r for r in rows if r["scenario"] == scenario]
    usable = _usable(rows)
    if not usable:
        return False
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    for model in _models(usable):
        mine = [r for r in usable if r["model"] == model]
        color, marker = _style(model, plt)
        ax.scatter([r["wall_per_sim_s"] for r in mine], [max(r["error"], 1e-16) for r in mine], s=14,
                   color=color, alpha=0.3, marker=marker)
        front = pareto_front(mine)
        ax.plot([r["wall_per_sim_s"] for r in front], [max(r["error"], 1e-16) for r in front], "-",
                marker=marker, color=color, label=model, markersize=5)
    ax.set_xscale("log")
    ax.set_yscale("log")
    kind = rows[0].get("error_kind", "")
    ax.set_xlabel("wall time per simulated second (s/s)")
    ax.set_ylabel(f"error ({kind})" if kind else "error")
    ax.set_title(title or f"{scenario}: error against cost (lines: each model's Pareto front)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    _save(plt, fig, path)
    return True


def pareto_markdown(rows: Sequence[dict]) -> str:
    """Markdown tables, one per scenario, of each model's Pareto front (cost, error, strain, settings), plus the
    models that never ran stably."""
    out = []
    for scenario in dict.fromkeys(r["scenario"] for r in rows):
        mine = [r for r in rows if r["scenario"] == scenario]
        kind = mine[0].get("error_kind", "")
        out.append(f"### {scenario}\n")
        out.append(f"| model | settings | wall s per sim s | error ({kind}) | max strain | max penetration (m) |")
        out.append("|---|---|---|---|---|---|")
        for model in _models(mine):
            front = pareto_front([r for r in mine if r["model"] == model])
            if not front:
                outcomes = sorted({r["outcome"] for r in mine if r["model"] == model})
                out.append(f"| {model} | (no stable run with an error: {', '.join(outcomes)}) | | | | |")
                continue
            for r in front:
                out.append(f"| {model} | {_settings_label(r)} | {r['wall_per_sim_s']:.3g} | {r['error']:.3g} | "
                           f"{r['max_strain']:.2g} | {r['max_penetration']:.2g} |")
        out.append("")
    return "\n".join(out)


def cheapest_markdown(rows: Sequence[dict], target: float) -> str:
    """A Markdown table of each model's cheapest stable run (least ``wall_per_sim_s``) whose error is within
    ``target``: its n_segments, dt, substeps, iterations, error and cost; a model that never reaches it gets its
    lowest error and that run's cost instead."""
    lines = [f"| model | reaches {target:g}? | n_segments | dt (s) | substeps | iterations | error | "
             "wall s per sim s |", "|---|---|---|---|---|---|---|---|"]
    for model in _models(rows):
        mine = _usable(r for r in rows if r["model"] == model)
        if not mine:
            outcomes = sorted({r["outcome"] for r in rows if r["model"] == model})
            lines.append(f"| {model} | no stable run ({', '.join(outcomes)}) | | | | | | |")
            continue
        within = [r for r in mine if r["error"] <= target]
        if within:
            r, verdict = min(within, key=lambda r: r["wall_per_sim_s"]), "yes"
        else:
            r, verdict = min(mine, key=lambda r: r["error"]), "no: its lowest error"
        cells = [int(r["n_segments"]), f"{r['dt']:g}"] + [int(r[k]) if _finite(r.get(k)) else "–"
                                                          for k in ("substeps", "iterations")]
        lines.append(f"| {model} | {verdict} | " + " | ".join(str(c) for c in cells)
                     + f" | {r['error']:.2g} | {r['wall_per_sim_s']:.3g} |")
    return "\n".join(lines) + "\n"


def stiffness_grid_png(results: Dict[str, Dict[tuple, np.ndarray]], path: str, *, iterations: Sequence[int],
                       dts: Sequence[float], start: Optional[np.ndarray] = None, time: float = 0.25) -> None:
    """The stiffness-effect grid as one image: per model a block of rows (dt) × columns (iterations) showing the
    cable's x-z shape at ``time``, blocks two abreast; a dashed line marks the rest length's reach from the pin.

    Args:
      results: ``{model: {(iterations, dt): (n, 3) positions or None}}``.
      path: PNG path.
      iterations, dts: the grid's columns and rows.
      start: ``(n, 3)`` start positions drawn faintly in every cell.
      time: the simulated time of the shapes, for the title.
    """
    plt = _plt()
    models = list(results)
    nrow, ncol = len(dts), len(iterations)
    blocks_across = min(2, len(models))
    blocks_down = (len(models) + blocks_across - 1) // blocks_across
    fig, axes = plt.subplots(nrow * blocks_down, ncol * blocks_across,
                             figsize=(2.3 * ncol * blocks_across, 1.7 * nrow * blocks_down), squeeze=False)
    for ax in axes.flat:
        ax.set_visible(False)
    for b, model in enumerate(models):
        r0, c0 = (b // blocks_across) * nrow, (b % blocks_across) * ncol
        for i, dt in enumerate(dts):
            for j, it in enumerate(iterations):
                ax = axes[r0 + i, c0 + j]
                ax.set_visible(True)
                x = results[model].get((it, dt))
                if start is not None:
                    ax.plot(start[:, 0], start[:, 2], color="0.8", lw=1)
                    reach = float(np.sum(np.linalg.norm(np.diff(start, axis=0), axis=1)))
                    ax.axvline(start[0, 0] + reach, color="0.6", lw=0.8, ls="--")
                if x is not None and np.all(np.isfinite(x)):
                    ax.plot(x[:, 0], x[:, 2], color="#c0401c", lw=1.5)
                    ax.plot(x[-1, 0], x[-1, 2], "o", color="#c0401c", ms=3)
                    stretch = float(np.sum(np.linalg.norm(np.diff(x, axis=0), axis=1)))
                    if start is not None:
                        ax.text(0.97, 0.9, f"+{stretch / reach - 1:.1%}", transform=ax.transAxes, ha="right",
                                va="top", fontsize=6)
                else:
                    ax.text(0.5, 0.5, "failed", ha="center", va="center", transform=ax.transAxes, color="#d03c30")
                ax.set_aspect("equal", adjustable="datalim")
                ax.tick_params(labelsize=5)
                if i == 0:
                    ax.set_title(f"{model}: iterations={it}", fontsize=7)
                if j == 0:
                    ax.set_ylabel(f"dt={dt:g} s", fontsize=7)
    fig.suptitle(f"stiffness effects: the cable at t = {time:g} s (grey: start; dashed: rest length from the pin; "
                 "label: elongation)", fontsize=9)
    fig.tight_layout()
    _save(plt, fig, path)


def stiffness_grid_markdown(rows: Sequence[dict], *, iterations: Sequence[int], dts: Sequence[float]) -> str:
    """Markdown: per model a table of the cable's elongation (total length / rest length − 1) at the grid's time,
    rows dt, columns iterations; ``diverged`` etc. where a run failed."""
    out = []
    for model in _models(rows):
        out.append(f"**{model}**: elongation (length / rest length − 1) at the end\n")
        out.append("| dt \\ iterations | " + " | ".join(str(i) for i in iterations) + " |")
        out.append("|---" * (len(iterations) + 1) + "|")
        for dt in dts:
            cells = []
            for it in iterations:
                match = [r for r in rows if r["model"] == model and math.isclose(r["dt"], dt)
                         and _finite(r.get("iterations")) and int(r["iterations"]) == it]
                if not match:
                    cells.append("–")
                elif match[-1]["outcome"] != "stable":
                    cells.append(match[-1]["outcome"])
                else:
                    cells.append(f"{match[-1]['error']:.3g}")
            out.append(f"| {dt:g} | " + " | ".join(cells) + " |")
        out.append("")
    return "\n".join(out)


def stability_map(rows: Sequence[dict], model: str, path: str) -> bool:
    """Write one model's stability map: a panel per stress family, the family's parameter against dt, each cell
    coloured by outcome. Returns False when the model has no rows."""
    mine = [r for r in rows if r["model"] == model]
    if not mine:
        return False
    plt = _plt()
    families = list(dict.fromkeys(r["scenario"] for r in mine))
    fig, axes = plt.subplots(1, len(families), figsize=(3.4 * len(families), 3.2), squeeze=False)
    for ax, family in zip(axes[0], families):
        cells = [r for r in mine if r["scenario"] == family]
        param = _family_param(cells)
        values = sorted({_param_value(r, param) for r in cells})
        dts = sorted({r["dt"] for r in cells})
        for r in cells:
            i, j = dts.index(r["dt"]), values.index(_param_value(r, param))
            ax.add_patch(plt.Rectangle((i - 0.45, j - 0.45), 0.9, 0.9,
                                       color=OUTCOME_COLORS.get(r["outcome"], "black")))
            ax.text(i, j, r["outcome"], ha="center", va="center", fontsize=6, color="white"
                    if r["outcome"] in ("stable", "diverged") else "black")
        ax.set_xlim(-0.5, len(dts) - 0.5)
        ax.set_ylim(-0.5, len(values) - 0.5)
        ax.set_xticks(range(len(dts)), [f"{d:g}" for d in dts], fontsize=7)
        ax.set_yticks(range(len(values)), [f"{v:g}" for v in values], fontsize=7)
        ax.set_xlabel("dt (s)", fontsize=8)
        ax.set_ylabel(param, fontsize=8)
        ax.set_title(family, fontsize=9)
    handles = [plt.Rectangle((0, 0), 1, 1, color=c) for c in OUTCOME_COLORS.values()]
    fig.legend(handles, list(OUTCOME_COLORS), loc="lower center", ncol=len(OUTCOME_COLORS), fontsize=7)
    fig.suptitle(f"{model}: stability map", fontsize=10)
    fig.tight_layout(rect=(0, 0.08, 1, 0.95))
    _save(plt, fig, path)
    return True


def _family_param(rows: Sequence[dict]) -> str:
    keys = set()
    for r in rows:
        keys |= set(json.loads(r.get("params") or "{}"))
    keys.discard("variant")
    return sorted(keys)[0] if keys else "n_segments"


def _param_value(row: dict, param: str) -> float:
    if param == "n_segments":
        return float(row["n_segments"])
    return float(json.loads(row.get("params") or "{}").get(param, math.nan))


def outcome_markdown(rows: Sequence[dict]) -> str:
    """Markdown: counts of each outcome per model, and every failed run's reason."""
    out = ["| model | " + " | ".join(OUTCOME_COLORS) + " |", "|---" * (len(OUTCOME_COLORS) + 1) + "|"]
    for model in _models(rows):
        mine = [r for r in rows if r["model"] == model]
        out.append(f"| {model} | " + " | ".join(str(sum(r["outcome"] == o for r in mine)) for o in OUTCOME_COLORS)
                   + " |")
    out.append("")
    out.append("| scenario | model | dt | n_segments | params | outcome | reason |")
    out.append("|---|---|---|---|---|---|---|")
    for r in rows:
        if r["outcome"] in ("diverged", "tunneled", "rejected"):
            out.append(f"| {r['scenario']} | {r['model']} | {r['dt']:g} | {int(r['n_segments'])} | {r['params']} | "
                       f"{r['outcome']} | {str(r['reason']).replace('|', '/')[:160]} |")
    return "\n".join(out) + "\n"


"""Convergence figures: best-so-far and iteration-mean cost per iteration, success rate on a
twin axis."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..errors import ParamError
from ._common import figure_axes, legend_outside


def _masked(values) -> np.ma.MaskedArray:
    # Iterations with no successful ant carry inf (or NaN): mask them so lines just break there.
    return np.ma.masked_invalid(np.asarray(values, dtype=float).ravel())


def _run_labels(label: str | Sequence[str] | None, n_runs: int) -> list[str | None]:
    """One label per run from ``label=``: None where the run's own ``"label"`` (or ``run i``) will
    name it."""
    if label is None:
        return [None] * n_runs
    if isinstance(label, str):
        return [label] if n_runs == 1 else [f"{label} {k}" for k in range(n_runs)]
    labels: list[str | None] = [str(lab) for lab in label]
    if len(labels) != n_runs:
        raise ParamError(f"{len(labels)} labels for {n_runs} histories")
    return labels


def _draw_run(ax: Axes, twin: Axes | None, run: dict[str, Any], lab: str, color: str) -> Axes | None:
    """One run's lines: best so far and iteration mean on ``ax``, the success rate on the twin axis
    (made on first need); returns the twin axis, None while no run had a success rate."""
    best = np.asarray(run["best"], dtype=float).ravel()
    # Running minimum; inf stays inf until the first success and is then masked.
    best_so_far = _masked(np.minimum.accumulate(np.where(np.isnan(best), np.inf, best)))
    iters = np.arange(len(best))
    ax.plot(iters, best_so_far, color=color, linewidth=2.0, label=f"{lab} best so far")
    if run.get("mean") is not None:
        mean = _masked(run["mean"])
        ax.plot(
            np.arange(len(mean)),
            mean,
            color=color,
            linewidth=1.2,
            linestyle="--",
            alpha=0.8,
            label=f"{lab} iteration mean",
        )
    if run.get("success_rate") is not None:
        if twin is None:
            twin = ax.twinx()
            twin.set_ylim(0.0, 1.05)
            twin.set_ylabel("success rate")
        rate = _masked(run["success_rate"])
        twin.plot(
            np.arange(len(rate)),
            rate,
            color=color,
            linewidth=1.0,
            linestyle=":",
            alpha=0.9,
            label=f"{lab} success rate",
        )
    return twin


def plot_convergence(
    history: dict[str, Any] | Sequence[dict[str, Any]],
    *,
    ax: Axes | None = None,
    optimal: float | None = None,
    label: str | Sequence[str] | None = None,
    title: str | None = None,
    ylabel: str = "path cost",
) -> Figure:
    """Best-so-far (solid) and iteration mean (dashed) cost per iteration, for one run or several.

    ``history`` is a dict with arrays under ``"best"`` (iteration best or best-so-far: the running
    minimum is drawn) and ``"mean"`` (optional), and optionally ``"success_rate"`` (drawn dotted on a
    twin axis, 0..1: the share of the iteration's ants that reached the goal) and ``"label"``; or a
    list of such dicts. ``label`` is a string for one run or a
    list of strings, one per run (default: the dict's ``"label"``, else ``run i``). Inf or NaN values
    (iterations where no ant arrived) are masked. ``optimal`` adds a dashed horizontal line.
    ``ylabel``: the y axis's label (the cost a planner minimises; for most planners it is the path
    length, so ``ylabel="path length"`` says so). The legend sits beside the axes (and beside the
    success rate's axis).
    """
    runs = [history] if isinstance(history, dict) else list(history)
    if not runs:
        raise ParamError("plot_convergence needs at least one history")
    labels = _run_labels(label, len(runs))
    fig, ax = figure_axes(ax, figsize=(7.0, 4.5))
    twin = None
    for k, (run, lab) in enumerate(zip(runs, labels)):
        if "best" not in run:
            raise ParamError(f"history {k} has no 'best' array (keys: {sorted(run)})")
        if lab is None:
            lab = str(run.get("label", f"run {k}" if len(runs) > 1 else "run"))
        twin = _draw_run(ax, twin, run, lab, color=f"C{k % 10}")
    if optimal is not None:
        ax.axhline(float(optimal), color="black", linestyle="--", linewidth=1.0, label=f"optimum {float(optimal):.4g}")
    ax.set_xlabel("iteration")
    ax.set_ylabel(ylabel)
    if title is not None:
        ax.set_title(title)
    handles, names = ax.get_legend_handles_labels()
    if twin is not None:
        h2, n2 = twin.get_legend_handles_labels()
        handles, names = handles + h2, names + n2
    legend_outside(ax, handles, names, beside=[twin] if twin is not None else [])
    return fig

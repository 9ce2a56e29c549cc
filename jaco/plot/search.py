"""Figures of a search (:func:`jaco.search`): the anytime history, parameter importance and the
planner's effect, contours over two parameters, the Pareto front of two objectives."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from ..errors import ParamError
from ._common import PLANNER_COLUMNS, figure_axes, legend_outside

if TYPE_CHECKING:
    import pandas as pd
    from numpy.typing import ArrayLike

    from ..research.search import Study

    #: One search study, a list of them, or a dict label -> study.
    Studies = Study | Sequence[Study] | Mapping[str, Study]


def _studies(studies: Studies) -> dict[str, Study]:
    """A :class:`jaco.research.search.Study`, a list of them or a dict label -> study."""
    from ..research.search import Study

    if isinstance(studies, Study):
        studies = {studies.info["sampler"]: studies}
    elif isinstance(studies, (list, tuple)):
        studies = {
            f"{s.info['sampler']} ({s.study.study_name})"
            if sum(t.info["sampler"] == s.info["sampler"] for t in studies) > 1
            else s.info["sampler"]: s
            for s in studies
        }
    if not isinstance(studies, dict) or not studies or not all(isinstance(s, Study) for s in studies.values()):
        raise ParamError("expected a jaco search Study, a list of Studies or a dict label -> Study")
    return studies


def _objective_axis(ax, name: str, axis: str = "y") -> bool:
    """Label an objective's axis; gaps and success rates are fractions shown as %."""
    percent = name in ("gap", "success")
    label = {
        "gap": "gap to the optimum (%)",
        "success": "success rate (%)",
        "length": "path length",
        "turns": "turns",
        "budget": "ants × iterations",
    }.get(name, name)
    (ax.set_ylabel if axis == "y" else ax.set_xlabel)(label)
    return percent


def _log_axis(ax, values) -> None:
    """A log y axis for ``values`` (objective values as drawn): log where all are > 0; symlog,
    linear below the smallest positive value's power of ten, where some are 0 (a gap of 0, the
    optimum: a log axis would drop it); linear where none is > 0. The axis label says which."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    positive = v[v > 0]
    if not positive.size:
        note = " (no value > 0: linear scale)"
    elif (v <= 0).any():
        linthresh = 10.0 ** np.floor(np.log10(positive.min()))
        ax.set_yscale("symlog", linthresh=linthresh, linscale=0.5)
        note = f" (log scale, linear below {linthresh:g})"
    else:
        ax.set_yscale("log")
        note = " (log scale)"
    ax.set_ylabel(ax.get_ylabel() + note)


def plot_search_history(
    studies: Studies, *, x: str = "trials", ax: Axes | None = None, title: str | None = None, log: bool = False
) -> Figure:
    """The anytime curve of one or several searches: the best objective so far (a step line) against
    finished ``trials``, ant-``iterations`` spent (fair across multi-fidelity searches) or wall
    ``time`` (seconds since the first trial started); one line per study (e.g. per sampler), with a
    single study's trial values as points behind it. ``studies``: a Study, a list, or a dict label ->
    Study. The y axis of a gap or success rate is in %. ``log``: a log y axis (symlog, linear near
    0, when a value is 0, e.g. a gap that reached the optimum; the axis label says which)."""
    studies = _studies(studies)
    columns = {"trials": None, "iterations": "iterations", "time": "end_s"}
    if x not in columns:
        raise ParamError(f"x must be one of {', '.join(columns)}, got {x!r}")
    fig, ax = figure_axes(ax, figsize=(7.0, 4.2))
    names = {tuple(s.objectives) for s in studies.values()}
    if len(names) != 1 or len(next(iter(names))) != 1:
        raise ParamError("plot_search_history: the studies must share one objective (several: plot_pareto)")
    name = next(iter(names))[0]
    scale = 100.0 if _objective_axis(ax, name) else 1.0
    shown = []  # every value drawn (for a log axis)
    for label, study in studies.items():
        h = study.history()
        xs = np.arange(1, len(h) + 1) if columns[x] is None else h[columns[x]].to_numpy(float)
        shown.append(scale * h["best"].to_numpy(float))
        (line,) = ax.step(xs, shown[-1], where="post", label=label, linewidth=1.8)
        if len(studies) == 1:
            done = h["state"].eq("COMPLETE").to_numpy()
            shown.append(scale * h["value"].to_numpy(float)[done])
            ax.scatter(xs[done], shown[-1], s=10, alpha=0.35, color=line.get_color(), label="trials")
    if log:
        _log_axis(ax, np.concatenate(shown))
    ax.set_xlabel({"trials": "finished trials", "iterations": "ant-iterations spent", "time": "wall time (s)"}[x])
    ax.set_title(title if title is not None else f"best {name} so far")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", borderaxespad=0.0)
    fig.tight_layout()
    return fig


def _planner_column(table: pd.DataFrame) -> str | None:
    """The table's planner column: ``planner``, else ``variant`` (older tables), else None."""
    return next((c for c in PLANNER_COLUMNS if c in table.columns), None)


def _planner_groups(study: Study, table: pd.DataFrame, planner: Any, what: str) -> list[tuple[Any, pd.DataFrame]]:
    """``[(planner, its rows)]`` of a table of finished trials: one entry per planner the trials
    span (in the order of the study's space, then of appearance), or only ``planner`` (its name or
    short name) when given; ``[(None, table)]`` for a table without a planner column."""
    from ..research.tables import short_name

    column = _planner_column(table)
    if column is None:
        if planner is not None:
            raise ParamError(f"{what}: planner={planner!r}, but the study's trials name no planner")
        return [(None, table)]
    present = list(table[column].dropna().drop_duplicates())
    space = next((study.info["space"].get(c) for c in PLANNER_COLUMNS if c in study.info["space"]), None)
    order = [p for p in (space if isinstance(space, list) else [space]) if p in present]
    names = order + [p for p in present if p not in order]
    if planner is not None:
        chosen = [p for p in names if p == planner or short_name(str(p)) == planner]
        if not chosen:
            raise ParamError(
                f"{what}: no finished trial of planner {planner!r} (its trials' planners: "
                f"{', '.join(map(str, names)) or 'none'})"
            )
        names = chosen[:1]
    return [(p, table[table[column] == p]) for p in names] or [(None, table)]


def _finished(study: Study, what: str) -> tuple[str, pd.DataFrame]:
    """The study's one objective and its finished trials (:attr:`Study.trials` rows, the objective's
    column under the objective's name)."""
    if len(study.objectives) > 1:
        raise ParamError(f"{what}: one objective only")
    table = _by_objective(study, study.trials)
    return study.objectives[0], table[table["state"] == "COMPLETE"]


def _by_objective(study: Study, table: pd.DataFrame) -> pd.DataFrame:
    """Trials with each objective's column (``gap_penalised_mean``, ...:
    :func:`jaco.research.search.objective_column`) named by its objective (``gap``)."""
    from ..research.search import objective_column

    return table.rename(columns={objective_column(n): n for n in study.objectives})


def planner_effect(values: ArrayLike, planners: ArrayLike) -> float:
    """The share of the variance of ``values`` explained by the planner, η² (eta squared): the
    between-planner sum of squares over the total, ``Σ_p n_p (mean_p − mean)² / Σ_i (v_i − mean)²``
    over the finite values, 0 (the planners' means are equal) to 1 (every planner's values are all
    equal: the planner decides everything); NaN when the values do not vary."""
    v = np.asarray(values, float)
    groups = np.asarray(planners, dtype=object)
    if v.shape != groups.shape:
        raise ParamError(f"planner effect: {v.size} values for {groups.size} planners")
    keep = np.isfinite(v)
    v, groups = v[keep], groups[keep]
    total = float(((v - v.mean()) ** 2).sum()) if v.size else 0.0
    if total <= 0.0:
        return float("nan")
    between = sum(
        float((groups == g).sum()) * (float(v[groups == g].mean()) - float(v.mean())) ** 2 for g in set(groups)
    )
    return between / total


def _importance_within(study: Study, numbers: Iterable[int]) -> dict[str, float] | None:
    """PED-ANOVA importance of the parameters of the trials ``numbers`` (one planner's finished
    trials), on those trials alone, as shares that sum to 1; all 0 when no parameter's
    distribution among the best trials differs from all (e.g. equal values); None with fewer than
    two trials."""
    import warnings

    import optuna

    from ..research.search_storage import quiet

    numbers = set(numbers)
    trials = [t for t in study.study.get_trials(deepcopy=False) if t.number in numbers and t.value is not None]
    if len(trials) < 2:
        return None
    if not {k for t in trials for k in t.params if k not in PLANNER_COLUMNS}:
        return {}
    with quiet(), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # "too few trials", "target and region select the same trials": handled here
        alone = optuna.create_study(direction=study.study.direction)  # the planner's trials alone
        for t in trials:
            params = {k: v for k, v in t.params.items() if k not in PLANNER_COLUMNS}
            alone.add_trial(
                optuna.trial.create_trial(
                    params=params, distributions={k: t.distributions[k] for k in params}, value=t.value
                )
            )
        raw = optuna.importance.get_param_importances(
            alone, evaluator=optuna.importance.PedAnovaImportanceEvaluator(), normalize=False
        )
    total = sum(raw.values())
    return {k: (v / total if total > 0 else 0.0) for k, v in raw.items()}


def _draw_planner_effect(effect_ax: Axes, table: pd.DataFrame, name: str, n_planners: int) -> None:
    """The planner's effect on the objective ``name`` as one bar: η² over the finished trials."""
    column = _planner_column(table)
    eta = planner_effect(table[name], table[column])
    effect_ax.barh(["planner"], [0.0 if np.isnan(eta) else eta], color="#c44e52", height=0.5, label="planner effect")
    inside = not np.isnan(eta) and eta > 0.75  # the value's text inside the bar's end
    effect_ax.text(
        0.0 if np.isnan(eta) else eta,
        0,
        " η² = n/a (the values do not vary)"
        if np.isnan(eta)
        else f" η² = {eta:.2f} "
        if inside
        else f" η² = {eta:.2f}",
        va="center",
        ha="right" if inside else "left",
        color="white" if inside else "black",
        fontsize="small",
    )
    effect_ax.set_xlim(0.0, 1.0)
    effect_ax.set_xlabel(f"share of the variance of {name} between planners (η², over {len(table)} finished trials)")
    effect_ax.set_title(f"the planner's effect ({n_planners} planners)")


def _draw_importances(
    ax: Axes,
    groups: list[tuple[Any, pd.DataFrame]],
    shares: dict[Any, dict[str, float] | None],
    params: list[str],
    several: bool,
) -> list[str]:
    """One bar per planner and parameter, its share written at its end ("not used" where the
    planner lacks the parameter); returns each planner's note (its trials, and why no share)."""
    from ..research.tables import short_name

    height = 0.8 / len(groups)
    notes = []
    for g, (p, part) in enumerate(groups):
        s = shares[p]
        note = f"{len(part)} trials"
        if s is None:
            note += ": too few"
        elif s and not any(s.values()):
            note += ": nothing separates its best trials"
        notes.append(note)
        label = f"{'all trials' if p is None else short_name(p)} ({note})"
        ys = np.arange(len(params)) + (0.4 - height * (g + 0.5) if several else 0.0)
        widths = [(s or {}).get(k, np.nan) for k in params]
        ax.barh(ys, np.nan_to_num(widths), height=height if several else 0.8, color=f"C{g % 10}", label=label)
        for y, w in zip(ys, widths):
            ax.text(
                0.0 if np.isnan(w) else w,
                y,
                " not used" if np.isnan(w) else f" {w:.2f}",
                va="center",
                fontsize="x-small" if several else "small",
                color="#7f7f7f" if np.isnan(w) else "black",
            )
    return notes


def plot_param_importance(
    study: Studies, *, planner: Any = None, ax: Axes | None = None, title: str | None = None
) -> Figure:
    """How much the planner and each searched parameter matter to the objective, over the
    finished trials (their objective values: failed runs counted with the study's penalty).

    * **The planner's effect** (when the trials span several planners): η², the share of the
      variance of the objective values between planners (between-planner sum of squares / total,
      ``Σ_p n_p (mean_p − mean)² / Σ_i (v_i − mean)²``); 0: the planners' means are equal, 1: all
      of a planner's trials have the same value (the planner decides everything).
      Drawn in a panel of its own, on its own scale.
    * **Parameter importance within each planner**: Optuna's PED-ANOVA (Watanabe et al. 2023) over
      that planner's own finished trials only: how differently a parameter is distributed among the
      planner's best 10% of trials than among all its trials (a Pearson divergence of Parzen
      estimates), as shares that sum to 1 per planner; one bar per planner and parameter (a
      parameter the planner does not use has none: "not used"). All 0 ("nothing separates its best
      trials") when no parameter's distribution differs, e.g. when every trial of the planner has
      the same value (Optuna's normalisation would show equal shares). The legend gives each
      planner's trials: PED-ANOVA wants at least 5 in the best 10%, about 50 per planner. The
      shares rank parameters within a planner; they are not comparable to η².

    ``planner``: draw one planner's importances only (its name or short name), in one axes (or in
    ``ax``); a study over several planners otherwise needs a figure of its own (``ax`` refused).
    """
    from ..research.tables import short_name

    study = next(iter(_studies(study).values()))
    name, table = _finished(study, "plot_param_importance")
    if len(table) < 2:
        raise ParamError("plot_param_importance needs at least two finished trials")
    groups = _planner_groups(study, table, planner, "plot_param_importance")
    several = len(groups) > 1
    if several and ax is not None:
        raise ParamError(
            f"plot_param_importance: the trials span {len(groups)} planners "
            f"({', '.join(short_name(p) for p, _ in groups)}), drawn in two panels of a figure of their own; "
            "leave ax out, or pass planner= to draw one planner's importances into ax"
        )
    shares = {p: _importance_within(study, part["number"]) for p, part in groups}
    params = sorted(
        {k for s in shares.values() if s for k in s}, key=lambda k: max((s or {}).get(k, 0.0) for s in shares.values())
    )
    if not params:
        raise ParamError("plot_param_importance: no searched parameter with at least two finished trials")
    rows = len(params) * (len(groups) if several else 1)
    if several:
        fig = Figure(figsize=(7.5, 0.32 * rows + 3.2), layout="constrained")
        effect_ax, ax = fig.subplots(2, 1, height_ratios=[1.0, max(2.0, 0.32 * rows)])
        _draw_planner_effect(effect_ax, table, name, len(groups))
    else:
        fig, ax = figure_axes(ax, figsize=(6.0, 0.5 * rows + 1.5))
    notes = _draw_importances(ax, groups, shares, params, several)
    ax.set_yticks(range(len(params)), params)
    ax.set_xlim(0, 1.15)
    first = groups[0][0]
    within = " within each planner" if several else "" if first is None else f" within {short_name(first)}"
    ax.set_xlabel(f"importance{within} for {name} (PED-ANOVA shares, sum 1 per planner)")
    if title is not None:
        (fig.suptitle if several else ax.set_title)(title)
    else:
        ax.set_title("parameter importance" + within + ("" if several else f" ({notes[0]})"))
    if several:
        legend_outside(ax, title="planner")
    else:
        fig.tight_layout()
    return fig


def _contour_panel(ax, part, x, y, name, logs, norm, scale, best_label):
    """One contour panel: the trials of ``part`` as points over a contour between them, the best
    starred (none when all are equal); returns the points' collection."""
    import matplotlib.tri as mtri

    px, py = (np.log10(part[c].to_numpy(float)) if lg else part[c].to_numpy(float) for c, lg in zip((x, y), logs))
    v = scale * part[name].to_numpy(float)
    try:
        tri = mtri.Triangulation(10**px if logs[0] else px, 10**py if logs[1] else py)
        ax.tricontourf(tri, v, levels=12, cmap="viridis_r", norm=norm, alpha=0.55)
    except (ValueError, RuntimeError):  # fewer than three distinct points: the points alone
        pass
    sc = ax.scatter(
        part[x], part[y], c=v, cmap="viridis_r", norm=norm, s=22, edgecolors="black", linewidths=0.4, label="trials"
    )
    if part[name].nunique() > 1 or len(part) == 1:  # all trials equal: none is the best
        best = part.loc[part[name].idxmin() if OBJECTIVE_MAX.get(name) is None else part[name].idxmax()]
        ax.scatter([best[x]], [best[y]], marker="*", s=220, c="#d62728", edgecolors="black", zorder=5, label=best_label)
    return sc


def _contour_axes(n_panels: int, ax: Axes | None) -> tuple[Figure, list[Axes]]:
    """The contour's figure and axes: ``ax`` (or a new axes) for one panel; for several, a figure
    of its own with up to three panels a row on shared axes."""
    if n_panels == 1:
        fig, ax = figure_axes(ax, figsize=(6.2, 4.8))
        return fig, [ax]
    cols = min(n_panels, 3)
    rows = -(-n_panels // cols)
    fig = Figure(figsize=(4.6 * cols + 1.2, 4.0 * rows + 0.6), layout="constrained")
    grid = fig.subplots(rows, cols, sharex=True, sharey=True, squeeze=False).ravel()
    for extra in grid[n_panels:]:
        fig.delaxes(extra)
    return fig, list(grid[:n_panels])


def plot_search_contour(
    study: Studies, x: str, y: str, *, planner: Any = None, ax: Axes | None = None, title: str | None = None
) -> Figure:
    """The objective over two searched parameters: every finished trial as a point coloured by
    its value, over a contour interpolated between them (log axes for log ranges); the best trial
    is starred (none when all have the same value).

    A contour is interpolated between the trials of one planner only: when the trials span several
    planners, one panel per planner holds that planner's own trials (its best starred), on shared
    axes and one colour scale; a planner whose trials lack ``x`` or ``y`` has an empty panel that
    says so. ``planner`` (a name or short name) draws that planner's trials alone, in one axes (or
    in ``ax``, which a study over several planners needs ``planner`` for)."""
    from matplotlib.ticker import NullFormatter, ScalarFormatter

    from ..research.tables import short_name

    study = next(iter(_studies(study).values()))
    name, table = _finished(study, "plot_search_contour")
    for c in (x, y):
        if c not in table.columns or c in PLANNER_COLUMNS:
            raise ParamError(
                f"{c!r} is not a searched number of this study (columns: {', '.join(map(str, table.columns))})"
            )
    groups = [
        (p, part.dropna(subset=[x, y, name]))
        for p, part in _planner_groups(study, table, planner, "plot_search_contour")
    ]
    if sum(len(part) for _, part in groups) < 2:
        raise ParamError("plot_search_contour needs at least two finished trials with both parameters")
    several = len(groups) > 1
    if several and ax is not None:
        raise ParamError(
            f"plot_search_contour: the trials span {len(groups)} planners "
            f"({', '.join(short_name(p) for p, _ in groups)}), one panel each; leave ax out, or pass planner= "
            "to draw one planner's trials into ax"
        )
    scale = 100.0 if name in ("gap", "success") else 1.0
    logs = [str(study.info["space"].get(c, "")).endswith(":log") for c in (x, y)]
    values = scale * np.concatenate([part[name].to_numpy(float) for _, part in groups])
    low, high = np.nanmin(values), np.nanmax(values)
    norm = Normalize(low, high if high > low else low + 1)
    fig, axes = _contour_axes(len(groups), ax)
    for a, (p, part) in zip(axes, groups):
        sc = _contour_panel(a, part, x, y, name, logs, norm, scale, "best" if p is None else f"best of {short_name(p)}")
        if several:
            equal = ", all equal" if len(part) > 1 and part[name].nunique() == 1 else ""
            a.set_title(f"{short_name(p)} ({len(part)} trials{equal})", fontsize="medium")
            if not len(part):
                a.text(
                    0.5, 0.5, f"no finished trial\nwith {x} and {y}", transform=a.transAxes, ha="center", va="center"
                )
        for lg, axis, setter in zip(logs, (a.xaxis, a.yaxis), (a.set_xscale, a.set_yscale)):
            if lg:
                setter("log")
                axis.set_major_formatter(ScalarFormatter())
                axis.set_minor_formatter(NullFormatter())
        a.set_xlabel(x)
        a.set_ylabel(y)
    fig.colorbar(sc, ax=axes if several else axes[0], label=name + (" (%)" if scale == 100.0 else ""))
    if several:
        fig.suptitle(
            title if title is not None else f"{name} over {x} and {y}, one panel per planner (★ its best trial)"
        )
    else:
        p = groups[0][0]
        of = "" if p is None or planner is None else f" of {short_name(p)}"
        axes[0].set_title(title if title is not None else f"{name} over {x} and {y}{of} (★ best trial)")
        fig.tight_layout()
    return fig


OBJECTIVE_MAX = {"success": True}  # objectives a search maximises (the rest are minimised)


def plot_pareto(study: Studies, a: str, b: str, *, ax: Axes | None = None, title: str | None = None) -> Figure:
    """Two objectives of a search: every finished trial, with the Pareto front (the trials no
    other trial beats on both) joined by a line."""
    study = next(iter(_studies(study).values()))
    for n in (a, b):
        if n not in study.objectives:
            raise ParamError(f"{n!r} is not an objective of this study ({', '.join(study.objectives)})")
    table = _by_objective(study, study.trials)
    table = table[table["state"] == "COMPLETE"]
    front = _by_objective(study, study.best_trials).sort_values(a)
    fig, ax = figure_axes(ax, figsize=(6.0, 4.5))
    sa, sb = (100.0 if n in ("gap", "success") else 1.0 for n in (a, b))
    ax.scatter(sa * table[a], sb * table[b], s=16, alpha=0.45, color="#7f7f7f", label="trials")
    ax.plot(sa * front[a], sb * front[b], "o-", color="#d62728", markersize=5, label="Pareto front")
    _objective_axis(ax, a, "x")
    _objective_axis(ax, b, "y")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize="small", borderaxespad=0.0)
    ax.set_title(title if title is not None else f"{a} against {b}")
    fig.tight_layout()
    return fig

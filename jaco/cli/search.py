"""``jaco search``: adaptive batched search on the command line (:func:`jaco.search`), and ``jaco
rerun STORAGE --trial N`` for a stored trial."""

from __future__ import annotations

import argparse
import math
import time
from typing import Any

from .args import UsageError, parse_param_number, split_params
from .commands.run import NO_PATH  # as solve: no trial reached the goal
from .output_flags import check_outputs, handles_outputs


def parse_dimension(name: str, value: str) -> Any:
    """``--param`` of a search: ``lo:hi`` (a real range), ``lo:hi:log``, ``lo:hi:int`` (also
    ``lo:hi:int:log``), ``a,b,c`` (a categorical) or one number (fixed)."""
    if ":" in value:
        parts = [p.strip() for p in value.split(":")]
        tags = parts[2:]
        if len(parts) < 2 or set(tags) - {"log", "int"} or len(set(tags)) != len(tags):
            hint = " (START:STOP:COUNT is the sweep's form)" if len(parts) == 3 and parts[2].isdigit() else ""
            raise UsageError(f"--param {name}={value}: a search range is LOW:HIGH, LOW:HIGH:log or LOW:HIGH:int{hint}")
        lo, hi = parse_param_number(name, parts[0]), parse_param_number(name, parts[1])
        return (lo, hi, *tags)
    if "," in value:
        items = [v.strip() for v in value.split(",") if v.strip()]
        numbers = [parse_param_number(name, v) for v in items]
        return [int(x) if x.is_integer() and name in ("n_ants", "n_iters") else x for x in numbers]
    x = parse_param_number(name, value)
    return int(x) if x.is_integer() and name in ("n_ants", "n_iters") else x


def parse_space(items: list[str] | None) -> dict:
    return {name: parse_dimension(name, value) for name, value in split_params(items)}


def _fmt(name: str, x) -> str:
    if isinstance(x, str):
        return x
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if name in ("gap", "success", "success_rate", "gap_median", "gap_penalised_mean"):
        return f"{100 * x:.2f}%"
    return f"{x:.4g}"


def _prepare(args: argparse.Namespace) -> dict:
    """What ``jaco search`` searches: the arguments of :func:`jaco.search` (``call``) and what the
    summary needs, checked before anything compiles."""
    from .queries import load_map, resolve_queries

    space = parse_space(args.param)
    if not space:
        raise UsageError("jaco search needs at least one --param NAME=LOW:HIGH (or a list a,b,c) to search")
    variants = args.planner or [args.default_planner]
    if "variant" in space or "planner" in space:
        raise UsageError("name the planners with --planner (repeatable), not --param planner=...")
    space["variant"] = variants if len(variants) > 1 else variants[0]
    grid = load_map(args.map)
    starts, goals, scenarios, label = resolve_queries(grid, args)
    start, goal = (starts[0], goals[0]) if len(starts) == 1 else (starts, goals)
    from ..research.search import Halving

    fidelity = None
    if args.halving or args.hyperband:
        fidelity = Halving(min_iters=args.min_iters, eta=args.eta, hyperband=args.hyperband)
    elif args.min_iters is not None or args.eta != 3:
        raise UsageError("--min-iters and --eta belong to --halving or --hyperband")
    if args.linear and not args.plot:
        raise UsageError("--linear is the axis of the --plot history: give --plot FILE too")
    if args.workers > 1 and not args.storage:
        raise UsageError("--workers N shares one study between processes: give --storage (a .db file, ...)")
    if args.workers > 1 and args.sampler.startswith("evosax:"):
        raise UsageError("an evosax strategy runs one worker per study: leave out --workers")
    trials = 128 if args.trials is None and args.timeout is None else args.trials  # --timeout alone: until it
    call = dict(
        trials=trials,
        timeout=args.timeout,
        batch=args.batch,
        seeds=args.seeds,
        n_ants=args.ants,
        n_iters=args.iters,
        steplimit=args.steplimit,
        sampler=args.sampler,
        seed=args.seed,
        objective=args.objective or ["gap"],
        fidelity=fidelity,
        storage=args.storage,
        study_name=args.study,
        worker=args.worker,
        heartbeat_interval=args.heartbeat_interval,
        grace_period=args.grace_period,
    )
    return dict(
        grid=grid,
        start=start,
        goal=goal,
        space=space,
        call=call,
        variants=variants,
        scenarios=scenarios,
        where=f"start {tuple(starts[0])} -> goal {tuple(goals[0])}"
        if len(starts) == 1
        else f"{len(starts)} queries ({label})",
    )


@handles_outputs("--csv", "--plot")
def cmd_search(args: argparse.Namespace) -> int:
    from ..research.search import search

    job = _prepare(args)
    grid, call, variants = job["grid"], job["call"], job["variants"]
    check_outputs(args, grid, figures=("--plot",), files=(("--csv", None),))
    args.kept = lambda: _search_kept(args.storage, args.study)  # what an interrupt kept (the last line says)
    trials = call["trials"]
    budget = " or ".join(([f"{trials} trials"] if trials else []) + ([f"{args.timeout:g} s"] if args.timeout else []))
    if trials and args.timeout:
        budget += ", whichever comes first"
    print(
        f"search {', '.join(variants)} on {grid.name} ({grid.height}x{grid.width}), {job['where']}: {budget} in batches of {args.batch}, {args.seeds} seeds, sampler {args.sampler}"
        + (f", {'hyperband' if args.hyperband else 'successive halving'} over iterations" if call["fidelity"] else "")
        + (f", storage {args.storage}" if args.storage else "")
        + (f", {args.workers} workers" if args.workers > 1 else ""),
        flush=True,
    )
    if args.workers > 1:
        study = run_workers(args, call)
    else:
        study = search(grid, job["start"], job["goal"], job["space"], **call)
    args.kept = None
    args.finished = True  # from here a failed write says that the search itself finished
    return _summary(args, study, job["space"], call["objective"], job["scenarios"])


def _summary(args, study, space, objectives, scenarios) -> int:
    """The lines and files after a search: timings, the best trials, --csv and --plot."""
    from ..research.search import objective_column

    seconds = time.perf_counter() - args.started
    t = study.timings
    if args.workers > 1:
        print(f"{len(study.study.trials)} trials in the study; {args.workers} workers ran for {seconds:.2f} s")
    else:
        print(
            f"{len(study.study.trials)} trials in the study; this command ran {t.get('generations', 0)} generations in "
            f"{seconds:.2f} s (sampler {t.get('sampler_s', 0):.2f} s, evaluation {t.get('evaluate_s', 0):.2f} s, "
            f"{t.get('compiles', 0)} compiled programs)"
        )
    print(f"stopped: {study.stopped}")
    for sc in scenarios or ():
        print(f"scenario #{sc.index}: optimal length {sc.optimal:.4f} (from the .scen file)")
    table = study.trials
    if args.csv:
        from ..outputs import write_text
        from ..research.tables import csv_text

        print(f"wrote {write_text(args.csv, csv_text(table))}")  # floats at float32 precision, as every table
    if args.plot:
        from .. import plot

        fig = (  # a log axis by default: the failures' penalties would flatten the gaps on a linear one
            plot.plot_search_history(study, log=not args.linear)
            if len(objectives) == 1
            else plot.plot_pareto(study, *objectives[:2])
        )
        print(f"wrote {plot.save(fig, args.plot, format=args.plot_format)}")
    finished = table[table["state"] == "COMPLETE"]
    columns = [objective_column(o) for o in objectives]  # gap_penalised_mean, ...
    shown = (
        study.best_trials
        if len(objectives) > 1
        else finished.sort_values(
            [columns[0], "number"], ascending=[objectives[0] != "success", True], kind="stable"
        ).head(args.top)
    )
    params = [c for c in table.columns if c in space and c != "variant"]
    cols = ["number", "planner", *params, *columns, "success_rate", "gap_median", "runs"]
    what = "Pareto front" if len(objectives) > 1 else f"top {len(shown)} of {len(finished)} finished trials"
    penalised = [c for o, c in zip(objectives, columns) if c != o]
    note = f"; a failed run counts as its penalty in {', '.join(penalised)}" if penalised else ""
    print(f"\n{what} (gap_median over the successful runs{note}):")
    import pandas as pd

    text = pd.DataFrame({c: shown[c].map(lambda x, c=c: _fmt(c, x)) for c in cols if c in shown})
    print(text.to_string(index=False) if len(text) else "(none)")
    if finished.empty or not (finished["success_rate"] > 0).any():
        print(
            "\nno trial reached the goal: try a backtracking planner (--planner iaca), more ants or iterations, "
            "or a larger β or step limit"
        )
        return NO_PATH
    if len(objectives) == 1:
        best = study.best_params
        conf = ", ".join(f"{k}={v:g}" if not isinstance(v, str) else f"{k}={v}" for k, v in best.items())
        print(f"\nbest: trial {study.best_trial.number}: {conf}; {columns[0]} {_fmt(columns[0], study.best_value)}")
    if args.storage:
        print(
            f"study {study.study.study_name!r} in {args.storage}: run the same command again to resume or extend it "
            f"(--trials); 'jaco rerun {args.storage} --study {study.study.study_name} --trial N' reruns a trial; "
            f"'optuna-dashboard {args.storage if '://' in args.storage else 'sqlite:///' + args.storage}' shows it"
        )
    return 0


# -- --workers N: local worker processes on one study ---------------------------------------------
def _shares(cores: list[int], n: int) -> list[list[int]]:
    """The cores of each of ``n`` workers: a round-robin split (a core each, shared, when there are
    fewer cores than workers)."""
    if n <= len(cores):
        return [cores[i::n] for i in range(n)]
    return [[cores[i % len(cores)]] for i in range(n)]


def _worker(state: dict, index: int, cores: list[int]) -> None:
    """One worker process of ``--workers N`` (spawned): its own process group (a Ctrl-C in the
    terminal reaches the parent, which stops the workers), its share of the cores, the search."""
    import os
    import signal
    import sys

    from ..errors import JacoError
    from ..research.search import search
    from .signals import INTERRUPTED, TERMINATED, Terminated, stop_signals

    os.setpgrp()
    # The parent stops a worker with SIGINT. A process started with SIGINT ignored (a shell's
    # background job: `jaco search --workers 4 ... &`) passes that on, and Python keeps it ignored.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    if cores and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, cores)  # before the first compile: XLA sizes its thread pool from it
    args = argparse.Namespace(**state)
    args.workers, args.worker = 1, state["worker"] + index
    code = 0
    try:
        with stop_signals():  # as every jaco command: an interrupt swallowed by a callback is sent again
            if getattr(args, "walk", None) is not None:  # as jaco.cli does for every command
                from ..engine import native

                native.set_walk(args.walk)
            job = _prepare(args)
            search(job["grid"], job["start"], job["goal"], job["space"], **job["call"], progress=False)
    except KeyboardInterrupt:  # stopped by the parent: the batch that ran is stored, the running one released
        code = INTERRUPTED
    except Terminated:  # SIGTERM to the worker itself: the same
        code = TERMINATED
    except (JacoError, UsageError) as e:
        print(f"jaco: error: worker {args.worker}: {' '.join(str(e).split())}", file=sys.stderr)
        code = 2
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(code)  # at once, as the jaco command after an interrupt (an XLA compile cannot be stopped)


def run_workers(args: argparse.Namespace, call: dict):
    """``--workers N``: N worker processes on the study in ``args.storage``; the parent shows the
    study's finished trials, and on Ctrl-C or SIGTERM sends each worker SIGINT and waits for it."""
    import multiprocessing
    import os

    from .. import progress as _progress
    from ..errors import JacoError
    from ..research.search import load_study

    cores = sorted(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else list(range(os.cpu_count() or 1))
    state = {k: v for k, v in vars(args).items() if not callable(v)}
    ctx = multiprocessing.get_context("spawn")
    procs = [
        ctx.Process(target=_worker, args=(state, i, share), name=f"jaco-worker-{i}")
        for i, share in enumerate(_shares(cores, args.workers))
    ]
    bar = _progress.Bar(_progress.enabled(None), f"search {args.sampler}, {args.workers} workers", "trial")
    bar.start(call["trials"])
    watch: list = []
    try:
        for p in procs:
            p.start()
        while any(p.is_alive() for p in procs):
            procs[0].join(timeout=1.0) if procs[0].is_alive() else time.sleep(1.0)
            done = _finished(args, watch)
            bar.update(min(done, call["trials"] or done))
            if any(p.exitcode not in (None, 0) for p in procs):
                break  # a worker failed: stop the others
    except BaseException:  # Ctrl-C or SIGTERM (raised as jaco.cli.Terminated)
        _stop(procs)
        raise
    finally:
        bar.close()
    _stop(procs)
    failed = [(i, p.exitcode) for i, p in enumerate(procs) if p.exitcode != 0]
    if failed:
        i, code = failed[0]
        raise JacoError(f"worker {args.worker + i} of {len(procs)} exited with code {code} (its message is above)")
    return load_study(args.storage, args.study or "jaco")


def _finished(args, watch: list) -> int:
    """The study's finished trials (0 before a worker created it); ``watch`` keeps the study open."""
    from ..errors import JacoError
    from ..research.search import load_study

    try:
        if not watch:
            watch.append(load_study(args.storage, args.study or "jaco").study)
        return sum(t.state.name in ("COMPLETE", "PRUNED") for t in watch[0].get_trials(deepcopy=False))
    except (JacoError, Exception):  # noqa: BLE001 - no study yet, or a busy storage: ask again next second
        return 0


def _stop(procs, wait: float = 120.0) -> None:
    """SIGINT to every running worker; each stores what ran and releases its running trials (another
    worker, or the same command again, takes them over at once). One still running after ``wait``
    seconds is killed: its trials are taken over once its heartbeat is older than the grace period."""
    import os
    import signal

    for p in procs:
        if p.is_alive() and p.pid is not None:
            os.kill(p.pid, signal.SIGINT)
    deadline = time.monotonic() + wait
    for p in procs:
        p.join(timeout=max(0.0, deadline - time.monotonic()))
        if p.is_alive():
            p.kill()
            p.join()


def _search_kept(storage: str | None, study_name: str | None) -> str:
    """What an interrupted search kept (its finished trials, read back from ``storage``) and how to
    go on, for the line ``jaco: interrupted: ...``."""
    if storage is None:
        return "nothing was kept (add --storage FILE.db to keep finished trials)"
    from ..errors import JacoError
    from ..research.search import load_study

    try:
        trials = load_study(storage, study_name or "jaco").study.trials
    except JacoError:  # no storage file or no study yet: nothing had finished
        trials = []
    done = sum(t.state.name == "COMPLETE" for t in trials)
    if not done:
        return f"no trial had finished, none stored in {storage}; the same command resumes"
    return f"{done} trial{'s' if done != 1 else ''} stored in {storage}; the same command resumes"


def cmd_rerun(args: argparse.Namespace) -> int:
    """``jaco rerun``: a run or sweep record (:func:`jaco.cli.commands.rerun.cmd_rerun`), or with
    ``--trial N [--study NAME]`` a trial of a stored search; exit 0 when it matched, 1 when not."""
    from ..research.search import load_study
    from .commands.rerun import cmd_rerun as rerun_record
    from .commands.rerun import report_rerun

    if args.trial is None:
        if args.study is not None:
            raise UsageError("--study names a search study: give --trial N too")
        return rerun_record(args)

    study = load_study(args.record, args.study)
    print(f"study    {study.study.study_name!r}: {len(study.study.trials)} trials, sampler {study.info['sampler']}")
    return report_rerun(lambda: study.rerun(args.trial), "the stored trial")

"""Progress bars on stderr for the long calls (``jaco.solve``, ``jaco.sweep``, ``jaco.tune``).

``progress`` is ``None`` (auto: on when stderr is a terminal or the code runs in a Jupyter
kernel, so a test run or a redirected script prints none), ``True`` (always) or ``False``
(never). The bars are tqdm's text bars, which a terminal and a notebook both render.

How a bar learns of a compiled loop's progress:

- A run on the native walk (CPU) hands its number of finished iterations to the kernel's stop
  flag every iteration anyway (:func:`jaco.engine.native.stop_requested`); while
  :func:`run_interruptibly` waits for the run, a helper thread reads that count every :data:`POLL` seconds
  (:func:`jaco.engine.native.iterations_done`). The run makes no host callback, so a solve with a
  bar costs only the helper thread's start more than one without (a callback costs about 100 µs:
  25 of them made a solve of 6 ms take 10).
- A run on the JAX walk (GPU/TPU, or no kernel) reports through :func:`jax.debug.callback` to
  :func:`report`, at most :data:`REPORTS` times per call; ``jaco.solve`` compiles such a run only
  when a bar is shown (one more program). ``jaco.tune``'s loop always reports (once per step,
  next to a whole population of runs).

Neither reads anything back into the run, so the results are the same bit for bit with and
without bars.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import logging
import sys
import threading
import time
from collections.abc import Callable, Hashable
from typing import Any, TypeVar

from .engine import native
from .engine.cache import keep

T = TypeVar("T")

REPORTS = 25  # a compiled loop reports at most this often per run (every ceil(n / REPORTS) steps)
SOLVE_DELAY = 2.0  # seconds: a solve shows its bar only once it has taken this long
POLL = 0.05  # seconds between the looks at an interrupt, and at the kernel's count of iterations
QUICK = 0.02  # seconds: a program whose last call took less runs on the calling thread (run_interruptibly)


def enabled(progress: bool | None) -> bool:
    """Whether to show bars: ``progress`` True/False, or None for auto (a terminal or a notebook)."""
    if progress is not None:
        return bool(progress)
    try:
        if sys.stderr is not None and sys.stderr.isatty():
            return True
    except (AttributeError, ValueError):  # a closed or unusual stream
        return False
    shell = getattr(sys.modules.get("IPython"), "get_ipython", lambda: None)()
    return type(shell).__name__ == "ZMQInteractiveShell"  # a Jupyter kernel


def every(n: int) -> int:
    """Report every this many steps of a loop of ``n``: at most :data:`REPORTS` reports."""
    return max(1, -(-int(n) // REPORTS))


class Bar:
    """A tqdm bar opened on first use: ``status(text)`` shows a line before the work is counted
    (e.g. "compiling…"), ``start(total, desc)`` sets what is counted, ``update(done)`` moves it to
    ``done``; ``delay``: open only when an update comes this many seconds after creation and
    work remains. Nothing is printed when ``show`` is false."""

    def __init__(self, show: bool, desc: str, unit: str, delay: float = 0.0):
        self.show, self.desc, self.unit, self.delay = show, desc, unit, delay
        self.t0 = time.time()
        self.total: int | None = None
        self.bar: Any = None  # a tqdm bar, once opened

    def _open(self, desc, initial=0, bar_format=None):
        from tqdm import tqdm

        self.bar = tqdm(
            total=self.total,
            desc=desc,
            unit=self.unit,
            initial=initial,
            file=sys.stderr,
            dynamic_ncols=True,
            bar_format=bar_format,
        )

    def status(self, text: str) -> None:
        if not self.show:
            return
        if self.bar is None:
            self._open(f"{self.desc}: {text}", bar_format="{desc} [{elapsed}]")  # nothing counted yet
        else:
            self.bar.set_description_str(f"{self.desc}: {text}")

    def start(self, total: int, desc: str | None = None) -> None:
        self.total = total
        self.desc = desc or self.desc
        if self.show and not self.delay:
            if self.bar is None:
                self._open(self.desc)
            self.bar.total, self.bar.bar_format = total, None
            self.bar.set_description_str(self.desc)

    def update(self, done: int) -> None:
        if not self.show:
            return
        if self.bar is None:
            if time.time() - self.t0 < self.delay or (self.total is not None and done >= self.total):
                return
            self._open(self.desc, initial=int(done))  # the rate and time left count from here
        self.bar.update(int(done) - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


# -- what a compiled loop reports to (one listener at a time, set by the call that runs it) ----
_LISTENER: list = [None]
_RUNS = [False]  # whether the listener counts runs' iterations (then it follows the native walk's count)


class Interrupted(Exception):
    """Raised inside a compiled loop's report when the user interrupted the call: XLA then ends
    the computation at once (:func:`run_interruptibly`)."""


def report(done: int) -> None:
    """Host side of :func:`jax.debug.callback` in a compiled loop: ``done`` steps are finished.
    After an interrupt it raises :class:`Interrupted`, which ends the computation."""
    if native.stop_is_set():
        raise Interrupted("interrupted")
    bar = _LISTENER[0]
    if bar is not None:
        bar.update(int(done))


class _QuietInterrupts(logging.Filter):
    """JAX logs a failed debug callback with its traceback; an interrupt is no failure."""

    def filter(self, record) -> bool:
        exc = record.exc_info[1] if record.exc_info else None
        return not isinstance(exc, Interrupted)


logging.getLogger("jax._src.debugging").addFilter(_QuietInterrupts())
logging.getLogger("jax._src.callback").addFilter(_QuietInterrupts())
_WORKER = concurrent.futures.ThreadPoolExecutor(max_workers=1, thread_name_prefix="jaco-compute")


def run_interruptibly(fn: Callable[..., T], *args: Any, program: Hashable | None = None, **kwargs: Any) -> T:
    """``fn(*args, **kwargs)`` (compiling or running a compiled program, fetching its results) in a
    worker thread while the main thread waits in short steps, so that Ctrl-C (SIGINT) or SIGTERM is
    seen at once: only the main thread runs Python's signal handlers, and it would not run them
    while blocked inside XLA. On an interrupt, every compiled run ends its iteration loop at the
    next iteration (:func:`jaco.engine.native.stop_requested`: a solve, each run of a sweep chunk,
    a search batch or a tuning step), a loop that reports its steps ends at its next report, and
    the interrupt is re-raised once the work has ended (or after a second: an XLA compile cannot
    be stopped and finishes in the background, then its program ends at once). The next call
    runs normally. Called from any other thread, it just calls ``fn``.

    While a shown bar counts runs' iterations (:class:`listening` with ``runs``, :class:`reporting`),
    a helper thread moves it to the native walk's count of finished iterations (:func:`_polling`).

    ``program``: what the call runs (a compiled program and its shapes, e.g. a solve's). A program
    whose last call took less than :data:`QUICK` seconds runs on the calling thread instead: the
    hand-over to the worker and back costs two thread wake-ups, each possibly on the other core (a
    3 ms solve took 0.96 of the time without them on the 2-core machines here). An interrupt then
    takes effect when the call returns, which a call of the same program takes a few times
    :data:`QUICK` at most (the same shapes; a query or parameters that make its ants walk longer)."""
    listener = _LISTENER[0] if _RUNS[0] and getattr(_LISTENER[0], "show", True) else None  # a hidden bar: no polls
    polling = _polling(listener) if listener is not None else contextlib.nullcontext()
    if threading.current_thread() is not threading.main_thread():
        with polling:
            return fn(*args, **kwargs)
    t0 = time.perf_counter()
    if program is not None and _TOOK.get(program, QUICK) < QUICK:
        with polling:
            out = fn(*args, **kwargs)
    else:
        out = _in_worker(polling, fn, *args, **kwargs)
    if program is not None:
        keep(_TOOK, program, time.perf_counter() - t0, PROGRAMS_TIMED)
    return out


def _in_worker(polling: Any, fn: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """``fn(*args, **kwargs)`` in the worker thread while this (main) thread waits in steps of
    :data:`POLL`; on an interrupt, the stop request (see :func:`run_interruptibly`)."""
    future = _WORKER.submit(fn, *args, **kwargs)
    try:
        with polling:
            while True:
                try:
                    return future.result(timeout=POLL)
                except concurrent.futures.TimeoutError:
                    continue
    except BaseException:  # KeyboardInterrupt, the CLI's SIGTERM exception
        if not future.done():
            native.set_stop(True)
            future.add_done_callback(lambda _: native.set_stop(False))  # until the interrupted work has ended
            with contextlib.suppress(BaseException):
                future.result(timeout=1.0)  # a reporting loop ends at its next report
        raise


PROGRAMS_TIMED = 256  # programs whose last call's time is kept
_TOOK: dict = {}  # seconds the last call of each program took (run_interruptibly's ``program``)


def _move(listener: Any, seen: int) -> int:
    """Move ``listener`` to the kernel's count of finished iterations if it grew past ``seen``
    (it stays 0 under a JAX-walk run, whose callbacks move the bar); returns the larger."""
    done = native.iterations_done()
    if done > seen:
        listener.update(done)
    return max(done, seen)


@contextlib.contextmanager
def _polling(listener: Any):
    """``with _polling(listener):`` the kernel's count set back to 0, then a helper thread moves
    ``listener`` (:func:`_move`) every :data:`POLL` seconds while the work runs, and once more at
    the end."""
    native.iterations_done(reset=True)
    finished = threading.Event()
    seen = [0]

    def poll():
        while not finished.wait(POLL):
            seen[0] = _move(listener, seen[0])

    helper = threading.Thread(target=poll, name="jaco-progress", daemon=True)
    helper.start()
    try:
        yield
    finally:
        finished.set()
        helper.join()
        _move(listener, seen[0])


class reporting:
    """``with reporting(update):`` the compiled runs' reports call ``update(done)`` with their
    finished iterations (and nothing is closed after): the chunks of a sweep count their
    iterations into one bar."""

    def __init__(self, update):
        self.update = update

    def __enter__(self):
        _LISTENER[0], _RUNS[0] = self, True
        return self

    def __exit__(self, *exc):
        _LISTENER[0], _RUNS[0] = None, False
        return False


class listening:
    """``with listening(bar, runs=...):`` the compiled loops' reports move ``bar`` (then it is
    closed). ``runs``: the work is runs of :func:`jaco.engine.run.make_run`, whose finished
    iterations the bar counts (so it also follows the native walk's count); else a loop of its
    own that reports its steps through :func:`report` (``jaco.tune``'s)."""

    def __init__(self, bar: Bar, runs: bool = False):
        self.bar, self.runs = bar, runs

    def __enter__(self):
        _LISTENER[0], _RUNS[0] = self.bar, self.runs
        return self.bar

    def __exit__(self, *exc):
        _LISTENER[0], _RUNS[0] = None, False
        self.bar.close()
        return False

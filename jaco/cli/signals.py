"""Stopping a command: SIGTERM raised as :class:`Terminated` in the main thread (as Ctrl-C raises
KeyboardInterrupt), and an interrupt that a callback swallowed delivered again. Its own module,
so that the ``--workers`` processes (:mod:`jaco.cli.search`) use it without importing the CLI."""

from __future__ import annotations

import contextlib
import sys

INTERRUPTED, TERMINATED = 130, 143  # exit codes: 128 + the signal (SIGINT, SIGTERM)


class Terminated(BaseException):
    """SIGTERM, raised in the main thread like Ctrl-C's KeyboardInterrupt, so that the same
    clean-up runs: temporary files removed, nothing half-written, finished chunks and trials kept."""


def _terminate(signum, frame):
    raise Terminated()


def _redeliver(unraisable, previous_hook, signals) -> None:
    """``sys.unraisablehook`` while a command runs. Python ignores an exception raised where it
    cannot propagate: a garbage-collector callback (JAX registers one), a ``__del__``. A signal whose
    handler ran there would be lost and the command would go on; it is sent again a moment later,
    from another thread, so that the handler runs where the exception reaches the clean-up."""
    import os
    import threading

    for exc_type, signum in signals:
        if isinstance(unraisable.exc_value, exc_type):
            threading.Timer(0.01, os.kill, (os.getpid(), signum)).start()
            return
    previous_hook(unraisable)


@contextlib.contextmanager
def stop_signals():
    """While a command runs: SIGTERM raises :class:`Terminated` (SIGINT raises KeyboardInterrupt, as
    always), and either one is delivered again if its exception was swallowed (:func:`_redeliver`)."""
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():  # signals reach the main thread only
        yield
        return
    previous = signal.signal(signal.SIGTERM, _terminate)
    previous_hook = sys.unraisablehook
    signals = ((KeyboardInterrupt, signal.SIGINT), (Terminated, signal.SIGTERM))
    sys.unraisablehook = lambda u: _redeliver(u, previous_hook, signals)
    try:
        yield
    finally:
        sys.unraisablehook = previous_hook
        signal.signal(signal.SIGTERM, previous)

"""Several workers on one study (:func:`jaco.search` ``worker=``): each writes a heartbeat, and the
RUNNING trials of a dead worker are claimed by exactly one other worker through an atomic
RUNNING → FAIL transition and evaluated again, once, as a new trial (:class:`Workers`)."""

from __future__ import annotations

import time
from typing import NamedTuple

import numpy as np

from .search_checks import SearchError, positive_seconds
from .search_storage import end_session
from .store import process_exists

BEAT = "jaco_worker:"  # the study's user attribute per worker: its last heartbeat (time.time(); 0: it stopped)


class Heartbeats(NamedTuple):
    """``worker`` (this process's index), ``interval`` and ``grace`` (seconds), checked."""

    worker: int
    interval: float
    grace: float


def check_heartbeats(worker, interval, grace) -> Heartbeats:
    """``(worker, heartbeat_interval, grace_period)`` checked; the grace period defaults to three
    heartbeat intervals."""
    if isinstance(worker, bool) or not isinstance(worker, (int, np.integer)) or not 0 <= worker < 2**20:
        raise SearchError(f"worker must be an integer >= 0 (this worker's index), got {worker!r}")
    interval = positive_seconds("heartbeat_interval", interval)
    grace = 3 * interval if grace is None else positive_seconds("grace_period", grace)
    if grace <= interval:
        raise SearchError(f"grace_period ({grace:g} s) must be longer than heartbeat_interval ({interval:g} s)")
    return Heartbeats(int(worker), interval, grace)


class Workers:
    """This worker's heartbeat (a thread writes the study attribute ``jaco_worker:ID`` every
    ``interval`` seconds; 0 when the worker stops) and the takeover of the trials of dead workers:
    a RUNNING trial is a dead worker's when its owner's heartbeat is older than ``grace`` (or 0,
    or the owner was a process of this host that no longer exists). :meth:`claim` fails such a
    trial through one atomic storage transition, so exactly one worker wins it; :meth:`replace`
    makes the new trial that evaluates it again. ``storage`` is the storage object the study was
    opened on (:func:`jaco.research.search_storage.opened`)."""

    def __init__(self, study, storage, claim_lock, interval: float, grace: float):
        import os
        import socket
        import threading
        import uuid

        self.study, self.storage, self.claim_lock = study, storage, claim_lock
        self.interval, self.grace = interval, grace
        self.host = socket.gethostname()
        self.id = f"{self.host}:{os.getpid()}:{uuid.uuid4().hex[:8]}"
        self.study_id = storage.get_study_id_from_name(study.study_name)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._beat_loop, name="jaco-heartbeat", daemon=True)

    def start(self) -> None:
        self._beat(time.time())
        self._thread.start()

    def stop(self) -> None:
        """No more heartbeats; a trial this worker leaves RUNNING is free for takeover at once."""
        self._stop.set()
        if self._thread.ident is not None:  # (an interrupt may land inside start, before the thread)
            self._thread.join()
        try:
            self._beat(0.0)
        except Exception:  # noqa: BLE001 - the storage failed (what stopped the search?): its heartbeat ages out
            pass

    def _beat(self, when: float) -> None:
        self.storage.set_study_user_attr(self.study_id, BEAT + self.id, when)

    def _beat_loop(self) -> None:
        while not self._stop.wait(self.interval):
            try:
                self._beat(time.time())
            except Exception:  # noqa: BLE001 - a busy storage misses one beat; the grace period allows it
                pass

    def alive(self, owner: str | None, beats: dict) -> bool:
        """Whether worker ``owner`` (None: a trial of a jaco before workers) may still run its trials."""
        if owner == self.id:
            return True
        beat = beats.get(BEAT + owner) if owner else None
        if not beat:
            return False
        host, pid, _ = owner.rsplit(":", 2)  # type: ignore[union-attr]
        if host == self.host and not process_exists(int(pid)):
            return False
        return time.time() - float(beat) < self.grace

    def running(self, trials) -> tuple[list, list]:
        """RUNNING ``trials`` split into (live workers' trials, dead workers' trials); a trial asked
        but never given its parameters (its worker killed in between) is dead once older than the
        grace period."""
        beats = self.storage.get_study_user_attrs(self.study_id)
        live: list = []
        dead: list = []
        for t in trials:
            if "jaco_trial" in t.user_attrs:
                ok = self.alive(t.user_attrs["jaco_trial"].get("owner"), beats)
            else:
                started = t.datetime_start.timestamp() if t.datetime_start else 0.0
                ok = time.time() - started < self.grace
            (live if ok else dead).append(t)
        return live, dead

    def trial_id(self, number: int) -> int:
        """The storage's id of the study's trial ``number``."""
        return self.storage.get_trial_id_from_study_id_trial_number(self.study_id, number)

    def claim(self, frozen) -> bool:
        """Mark a dead worker's RUNNING trial FAIL; True for the one worker whose transition did it."""
        import optuna
        from optuna.trial import TrialState

        tid = self.trial_id(frozen.number)
        with self.claim_lock():
            try:
                if self.storage.get_trial(tid).state != TrialState.RUNNING:
                    return False
                return bool(self.storage.set_trial_state_values(tid, TrialState.FAIL))
            except (optuna.exceptions.UpdateFinishedTrialError, optuna.exceptions.StorageInternalError):
                return False  # another worker failed it first

    def take_over(self, frozen, retry: bool):
        """Claim a dead worker's RUNNING trial (:meth:`claim`) and, with ``retry``, make the new
        trial that evaluates it again (:meth:`replace`); that new trial, or None where another
        worker won the claim (or without ``retry``).

        The claim and the new trial are two storage writes. A stop between them (Ctrl-C, SIGTERM)
        would leave a FAIL trial that no later search retries (they take over RUNNING trials only),
        so the interrupted worker makes the new trial on its way out, unless the write it
        interrupted had made it already. That trial is RUNNING and owned by a worker that is
        stopping, so the next search takes it over at once. Only an interrupt inside the claim's
        own storage call, after its transition, still loses the retry."""
        won = False
        try:
            won = self.claim(frozen)
            return self.replace(frozen) if won and retry else None
        except BaseException as e:
            if won and retry:
                end_session(self.storage, e)  # the interrupted write may have left its transaction open
                trials = self.study.get_trials(deepcopy=False)
                if frozen.number not in [t.user_attrs.get("jaco_trial", {}).get("retry_of") for t in trials]:
                    self.replace(frozen)
            raise

    def replace(self, frozen):
        """A new RUNNING trial owned by this worker with ``frozen``'s parameters, attributes and
        intermediate values (``retry_of``: its number)."""
        from datetime import datetime

        from optuna.trial import FrozenTrial, Trial, TrialState

        attrs = dict(frozen.user_attrs)
        attrs["jaco_trial"] = {**attrs["jaco_trial"], "owner": self.id, "retry_of": frozen.number}
        template = FrozenTrial(
            number=-1,
            state=TrialState.RUNNING,
            value=None,
            datetime_start=datetime.now(),
            datetime_complete=None,
            params=frozen.params,
            distributions=frozen.distributions,
            user_attrs=attrs,
            system_attrs=frozen.system_attrs,
            intermediate_values=frozen.intermediate_values,
            trial_id=-1,
        )
        return Trial(self.study, self.storage.create_new_trial(self.study_id, template_trial=template))

"""Fork pool processes only while no thread of the worker's main process is using the SQLite database.

SQLite keeps its file-lock bookkeeping in process memory, and a forked child inherits it. A pool process
forked (to replace a killed one) while a main-process thread (reconciler, heartbeats) held a SQLite lock
believes that lock is still held inside itself, forever: every job it runs fails with "database is locked".
The guard counts the connections checked out of the engine's pool and holds forks back until none is.
"""

from __future__ import annotations

import os
import threading

from sqlalchemy import Engine, event

FORK_WAIT_SECONDS = 30.0  # a fork never waits longer than this (a stuck thread must not stop the pool for good)


class ForkGuard:
    """Counts checked-out connections of one engine; `before_fork` waits for none and holds new ones back."""

    def __init__(self) -> None:
        self._idle = threading.Condition()
        self._in_use = 0
        self._forking = False

    def checkout(self, *_: object) -> None:
        with self._idle:
            self._idle.wait_for(lambda: not self._forking, FORK_WAIT_SECONDS)
            self._in_use += 1

    def checkin(self, *_: object) -> None:
        with self._idle:
            self._in_use = max(self._in_use - 1, 0)
            self._idle.notify_all()

    def before_fork(self) -> None:
        with self._idle:
            self._forking = True
            self._idle.wait_for(lambda: self._in_use == 0, FORK_WAIT_SECONDS)

    def after_fork(self) -> None:
        with self._idle:
            self._forking = False
            self._idle.notify_all()


def guard_forks(engine: Engine) -> ForkGuard:
    """Install the guard on a SQLite engine of this (main) process."""
    guard = ForkGuard()
    event.listen(engine, "checkout", guard.checkout)
    event.listen(engine, "checkin", guard.checkin)
    os.register_at_fork(before=guard.before_fork, after_in_parent=guard.after_fork, after_in_child=guard.after_fork)
    return guard

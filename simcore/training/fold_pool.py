"""Train one model per fold of source families on a few processes, with one progress count over all of them.

`rigforge train skin-cv` (skin_family_cv.py) and the family ensemble (skin_ensemble.py) both train the same recipe
once per group of corpus `train` families, each time without that group (`assets.family_folds`). The folds run
on `workers` spawned processes (torch in a forked child of a process that used it can hang); each reports its
training step through a queue, and `report(steps done, steps in all)` is called once per change. The workers and
the queue's manager exit within PARENT_POLL_S of their parent's death (a `kill` of the command, which Python's pool
does not pass on to them), so no training runs on with nobody to take its result.
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import threading
import time
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from multiprocessing.managers import SyncManager
from typing import Any, TypeVar

T = TypeVar("T")
POLL_S = 1.0
PARENT_POLL_S = 1.0


def exit_with_parent(parent: int) -> None:
    """Start a daemon thread that ends this process once its parent (pid `parent`) is gone (a pool's initializer)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(PARENT_POLL_S)
        os._exit(1)  # the parent is gone: nobody reads this process's result

    threading.Thread(target=watch, name="exit-with-parent", daemon=True).start()


def run_folds(job: Callable[[int, Any], T], steps: list[int], workers: int, report: Callable[[int, int], None]) -> list[T]:
    """[job(k, progress) for k in range(len(steps))] on `workers` processes, started in that order, returned in it.
    `job` must be picklable (a module-level function or a partial of one); job k puts (k, step) on `progress` as it
    trains its steps[k] steps."""
    folds = len(steps)
    done, reported = [0] * folds, -1
    context = multiprocessing.get_context("spawn")
    manager = SyncManager(ctx=context)
    manager.start(exit_with_parent, (os.getpid(),))
    with manager, ProcessPoolExecutor(workers, mp_context=context, initializer=exit_with_parent, initargs=(os.getpid(),)) as pool:
        progress = manager.Queue()
        futures: dict[Future, int] = {pool.submit(job, k, progress): k for k in range(folds)}
        pending = set(futures)
        results: dict[int, T] = {}
        while pending:
            finished, pending = wait(pending, timeout=POLL_S, return_when=FIRST_COMPLETED)
            results.update((futures[f], f.result()) for f in finished)
            try:
                while True:
                    fold, step = progress.get_nowait()
                    done[fold] = step
            except queue.Empty:
                pass
            if sum(done) != reported:  # one report per change (a plain log gets one line each)
                reported = sum(done)
                report(reported, sum(steps))
    return [results[k] for k in range(folds)]


def step_reporter(fold: int, progress: Any) -> Callable[[int, int, dict], None]:
    """A `train_skin` report callback that puts (fold, step) on `progress` (None: reports nothing)."""

    def report(step: int, total: int, entry: dict) -> None:
        if progress is not None:
            progress.put((fold, step))

    return report

"""The time budget of one running stage.

Checked wherever the stage reports progress or checks for cancel; in the main thread a SIGALRM timer also
interrupts a stage that never checks (between Python bytecodes: a long native call ends first). A SIGALRM
timer already armed (e.g. pytest-timeout's) keeps its deadline and handler: it fires if it is due first, and is
re-armed for its remaining time after the stage. Native code the alarm interrupts may turn the StageTimeout into
an error of its own (numpy raises TypeError from a comparison it was inside): once the alarm has fired, whatever
leaves the stage leaves as the StageTimeout.
"""

from __future__ import annotations

import signal
import threading
import time
from types import FrameType, TracebackType
from typing import Any

from simcore.budgets import StageTimeout


class StageClock:
    """Context manager around one stage; `check()` raises StageTimeout once `seconds` have passed (0: never)."""

    def __init__(self, stage: str, seconds: float) -> None:
        self.stage, self.seconds = stage, seconds
        self.started = time.monotonic()
        self._previous: Any = None  # the SIGALRM handler before this stage's, as signal.signal returns it
        self._previous_left = 0.0  # seconds the timer armed before this stage had left when it began (0: none)
        self._armed = False
        self._fired = False  # the alarm raised the stage's StageTimeout

    def error(self) -> StageTimeout:
        return StageTimeout(f"the {self.stage} stage ran past its time budget of {self.seconds:g} s "
                            f"(RIGFORGE_BUDGETS__{self.stage.upper()}_SECONDS); try a smaller mesh or a shorter clip")

    def check(self) -> None:
        if self.seconds and time.monotonic() - self.started > self.seconds:
            raise self.error()

    def _alarm(self, signum: int, frame: FrameType | None) -> None:
        if time.monotonic() - self.started >= self.seconds:
            self._fired = True
            raise self.error()
        self._previous_left = 0.0  # the earlier timer was due first: it has fired
        signal.setitimer(signal.ITIMER_REAL, self.seconds - (time.monotonic() - self.started))
        if callable(self._previous):
            self._previous(signum, frame)

    def __enter__(self) -> StageClock:
        self.started, self._fired = time.monotonic(), False
        if self.seconds and threading.current_thread() is threading.main_thread():
            self._previous_left = signal.getitimer(signal.ITIMER_REAL)[0]
            self._previous = signal.signal(signal.SIGALRM, self._alarm)
            first = min(self.seconds, self._previous_left) if self._previous_left else self.seconds
            signal.setitimer(signal.ITIMER_REAL, first)
            self._armed = True
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        if self._armed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, signal.SIG_DFL if self._previous is None else self._previous)
            if self._previous_left:
                left = self._previous_left - (time.monotonic() - self.started)
                signal.setitimer(signal.ITIMER_REAL, max(left, 1e-3))  # overdue: fire at once
            self._armed = False
        if self._fired and exc is not None and not isinstance(exc, StageTimeout):
            raise self.error() from exc

"""The time budget of one running stage.

Checked wherever the stage reports progress or checks for cancel; in the main thread a SIGALRM timer also
interrupts a stage that never checks (between Python bytecodes: a long native call ends first).
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
        self._armed = False

    def error(self) -> StageTimeout:
        return StageTimeout(f"the {self.stage} stage ran past its time budget of {self.seconds:g} s "
                            f"(RIGFORGE_BUDGETS__{self.stage.upper()}_SECONDS); try a smaller mesh or a shorter clip")

    def check(self) -> None:
        if self.seconds and time.monotonic() - self.started > self.seconds:
            raise self.error()

    def _alarm(self, signum: int, frame: FrameType | None) -> None:
        raise self.error()

    def __enter__(self) -> StageClock:
        self.started = time.monotonic()
        if self.seconds and threading.current_thread() is threading.main_thread():
            self._previous = signal.signal(signal.SIGALRM, self._alarm)
            signal.setitimer(signal.ITIMER_REAL, self.seconds)
            self._armed = True
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None) -> None:
        if self._armed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, signal.SIG_DFL if self._previous is None else self._previous)
            self._armed = False

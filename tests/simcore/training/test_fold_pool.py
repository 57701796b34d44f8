"""The fold pool's workers end with the command that started them."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def _alive(pid: int) -> bool:
    """True while `pid` runs (a zombie left for init to reap counts as gone)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except FileNotFoundError:
        return False
    return fields[0] != "Z"


def _children(pid: int) -> list[int]:
    """The processes whose parent is `pid`."""
    out = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except (FileNotFoundError, ProcessLookupError):
            continue
        if int(fields[1]) == pid:
            out.append(int(stat.parent.name))
    return out


def _wait_for(condition: Callable[[], bool], seconds: float) -> bool:
    """Poll `condition` until it holds or `seconds` pass; its last value."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.2)
    return condition()


def test_workers_exit_when_the_command_is_killed(tmp_path: Path) -> None:
    command = subprocess.Popen([sys.executable, "-m", "tests.simcore.training.fold_pool_sleeper", str(tmp_path)], cwd=ROOT)
    try:
        assert _wait_for(lambda: len(list(tmp_path.glob("*.pid"))) == 2, 60), "the two folds did not start"
        folds = [int(p.read_text()) for p in tmp_path.glob("*.pid")]
        pids = _children(command.pid)  # the fold workers, the queue's manager, multiprocessing's resource tracker
        assert set(folds) <= set(pids) and all(_alive(pid) for pid in pids)
        command.send_signal(signal.SIGTERM)  # what `kill` sends; Python's pool does not pass it on to the workers
        command.wait(10)
        assert _wait_for(lambda: not any(_alive(pid) for pid in pids), 10), "a process of the pool outlived the command"
    finally:
        command.kill()
        command.wait()

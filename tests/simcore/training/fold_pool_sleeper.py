"""A command for test_fold_pool: two folds that write their process ids into DIR and then sleep."""

from __future__ import annotations

import os
import sys
import time
from functools import partial
from pathlib import Path
from typing import Any

from simcore.training.fold_pool import run_folds


def sleeper(folder: str, fold: int, progress: Any) -> None:
    """Write this process's id to FOLDER/<fold>.pid, then sleep far longer than the test waits."""
    Path(folder, f"{fold}.pid").write_text(str(os.getpid()))
    time.sleep(600)


if __name__ == "__main__":
    run_folds(partial(sleeper, sys.argv[1]), [1, 1], 2, lambda done, total: None)

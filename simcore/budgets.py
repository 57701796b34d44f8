"""Per-job resource budgets: a time budget per stage, a memory cap per worker process, a surface-sample budget.

The service reads them from settings (`RIGFORGE_BUDGETS__<NAME>`); the pipeline makes the job's budgets current
(`use`) so that deep code such as the voxeliser can read them (`current`) without threading them through every call.
"""

from __future__ import annotations

import os
import resource
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field

from simcore.errors import SimcoreError

MIB = 1024 * 1024
AUTO_MEMORY_SHARE = 0.8  # of the machine's (or container's) memory, split between a worker's pool processes
STAGES = ("ingest", "skeleton", "skin", "motion", "refine", "export")


class StageTimeout(SimcoreError):
    """A pipeline stage ran past its time budget."""

    code = "stage_timeout"


class OutOfMemory(SimcoreError):
    """A stage needed more memory than the worker process may use."""

    code = "out_of_memory"


class Budgets(BaseModel):
    """Budgets of one job (RIGFORGE_BUDGETS__<NAME>). A time budget of 0 turns that stage's budget off."""

    model_config = ConfigDict(extra="forbid")

    ingest_seconds: float = Field(300.0, ge=0, description="time budget of the ingest stage")
    skeleton_seconds: float = Field(900.0, ge=0, description="time budget of the skeleton stage")
    skin_seconds: float = Field(900.0, ge=0, description="time budget of the skin stage")
    motion_seconds: float = Field(600.0, ge=0, description="time budget of the motion stage")
    refine_seconds: float = Field(2400.0, ge=0, description="time budget of the physics refinement stage")
    export_seconds: float = Field(900.0, ge=0, description="time budget of the export stage")
    worker_memory_mb: int = Field(0, ge=0, description="memory cap of each worker pool process (its data segment, "
                                  "RLIMIT_DATA), MB; 0 = 80 % of the machine's memory split between the pool processes")
    surface_samples: int = Field(10_000_000, ge=1000, description="points the voxeliser may place on one mesh's "
                                 "triangles; a mesh needing more fails with too_large")

    def stage_seconds(self, stage: str) -> float:
        """The time budget of `stage` in seconds (0: none)."""
        return float(getattr(self, f"{stage}_seconds", 0.0))

    def memory_cap_bytes(self, processes: int = 1) -> int:
        """The memory cap of one of `processes` worker processes, in bytes."""
        if self.worker_memory_mb:
            return self.worker_memory_mb * MIB
        return int(machine_memory_bytes() * AUTO_MEMORY_SHARE / max(processes, 1))


_current: ContextVar[Budgets | None] = ContextVar("simcore_budgets", default=None)


def current() -> Budgets:
    """The budgets of the job running in this context (defaults outside a job)."""
    return _current.get() or Budgets()


@contextmanager
def use(budgets: Budgets) -> Iterator[None]:
    """Make `budgets` current for the code run inside."""
    token = _current.set(budgets)
    try:
        yield
    finally:
        _current.reset(token)


def machine_memory_bytes() -> int:
    """Physical memory, or the container's cgroup v2 limit when that is lower."""
    total = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    try:
        limit = Path("/sys/fs/cgroup/memory.max").read_text().strip()
    except OSError:
        return total
    return min(total, int(limit)) if limit.isdigit() else total


def apply_memory_cap(cap_bytes: int) -> None:
    """Cap this process's data segment (heap and anonymous mappings, RLIMIT_DATA): an allocation past it raises
    MemoryError (numpy) or an allocator RuntimeError (torch, warp) instead of waking the kernel's OOM killer.
    RLIMIT_DATA rather than RLIMIT_AS: torch and warp reserve address space they never touch."""
    _, hard = resource.getrlimit(resource.RLIMIT_DATA)
    resource.setrlimit(resource.RLIMIT_DATA, (cap_bytes if hard == resource.RLIM_INFINITY else min(cap_bytes, hard), hard))


def process_memory_cap() -> int | None:
    """The data-segment cap of this process in bytes, None when it has none."""
    soft, _ = resource.getrlimit(resource.RLIMIT_DATA)
    return None if soft == resource.RLIM_INFINITY else int(soft)


def is_allocation_failure(exc: BaseException) -> bool:
    """Whether `exc` is an allocator refusing memory: numpy's MemoryError or torch's and warp's RuntimeError."""
    if isinstance(exc, MemoryError):
        return True
    text = str(exc)
    return isinstance(exc, RuntimeError) and ("can't allocate memory" in text or "Failed to allocate" in text)


def out_of_memory(stage: str) -> OutOfMemory:
    """The error for a stage whose allocation was refused, naming the cap."""
    cap = process_memory_cap()
    limit = (f"the worker's memory cap of {cap / MIB:,.0f} MB (RIGFORGE_BUDGETS__WORKER_MEMORY_MB)" if cap is not None
             else "the memory this machine has")
    return OutOfMemory(f"the {stage} stage needed more memory than {limit}; try a smaller mesh or a shorter clip")

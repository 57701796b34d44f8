"""The rigging pipeline: ordered stages over one PipelineState, with progress and cancel checks.

Each stage module exposes `run(state: PipelineState, progress: StageProgress) -> None`, reads what
earlier stages left on the state and writes its own fields and artifacts into `state.workdir`.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from simcore.options import JobOptions

if TYPE_CHECKING:
    import numpy as np
    import scipy.sparse as sp

    from simcore.budgets import Budgets
    from simcore.ingest import IngestedMesh
    from simcore.io.gltf_morph_sequence import MeshSequence
    from simcore.motion.types import JointAnimation
    from simcore.skeleton.types import Skeleton
    from simcore.stage_clock import StageClock

ProgressCallback = Callable[[str, float], None]  # (stage name, overall fraction 0..1)
CancelCheck = Callable[[], None]  # raises simcore.errors.Canceled when the job was canceled


@dataclass
class PipelineInputs:
    """Uploaded files, already stored and sniffed. Formats: glb, gltf, obj, ply, stl, bvh."""

    mesh_path: Path
    mesh_format: str
    motion_path: Path | None = None
    motion_format: str | None = None
    motion_name: str | None = None  # the uploaded file's own name (stored files are named by hash): names the clip
    skeleton_path: Path | None = None  # an edited skeleton.json to re-skin with (`skeleton: keep`)


@dataclass
class PipelineState:
    """Everything stages share. `report` becomes report.json; `artifacts` maps name → file in workdir."""

    inputs: PipelineInputs
    options: JobOptions
    workdir: Path
    report: dict[str, Any] = field(default_factory=dict)
    artifacts: dict[str, Path] = field(default_factory=dict)
    mesh: IngestedMesh | None = None
    skeleton: Skeleton | None = None
    ground_faces: np.ndarray | None = None  # (F,) bool: ground-plane triangles, left out of skeleton and skinning
    weights: sp.csr_matrix | None = None  # (V, J) float32, rows sum to 1
    animation: JointAnimation | None = None
    mesh_sequence: MeshSequence | None = None  # (T, V, 3) frames of a mesh-sequence upload, in the mesh's frame
    refined_frames: np.ndarray | None = None  # (T, V, 3) float32 simulated vertex positions
    stage: str = "ingest"  # the stage running now: where warnings come from

    def body_faces(self) -> np.ndarray:
        """The mesh's faces but a ground plane's (it is bound rigidly to the root)."""
        assert self.mesh is not None, "ingest runs first"
        faces = self.mesh.faces
        return faces if self.ground_faces is None else faces[~self.ground_faces]

    def warn(self, message: str, *, code: str = "notice", figure: float | None = None,
             threshold: float | None = None) -> None:
        """Record a user-facing warning of the current stage (report.json and the job's `warnings`)."""
        from simcore.gate.warnings import add_warning

        add_warning(self.report, code=code, stage=self.stage, message=message, figure=figure, threshold=threshold)


class StageProgress:
    """Maps a stage's own 0..1 progress onto the job's overall progress, checks for cancel and the stage's budget."""

    def __init__(self, name: str, start: float, span: float, report: ProgressCallback, check_cancel: CancelCheck,
                 clock: StageClock | None = None):
        self.name, self._start, self._span = name, start, span
        self._report, self._check_cancel, self._clock = report, check_cancel, clock

    def __call__(self, fraction: float) -> None:
        self._report(self.name, self._start + self._span * min(max(fraction, 0.0), 1.0))
        if self._clock is not None:
            self._clock.check()

    def check_cancel(self) -> None:
        self._check_cancel()
        if self._clock is not None:
            self._clock.check()


def _stages(from_motion: bool = False) -> list[tuple[str, float, Callable[[PipelineState, StageProgress], None]]]:
    """(name, relative cost, run) in execution order; imported lazily so the API never loads torch.

    from_motion: the upload is a mesh sequence rigged from its motion (simcore.motion_rig), whose one stage
    stands in for skeleton, skin and motion."""
    from simcore import export_stage, ingest
    from simcore.motion import stage as motion_stage
    from simcore.mpm import refine_stage
    from simcore.skeleton import stage as skeleton_stage
    from simcore.skinning import stage as skin_stage

    if from_motion:
        from simcore.motion_rig import stage as motion_rig_stage

        return [("ingest", 1.0, ingest.run), ("skeleton", 3.0, motion_rig_stage.run), ("export", 1.0, export_stage.run)]
    return [
        ("ingest", 1.0, ingest.run),
        ("skeleton", 1.0, skeleton_stage.run),
        ("skin", 1.0, skin_stage.run),
        ("motion", 0.5, motion_stage.run),
        ("refine", 4.0, refine_stage.run),  # optional PhysRig MPM; returns at once unless refine.enabled
        ("export", 1.0, export_stage.run),  # keep last: writes and validates every output
    ]


def run_pipeline(
    inputs: PipelineInputs,
    options: JobOptions,
    workdir: Path,
    on_progress: ProgressCallback = lambda stage, fraction: None,
    check_cancel: CancelCheck = lambda: None,
    budgets: Budgets | None = None,
) -> PipelineState:
    """Run every applicable stage and its quality checks, write report.json, return the final state (artifacts
    in workdir). Each stage runs within its time budget (StageTimeout), a refused allocation fails it with
    OutOfMemory, and a job that cannot fit the memory budget fails before its heavy stages (too_large). A
    SimcoreError leaves with the warnings recorded so far in its `warnings`."""
    from simcore.budgets import Budgets, use

    workdir.mkdir(parents=True, exist_ok=True)
    state = PipelineState(inputs, options, workdir)
    with use(budgets or Budgets()):
        _run_stages(state, on_progress, check_cancel)
    report_path = workdir / "report.json"
    report_path.write_text(json.dumps(state.report, indent=2, default=str))
    state.artifacts["report.json"] = report_path
    on_progress("done", 1.0)
    return state


def _run_stages(state: PipelineState, on_progress: ProgressCallback, check_cancel: CancelCheck) -> None:
    from simcore.budgets import current, is_allocation_failure, out_of_memory
    from simcore.errors import SimcoreError
    from simcore.gate.checks import check_stage
    from simcore.job_cost import check_fits
    from simcore.stage_clock import StageClock

    wanted = state.options.stages
    stages = [s for s in _stages() if wanted is None or s[0] == "ingest" or s[0] in wanted]
    total = sum(cost for _, cost, _ in stages)
    done = 0.0
    timings: dict[str, float] = {}
    while stages:
        name, cost, run = stages.pop(0)
        check_cancel()
        started = time.perf_counter()
        on_progress(name, done / total)
        state.stage = name
        refused = False
        try:
            check_fits(name, state)
            with StageClock(name, current().stage_seconds(name)) as clock:
                run(state, StageProgress(name, done / total, cost / total, on_progress, check_cancel, clock))
                clock.check()
            check_stage(name, state)
        except SimcoreError as exc:
            exc.warnings = list(state.report.get("warnings", []))
            raise
        except (MemoryError, RuntimeError) as exc:
            if not is_allocation_failure(exc):
                raise
            refused = True  # raised below, once this handler has dropped the failed stage's frames and arrays
        if refused:
            error = out_of_memory(name)
            error.warnings = list(state.report.get("warnings", []))
            raise error
        timings[name] = round(time.perf_counter() - started, 3)
        done += cost
        if name == "ingest" and state.mesh_sequence is not None and state.options.skeleton in ("auto", "from_motion"):
            stages = [s for s in _stages(from_motion=True)[1:] if wanted is None or s[0] in wanted]
            total = done + sum(c for _, c, _ in stages)
    state.report["timings_s"] = timings

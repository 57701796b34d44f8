"""Quality-gate calibration: the gate's figures measured on the artists' own rigs playing their own clips.

For every rigged .glb/.gltf in DIR (loader stress tests excluded): the artist's weights and used joints
(weights, skeleton figures) and, for every clip in the file, the artist's LBS animation over all its frames
at the clip's own rate (edge stretch percentiles and volume ratio per frame, as the gate measures a job's
animation). `simcore.gate.thresholds.derive` turns these rows into the gate's thresholds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from simcore.errors import SimcoreError
from simcore.evaluation.assets import rigged_assets
from simcore.evaluation.motion_eval import EXCLUDED, world_bind
from simcore.gate.measures import deformation_series, lbs_blocks, skeleton_figures, weight_figures
from simcore.io.gltf_rig import used_joints
from simcore.metrics.skeleton import used_skeleton
from simcore.motion.gltf_clips import clip_names, read_gltf_clip
from simcore.motion.quality import skin_matrices


@dataclass
class RigRow:
    """Static figures of one artist rig."""

    name: str
    category: str
    unweighted_vertices: int = 0
    max_row_sum_error: float = 0.0
    non_finite_weights: int = 0
    joints_inside: float = 1.0
    zero_length_bone_share: float = 0.0


@dataclass
class ClipRow:
    """Worst frames of one artist rig playing one of its own clips."""

    name: str
    clip: str
    frames: int
    fps: float
    stretch_low: float  # lowest per-frame 1st percentile of edge length ratio
    stretch_low_frame: int
    stretch_high: float  # highest per-frame 99th percentile
    stretch_high_frame: int
    volume_low: float | None
    volume_high: float | None


@dataclass
class GateCalibration:
    rigs: list[RigRow] = field(default_factory=list)
    clips: list[ClipRow] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"rigs": [asdict(r) for r in self.rigs], "clips": [asdict(c) for c in self.clips], "skipped": self.skipped}


def _clip_row(name: str, doc: Any, asset: Any, index: int) -> ClipRow:
    clip = read_gltf_clip(doc, index, asset=asset)
    vertices, clip = world_bind(doc, asset, clip)
    mats = skin_matrices(clip.skeleton, clip.animation)
    s = deformation_series(vertices, asset.faces, lbs_blocks(vertices, asset.weights, mats))
    lo, hi = int(np.argmin(s.stretch_low)), int(np.argmax(s.stretch_high))
    vol = s.volume_ratio
    return ClipRow(name, clip.animation.name, clip.animation.num_frames, round(clip.animation.fps, 3),
                   float(s.stretch_low[lo]), lo, float(s.stretch_high[hi]), hi,
                   None if vol is None else float(vol.min()), None if vol is None else float(vol.max()))


def calibrate_gate(directory: Path, *, on_asset: Callable[[str], None] = lambda name: None) -> GateCalibration:
    """Measure every artist rig in `directory` and every clip it carries (see the module docstring)."""
    out = GateCalibration()
    for name, category, doc, asset in rigged_assets(Path(directory), out.skipped):
        if name in EXCLUDED:
            continue
        on_asset(name)
        referenced = np.unique(asset.faces)
        figures = weight_figures(asset.weights, referenced)
        row = RigRow(name, category, unweighted_vertices=int(figures["unweighted_vertices"]),
                     max_row_sum_error=figures["max_row_sum_error"], non_finite_weights=int(figures["non_finite_weights"]))
        skeleton = used_skeleton(asset.skeleton, used_joints(asset.skeleton, asset.weights))
        row.joints_inside, row.zero_length_bone_share = skeleton_figures(skeleton, asset.vertices, asset.faces).values()
        out.rigs.append(row)
        for index, clip in enumerate(clip_names(doc)):
            try:
                out.clips.append(_clip_row(name, doc, asset, index))
            except SimcoreError as exc:
                out.skipped[f"{name}/{clip}"] = f"{exc.code}: {exc}"
    return out

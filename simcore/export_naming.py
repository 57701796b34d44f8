"""Joint naming applied once, at the start of the export stage, to everything written from then on.

Effective preset: `options.naming` when given; otherwise `mixamo` for predicted skeletons (Mixamo names on
humanoids, descriptive names on the rest) and none for `skeleton: keep`, whose rig keeps the upload's names.
Renames state.skeleton, state.animation's joints and skeleton.json's names; report["naming"] says how.
Earlier stages (retargeting by names, exclude_joints, bone_stiffness) worked on the names before it.
"""

from __future__ import annotations

import json
from dataclasses import replace
from typing import TYPE_CHECKING

from simcore.skeleton.naming import joint_names, renamed

if TYPE_CHECKING:
    from simcore.pipeline import PipelineState
    from simcore.skeleton.bone_maps import Preset


def effective_preset(state: PipelineState) -> Preset | None:
    """The naming preset this job's export uses, or None to keep the skeleton's names."""
    if state.options.naming is not None:
        return state.options.naming
    return None if state.options.skeleton == "keep" else "mixamo"


def apply_naming(state: PipelineState) -> None:
    """Rename the job's joints by its preset (see the module docstring)."""
    preset = effective_preset(state)
    if preset is None or state.skeleton is None:
        state.report["naming"] = {"preset": None, "reason": "skeleton: keep keeps the upload's joint names"}
        return
    naming = joint_names(state.skeleton, preset)
    old = state.skeleton.names
    mapping = dict(zip(old, naming.names))
    state.skeleton = renamed(state.skeleton, naming.names)
    if state.animation is not None:
        state.animation = replace(state.animation, joint_names=[mapping[n] for n in state.animation.joint_names])
    path = state.artifacts.get("skeleton.json")
    if path is not None and path.is_file():
        doc = json.loads(path.read_text())
        doc["names"] = naming.names
        path.write_text(json.dumps(doc))
    state.report["naming"] = {"preset": preset, "reading": naming.reading,
                              "renamed": sum(a != b for a, b in zip(old, naming.names)),
                              "names": {a: b for a, b in mapping.items() if a != b}}

"""Pipeline stage `skeleton`: predict (or keep) the skeleton and write skeleton.json.

Options used: `skeleton` (auto | geometric | humanoid | learned | keep), `max_joints`, `up_axis`, `forward_axis`.
`keep` reuses the upload's own skin (state.mesh.source_rig, already in the mesh frame), or the skeleton file
given next to the mesh (inputs.skeleton_path, an edited skeleton.json: simcore.skeleton.skeleton_file). A ground plane
under the model (simcore.geometry.ground) is left out and recorded in state.ground_faces. The ingested mesh
is +Y up (ingest applies an `up_axis` override), so the humanoid fit is told "y" when an override was
given and detects the up axis itself otherwise.

skeleton.json: {"method", "names", "parents", "positions" (mesh frame, metres), "kinds", "orientations",
"tokens": {"ids", "class", "normalization": {"center", "scale"}} or null with "tokens_error"}.
"""

from __future__ import annotations

import json
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from simcore.arrays import unique_ints
from simcore.errors import InvalidInput, SimcoreError
from simcore.geometry.ground import ground_faces
from simcore.geometry.parts import SurfacePart, surface_parts
from simcore.skeleton.coverage import unreached_parts
from simcore.skeleton.origin_root import ADDED, origin_root
from simcore.skeleton.predict import SkeletonPrediction, predict_skeleton
from simcore.skeleton.types import Skeleton

if TYPE_CHECKING:
    from pathlib import Path

    from simcore.geometry.mesh import IngestedMesh
    from simcore.options import JobOptions
    from simcore.pipeline import PipelineState, StageProgress
    from simcore.skeleton.geometric import GeometricParams


def _tokens(skeleton: Skeleton, vertices: np.ndarray) -> tuple[dict[str, Any] | None, str | None]:
    """UniRig token ids of `skeleton` normalised by the mesh's bounding box, or (None, why not)."""
    try:
        from simcore.skeleton.tokenizer import Normalization, SkeletonTokenizer
    except ImportError as exc:  # the tokenizer is optional for rigging itself
        return None, f"tokenizer unavailable: {exc}"
    norm = Normalization.from_points(vertices)
    tokenizer = SkeletonTokenizer()
    try:
        ids = tokenizer.encode(skeleton, norm)
    except SimcoreError as exc:  # e.g. a kept studio rig longer than the token budget
        return None, str(exc)
    return {
        "ids": ids.tolist(),
        "class": tokenizer.read_class(ids),
        "normalization": {"center": norm.center.round(8).tolist(), "scale": round(float(norm.scale), 8)},
    }, None


def _given_skeleton(state: PipelineState, path: Path, vertices: np.ndarray) -> Skeleton:
    """The uploaded (edited) skeleton file at `path`; it goes with `skeleton: keep`. vertices: (V, 3) the ingested mesh's."""
    from simcore.skeleton.skeleton_file import read_skeleton_file

    if state.options.skeleton != "keep":
        raise InvalidInput("a skeleton file is used as it is: set options.skeleton to 'keep'", code="invalid_option",
                           field="options.skeleton")
    return read_skeleton_file(path.read_bytes(), vertices)


def predict_for_job(mesh: IngestedMesh, options: JobOptions, ground: np.ndarray,
                    geometric_params: GeometricParams | None = None, learned_model: Path | None = None
                    ) -> SkeletonPrediction:
    """The skeleton a job predicts for an ingested mesh with `options` (skeleton method, max_joints, axes), the
    ground-plane triangles `ground` (F,) bool left out, under a root at the file's origin (`origin_root`) unless
    options.root_joint is "none". `rigforge eval skeleton` calls this too, so its figures are what a job gives.
    geometric_params: the geometric method's tuning (None = the defaults; the ablation changes it); learned_model:
    the learned method's weights (None = the shipped file)."""
    prediction = predict_skeleton(
        mesh.vertices, mesh.faces[~ground], method=options.skeleton, max_joints=options.max_joints,
        up_axis="y" if options.up_axis else None, forward_axis=options.forward_axis, geometric_params=geometric_params,
        learned_model=learned_model,
    )
    skeleton, why = job_root(prediction.skeleton, mesh, ground, options)
    if why is None:
        return prediction
    return replace(prediction, skeleton=skeleton,
                   report={**prediction.report, "origin_root": {"added": why == ADDED, "reason": why}})


def job_root(skeleton: Skeleton, mesh: IngestedMesh, ground: np.ndarray, options: JobOptions) -> tuple[Skeleton, str | None]:
    """A predicted `skeleton` under the root options.root_joint asks for (`origin_root`: at the file's origin, judged
    against the mesh without its ground plane), and why it was or was not added (None for root_joint "none")."""
    if options.root_joint == "none":
        return skeleton, None
    return origin_root(skeleton, mesh.vertices[unique_ints(mesh.faces[~ground])], options.max_joints)


def mesh_ground(mesh: IngestedMesh) -> tuple[list[SurfacePart], np.ndarray]:
    """The mesh's connected parts and its ground-plane triangles (F,) bool (simcore.geometry.ground)."""
    parts = surface_parts(mesh.vertices, mesh.faces)
    return parts, ground_faces(parts, len(mesh.faces))


def run(state: PipelineState, progress: StageProgress) -> None:
    """Set state.skeleton, write skeleton.json, record report["skeleton"]."""
    options = state.options
    mesh = state.mesh
    if mesh is None:
        raise InvalidInput("the skeleton stage needs an ingested mesh", code="no_mesh", field="mesh")
    progress.check_cancel()
    progress(0.05)
    started = time.perf_counter()
    parts, ground = mesh_ground(mesh)
    report: dict[str, Any]
    if state.inputs.skeleton_path is not None:
        skeleton, method, report = _given_skeleton(state, state.inputs.skeleton_path, mesh.vertices), "given", {}
    elif options.skeleton == "keep":
        if mesh.source_rig is None:
            raise InvalidInput("options.skeleton is 'keep' but the uploaded mesh has no skin to keep",
                               code="no_skeleton", field="options.skeleton")
        skeleton = mesh.source_rig.skeleton.validate()
        method, report = "keep", {}
    else:
        prediction = predict_for_job(mesh, options, ground)
        skeleton, method, report = prediction.skeleton, prediction.method, prediction.report
        if options.skeleton == "humanoid" and method != "humanoid":
            state.warn("no humanoid was found with confidence; used the geometric skeleton instead")
    progress.check_cancel()
    progress(0.8)
    tokens, token_error = _tokens(skeleton, mesh.vertices[unique_ints(mesh.faces[~ground])])  # the model's box
    doc = {"method": method, **skeleton.to_dict(), "tokens": tokens}
    if token_error:
        doc["tokens_error"] = token_error
    path = state.workdir / "skeleton.json"
    path.write_text(json.dumps(doc))
    state.artifacts["skeleton.json"] = path
    state.skeleton = skeleton
    if ground.any():
        state.ground_faces = ground
        state.warn(f"a ground plane under the model ({int(ground.sum())} triangles) was left out of the skeleton and "
                   f"bound to the root joint {skeleton.names[0]!r}; remove it before rigging if it should not move with the root")
    unreached = unreached_parts(mesh.vertices, mesh.faces, [p for p in parts if not ground[p.faces].any()], skeleton)
    far_triangles = sum(len(p.faces) for p in unreached)
    if unreached:
        state.warn(f"{len(unreached)} separate part(s) of the mesh ({far_triangles} triangles) lie far from every bone and "
                   "will follow the nearest one rigidly; rig one character per file")
    state.report["skeleton"] = {
        "method": method,
        "requested": options.skeleton,
        "joints": skeleton.num_joints,
        "tokens": None if tokens is None else len(tokens["ids"]),
        "seconds": round(time.perf_counter() - started, 3),
        "ground_triangles": int(ground.sum()),
        "unreached_triangles": far_triangles,
        **report,
    }
    progress(1.0)

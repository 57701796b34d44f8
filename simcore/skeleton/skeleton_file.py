"""An edited skeleton uploaded next to the mesh (`skeleton: keep` with a skeleton file): read, checked, re-skinned.

The file is the `skeleton.json` a job writes (`names`, `parents`, `positions` in the ingested mesh's frame, metres,
+Y up; optional `orientations`, xyzw bind frames), edited: joints moved, added, deleted, re-parented or renamed.
Joints may come in any order (one root); they are put parents-first. Optional `kinds` (one JointKind value per
joint) are kept, so a helper (the root a job puts at the file's origin) still takes no weight when the tree comes
back; `file_order`, `file_parents` and `tokens` are ignored: an edited tree no longer follows the upload's skin order.
"""

from __future__ import annotations

import json

import numpy as np

from simcore.errors import InvalidInput
from simcore.io.json_bounds import JsonTooDeep, loads_bounded
from simcore.skeleton.types import JointKind, Skeleton, parents_first_order

MAX_FILE_BYTES = 1024 * 1024
MAX_JOINTS = 256  # as options.max_joints
MAX_NAME_CHARS = 200
OUTSIDE_FACTOR = 1.0  # a joint may sit at most this many mesh sizes outside the mesh's bounding box


def _fail(message: str) -> InvalidInput:
    return InvalidInput(message, code="invalid_skeleton", field="skeleton")


def _array(doc: dict, key: str, width: int | None, count: int) -> np.ndarray:
    try:
        value = np.asarray(doc[key], dtype=np.float64)
    except (KeyError, TypeError, ValueError):
        raise _fail(f"'{key}' is missing or not numbers") from None
    shape = (count,) if width is None else (count, width)
    if value.shape != shape:
        raise _fail(f"'{key}' has shape {list(value.shape)}, expected {list(shape)}")
    if not np.all(np.isfinite(value)):
        raise _fail(f"'{key}' has non-finite numbers")
    return value


def _kinds(doc: dict, count: int) -> list[JointKind]:
    """The file's `kinds`, one per joint, or none (every joint then a plain one)."""
    kinds = doc.get("kinds")
    if kinds is None:
        return []
    allowed = {k.value for k in JointKind}
    if not isinstance(kinds, list) or len(kinds) != count or not all(isinstance(k, str) and k in allowed for k in kinds):
        raise _fail(f"'kinds' must list one of {sorted(allowed)} per joint")
    return [JointKind(k) for k in kinds]


def read_skeleton_file(data: bytes, vertices: np.ndarray | None = None) -> Skeleton:
    """The Skeleton in an uploaded skeleton JSON, parents first. vertices: (V, 3) the ingested mesh, whose bounds
    the joints must stay near; None skips that check (the API reads the file before the mesh is ingested).

    Raises InvalidInput(code="invalid_skeleton", field="skeleton") naming what is wrong.
    """
    if len(data) > MAX_FILE_BYTES:
        raise _fail(f"the skeleton file is over {MAX_FILE_BYTES} bytes")
    try:
        doc = loads_bounded(data, 4)
    except (json.JSONDecodeError, UnicodeDecodeError, JsonTooDeep) as exc:
        raise _fail(f"the skeleton file is not valid JSON: {exc}") from None
    names = doc.get("names") if isinstance(doc, dict) else None
    if not isinstance(names, list) or not 1 <= len(names) <= MAX_JOINTS:
        raise _fail(f"'names' must list 1 to {MAX_JOINTS} joints")
    if not all(isinstance(n, str) and 0 < len(n.strip()) <= MAX_NAME_CHARS for n in names):
        raise _fail(f"joint names must be non-empty strings of at most {MAX_NAME_CHARS} characters")
    if len(set(names)) != len(names):
        raise _fail("joint names are not unique")
    count = len(names)
    parents = _array(doc, "parents", None, count)
    if np.any(parents != np.round(parents)):
        raise _fail("'parents' must be joint indices")
    parents = parents.astype(np.int64)
    if np.count_nonzero(parents < 0) != 1:
        raise _fail(f"the skeleton needs exactly one root (parent -1), found {int(np.count_nonzero(parents < 0))}")
    positions = _array(doc, "positions", 3, count)
    orientations = None
    if doc.get("orientations") is not None:
        orientations = _array(doc, "orientations", 4, count)
        norms = np.linalg.norm(orientations, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-3):
            raise _fail("'orientations' must be unit quaternions (xyzw)")
    try:
        order = parents_first_order(parents)
    except InvalidInput as exc:  # a cycle or an index out of range
        raise _fail(str(exc)) from None
    lo, hi = (vertices.min(axis=0), vertices.max(axis=0)) if vertices is not None else (positions.min(0), positions.max(0))
    margin = OUTSIDE_FACTOR * float((hi - lo).max())
    outside = np.flatnonzero(np.any((positions < lo - margin) | (positions > hi + margin), axis=1))
    if len(outside):
        name = names[int(outside[0])]
        raise _fail(f"joint {name!r} lies far outside the mesh (positions are in the mesh's frame, metres)")
    skeleton = Skeleton(positions, parents, names, _kinds(doc, count), orientations=orientations)
    return skeleton.reordered(order).validate()

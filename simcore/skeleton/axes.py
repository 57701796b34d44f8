"""Named axes for the `up_axis` / `forward_axis` options ("x", "-x", "y", … in the mesh's own frame)."""

from __future__ import annotations

import numpy as np

from simcore.errors import InvalidInput

AXES: dict[str, np.ndarray] = {
    "x": np.array([1.0, 0, 0]), "-x": np.array([-1.0, 0, 0]), "y": np.array([0, 1.0, 0]),
    "-y": np.array([0, -1.0, 0]), "z": np.array([0, 0, 1.0]), "-z": np.array([0, 0, -1.0]),
}
GLTF_UP = AXES["y"]


def axis(name: str | None, option: str) -> np.ndarray | None:
    """The unit vector `name` stands for, None for None; InvalidInput naming `options.<option>` otherwise."""
    if name is None:
        return None
    if name not in AXES:
        raise InvalidInput(f"unknown axis {name!r}; use one of {', '.join(AXES)}", code="invalid_option",
                           field=f"options.{option}")
    return AXES[name]

"""Named axes for the `up_axis` / `forward_axis` options ("x", "-x", "y", … in the mesh's own frame)."""

from __future__ import annotations

from typing import get_args

import numpy as np

from simcore.errors import InvalidInput
from simcore.options import Axis


def _unit(name: str) -> np.ndarray:
    """(3,) the unit vector an option name ("x", "-z", …) stands for."""
    out = np.zeros(3)
    out["xyz".index(name[-1])] = -1.0 if name.startswith("-") else 1.0
    return out


AXES: dict[str, np.ndarray] = {name: _unit(name) for name in get_args(Axis)}  # the options' own list
GLTF_UP = AXES["y"]


def axis(name: str | None, option: str) -> np.ndarray | None:
    """The unit vector `name` stands for, None for None; InvalidInput naming `options.<option>` otherwise."""
    if name is None:
        return None
    if name not in AXES:
        raise InvalidInput(f"unknown axis {name!r}; use one of {', '.join(AXES)}", code="invalid_option",
                           field=f"options.{option}")
    return AXES[name]

"""The special-case rules of the geometric method, each as the GeometricParams change that turns it off.

`rigforge eval skeleton --ablate` runs the geometric method once with all of them and once with each turned
off, so the table it prints is the evidence for every rule; `plain_params` turns all of them off (plain medial
thinning into a joint tree, the `thinning` candidate of `auto`).
"""

from __future__ import annotations

import math
from dataclasses import replace

from simcore.skeleton.geometric import GeometricParams

DEFAULT = GeometricParams()
RULES: dict[str, tuple[str, dict[str, object]]] = {
    "stronger_closing": ("retry voxelisation with a stronger closing when it shortens the medial axis",
                         {"close_retry": DEFAULT.close_radius}),
    "restore_limbs": ("give limbs that thinning erased their medial line back", {"restore_limbs": False}),
    "twin_spurs": ("keep or prune mirror-twin spurs together", {"twin_spurs": False}),
    "legs": ("denser joints and a firmer foot on legs standing on the floor", {"legs": False}),
    "limb_roots": ("a joint where a limb leaves the trunk", {"limb_roots": False}),
    "neck_pivot": ("a head's pivot where its neck is thinnest", {"neck_pivot": False}),
    "sheets": ("a flat sheet rigged as one principal-axis chain", {"sheet_ratio": 0.0}),
    "edge_loops": ("a low-poly tube gets a joint at each ring of vertices", {"loop_gap": math.inf}),
    "tip_pull": ("leaf joints pulled towards their parent", {"tip_pull": 0.0, "leg_tip_pull": 0.0}),
    "root_push": ("a chain's root pushed out to its end", {"root_push": 0.0}),
    "section_centre": ("chain joints moved to their limb's cross-section centre", {"section_limit": 0.0}),
    "mirror": ("twin joints averaged into mirror images (and the two rules below)",
               {"mirror": False, "lopsided": False, "midline_ends": False}),
    "lopsided": ("a twinless branch over bare mirrored solid dropped", {"lopsided": False}),
    "midline_ends": ("tip joints of head and tail chains on the mirror plane dropped", {"midline_ends": False}),
}


def without_rule(name: str, params: GeometricParams = DEFAULT) -> GeometricParams:
    """`params` with rule `name` (a key of RULES) turned off."""
    if name not in RULES:
        raise KeyError(f"unknown geometric rule {name!r}; expected one of {', '.join(RULES)}")
    return replace(params, **RULES[name][1])  # type: ignore[arg-type]


def plain_params(params: GeometricParams = DEFAULT) -> GeometricParams:
    """`params` with every rule of RULES turned off."""
    changes: dict[str, object] = {}
    for _, overrides in RULES.values():
        changes.update(overrides)
    return replace(params, **changes)  # type: ignore[arg-type]

"""The quality gate's thresholds: derived from the artists' own rigs (`rigforge eval gate DIR --write`) and
stored in thresholds.json beside this module, with the table they came from in thresholds.md.

Rule for a calibrated figure: the envelope is the worst value any artist rig reaches (over its rig, or every
frame of every clip it carries), so every artist rig passes its own clips. Past the envelope is a warning;
past it by a further 15 % of its deviation from rest (1.15 × the artist's worst stretch, as issue 25 bounds
our rigs against the artist's) fails the job. Invariants (no unweighted vertex, no NaN) have no tolerance.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Literal

THRESHOLDS_PATH = Path(__file__).with_name("thresholds.json")
FAIL_FACTOR = 1.15  # deviation from rest past the artist envelope that fails a job
# A float32 row of up to eight weights sums to 1 within eight float32 steps; artists' rigs stay within one.
ROW_SUM_TOLERANCE = 8 * 2.0 ** -23
# A vertex refined farther from its LBS position than its limb's radius may have left the limb: a warning only,
# as a thin part (an ear, a tail tip) can swing that far without harm; a tear also stretches edges past the
# artists' envelope, which fails.
TEAR_RADII = 1.0
# Refinement may change the enclosed volume by at most 3 % of the rest volume beyond what LBS already does.
REFINE_VOLUME_ADDED = 0.03
# Offset from LBS in character heights: the tether holds particles within options.refine.max_offset (default
# 0.01); past 0.05 is worth a look, past the option's ceiling (0.25) something escaped the tether.
REFINE_OFFSET_WARN = 0.05
REFINE_OFFSET_FAIL = 0.25


@dataclass(frozen=True)
class Threshold:
    """`bad` says which side fails: "below" (figure < limit is bad) or "above". `fail` None: warn only."""

    bad: Literal["below", "above"]
    warn: float
    fail: float | None

    def past(self, figure: float, limit: float) -> bool:
        return figure < limit if self.bad == "below" else figure > limit


# Calibrated figure → (which side is bad, its rest value, whether it can fail a job).
CALIBRATED: dict[str, tuple[Literal["below", "above"], float, bool]] = {
    "stretch_low": ("below", 1.0, True),
    "stretch_high": ("above", 1.0, True),
    "volume_low": ("below", 1.0, True),
    "volume_high": ("above", 1.0, True),
    "joints_inside": ("below", 1.0, False),  # a kept studio rig may hold controls outside the body
    "zero_length_bone_share": ("above", 0.0, False),  # artists' own rigs leave some
}


def _fixed() -> dict[str, Threshold]:
    return {
        "unweighted_vertices": Threshold("above", 0, 0),
        "non_finite_weights": Threshold("above", 0, 0),
        "max_row_sum_error": Threshold("above", ROW_SUM_TOLERANCE, ROW_SUM_TOLERANCE),
        "refine_non_finite_vertices": Threshold("above", 0, 0),
        "refine_tear_radii": Threshold("above", TEAR_RADII, None),
        "refine_det_f_clamped_share": Threshold("above", 0, None),
        "refine_volume_added": Threshold("above", REFINE_VOLUME_ADDED, REFINE_VOLUME_ADDED),
        "refine_offset_heights": Threshold("above", REFINE_OFFSET_WARN, REFINE_OFFSET_FAIL),
    }


def envelope_threshold(name: str, worst: float) -> Threshold:
    """The Threshold of calibrated figure `name` whose artist envelope is `worst`."""
    bad, rest, can_fail = CALIBRATED[name]
    fail = rest + FAIL_FACTOR * (worst - rest) if can_fail else None
    return Threshold(bad, worst, fail)


def derive(calibration: dict[str, Any]) -> dict[str, Any]:
    """thresholds.json content from a GateCalibration.to_dict(): every calibrated figure's envelope, the
    rig or clip that sets it, and the Threshold it gives."""
    samples: dict[str, list[tuple[float, str]]] = {name: [] for name in CALIBRATED}
    for rig in calibration["rigs"]:
        samples["joints_inside"].append((rig["joints_inside"], rig["name"]))
        samples["zero_length_bone_share"].append((rig["zero_length_bone_share"], rig["name"]))
    for clip in calibration["clips"]:
        where = f"{clip['name']}/{clip['clip']}"
        for key in ("stretch_low", "stretch_high", "volume_low", "volume_high"):
            if clip[key] is not None:
                samples[key].append((clip[key], where))
    out: dict[str, Any] = {}
    for name, values in samples.items():
        pick = min if CALIBRATED[name][0] == "below" else max
        worst, source = pick(values)
        t = envelope_threshold(name, worst)
        out[name] = {"bad": t.bad, "warn": t.warn, "fail": t.fail, "set_by": source, "samples": len(values)}
    return {"rule": " ".join(__doc__.split("\n\n")[1].split()), "fail_factor": FAIL_FACTOR, "figures": out}


@lru_cache(maxsize=1)
def thresholds() -> dict[str, Threshold]:
    """Every gate figure's Threshold: the calibrated ones from thresholds.json, then the invariants."""
    data = json.loads(THRESHOLDS_PATH.read_text())["figures"]
    out = {name: Threshold(v["bad"], v["warn"], v["fail"]) for name, v in data.items()}
    out.update(_fixed())
    return out

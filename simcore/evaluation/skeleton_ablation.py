"""`rigforge eval skeleton DIR --ablate`: the geometric method with each special-case rule turned off in turn.

Every file goes through the job's path (`skeleton_eval.load_case`, `job_prediction` with method geometric), once
with every rule on, once with each rule of `simcore.skeleton.geometric_rules.RULES` off, and once with all of
them off (`thinning`). A rule earns its place when turning it off makes the mean J2J or B2B worse.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from simcore.evaluation.assets import asset_files, problem
from simcore.evaluation.skeleton_eval import job_prediction, load_case, scores_of
from simcore.skeleton.geometric import GeometricParams
from simcore.skeleton.geometric_rules import RULES, plain_params, without_rule

ALL_ON = "all rules"
ALL_OFF = "thinning (all off)"


def variants() -> dict[str, GeometricParams]:
    """Label → geometric parameters: every rule on, each rule off ("-name"), every rule off."""
    out = {ALL_ON: GeometricParams()}
    out.update({f"-{name}": without_rule(name) for name in RULES})
    out[ALL_OFF] = plain_params()
    return out


@dataclass
class Ablation:
    """(J2J, B2B) per variant label per asset, and the files that could not be evaluated (name → reason)."""

    scores: dict[str, dict[str, tuple[float, float]]] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)

    def table(self) -> list[dict]:
        """One row per variant: mean J2J and B2B over the assets every variant scored, their change from all rules
        on, and on how many assets turning the rule off made J2J worse / better (a 1e-4 band counts as equal)."""
        assets = [a for a in self.scores[ALL_ON] if all(a in v for v in self.scores.values())] if self.scores else []
        base = np.array([self.scores[ALL_ON][a] for a in assets]).reshape(-1, 2)
        rows = []
        for label, by_asset in self.scores.items():
            values = np.array([by_asset[a] for a in assets]).reshape(-1, 2)
            mean = values.mean(axis=0) if len(values) else np.full(2, np.nan)
            change = values[:, 0] - base[:, 0]
            rule = label.lstrip("-")
            rows.append({"variant": label, "rule": RULES[rule][0] if rule in RULES else "", "assets": len(assets),
                         "j2j": round(float(mean[0]), 5), "b2b": round(float(mean[1]), 5),
                         "d_j2j": round(float(mean[0] - base[:, 0].mean()), 5) if len(assets) else None,
                         "d_b2b": round(float(mean[1] - base[:, 1].mean()), 5) if len(assets) else None,
                         "worse": int(np.count_nonzero(change > 1e-4)), "better": int(np.count_nonzero(change < -1e-4))})
        return rows

    def to_dict(self) -> dict:
        return {"table": self.table(), "per_asset": {k: {a: list(v) for a, v in d.items()} for k, d in self.scores.items()},
                "skipped": self.skipped}


def ablate_directory(directory: Path, *, max_joints: int = 64, split: str | None = None,
                     on_asset: Callable[[str], None] | None = None) -> Ablation:
    """Run every variant of `variants()` on each rigged file of `directory` (or of its MANIFEST `split`)."""
    out = Ablation()
    params = variants()
    for path in asset_files(directory, split):
        if on_asset is not None:
            on_asset(path.stem)
        try:
            case = load_case(path)
            for label, variant in params.items():
                scores = scores_of(case, job_prediction(case, "geometric", max_joints, variant).skeleton)
                out.scores.setdefault(label, {})[path.stem] = (scores.j2j, scores.b2b)
        except Exception as exc:  # one bad file is listed, the others still run
            out.skipped[path.stem] = problem(exc)
            for by_asset in out.scores.values():
                by_asset.pop(path.stem, None)
    return out

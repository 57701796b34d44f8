"""`auto`: pick one skeleton among the candidates of every method by the quality score (no ground truth)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.skeleton.candidate_score import CandidateScore, ShapeContext, score_candidate
from simcore.skeleton.candidates import Candidate


@dataclass
class Selection:
    """The chosen candidate, every candidate's score (same order as the candidates) and why it won."""

    chosen: Candidate
    scores: list[CandidateScore]
    reason: str

    def report(self, candidates: list[Candidate]) -> dict:
        """JSON-ready: the chosen method, the reason, and each candidate's method, joints and score terms."""
        return {
            "chosen": self.chosen.method,
            "reason": self.reason,
            "candidates": [{"method": c.method, "joints": c.skeleton.num_joints, "seconds": round(c.seconds, 3),
                            **({"class": c.report["class"]} if "class" in c.report else {}), **s.to_dict()}
                           for c, s in zip(candidates, self.scores)],
        }


def _best_per_method(candidates: list[Candidate], scores: list[CandidateScore]) -> dict[str, tuple[int, float]]:
    """method → (index, total) of its best-scoring candidate, in the candidates' method order."""
    best: dict[str, tuple[int, float]] = {}
    for k, (c, s) in enumerate(zip(candidates, scores)):
        if c.method not in best or s.total > best[c.method][1]:
            best[c.method] = (k, s.total)
    return best


def select_candidate(candidates: list[Candidate], shape: ShapeContext) -> Selection:
    """The candidate with the highest quality score (the first on ties: callers list their preferred method first)."""
    if not candidates:
        raise ValueError("no skeleton candidates to select from")
    scores = [score_candidate(c.skeleton, shape) for c in candidates]
    chosen = int(np.argmax([s.total for s in scores]))
    best = _best_per_method(candidates, scores)
    winner, terms = candidates[chosen], scores[chosen]
    others = ", ".join(f"{m} {total:.3f}" for m, (k, total) in best.items() if k != chosen)
    reason = (f"{winner.method} scored {terms.total:.3f} (inside {terms.inside:.2f}, reach {terms.reach:.3f}, "
              f"medial gap {terms.medial_gap:.3f}, off medial {terms.off_medial:.3f}, asymmetry {terms.asymmetry:.3f}, "
              f"stacked {terms.stacked:.2f})" + (f" ahead of {others}" if others else ""))
    return Selection(winner, scores, reason)

"""`auto`: pick one skeleton among the candidates of every method by the quality score (no ground truth).

Candidates come in order of preference (the humanoid template, then the geometric method): the first
whose score is within MARGIN of the best one wins. On corpus `train` the score's small differences picked worse
skeletons as often as better ones; a clear gap (a candidate with joints outside the body, stacked joints, bones
across the body or a lopsided tree on a symmetric mesh) is what it reliably sees.
Finger joints (`JointKind.HAND`) are left out of the score here: a finger's bones are shorter than the solid the
score reads (`stacked` would count them as joints in one place), and only the humanoid candidate has them, so they
would weigh a detail against whole methods. (The learned method's best-of-N keeps them: its samples differ in
their hands too.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from simcore.skeleton.candidate_score import CandidateScore, ShapeContext, score_candidate
from simcore.skeleton.candidates import Candidate
from simcore.skeleton.types import JointKind, Skeleton

MARGIN = 0.1  # of the quality score: a preferred candidate this close to the best one is kept


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


def without_fingers(skeleton: Skeleton) -> Skeleton:
    """The skeleton without its finger joints (JointKind.HAND), or itself when it has none."""
    fingers = np.array([kind == JointKind.HAND for kind in skeleton.kinds], dtype=bool)
    return skeleton.without(fingers)[0] if fingers.any() and not fingers[0] else skeleton


def _best_per_method(candidates: list[Candidate], scores: list[CandidateScore]) -> dict[str, tuple[int, float]]:
    """method → (index, total) of its best-scoring candidate, in the candidates' method order."""
    best: dict[str, tuple[int, float]] = {}
    for k, (c, s) in enumerate(zip(candidates, scores)):
        if c.method not in best or s.total > best[c.method][1]:
            best[c.method] = (k, s.total)
    return best


def select_candidate(candidates: list[Candidate], shape: ShapeContext, margin: float = MARGIN) -> Selection:
    """The first of `candidates` (listed in order of preference) whose quality score is within `margin` of the best."""
    if not candidates:
        raise ValueError("no skeleton candidates to select from")
    scores = [score_candidate(without_fingers(c.skeleton), shape) for c in candidates]
    top = max(s.total for s in scores)
    chosen = next(k for k, s in enumerate(scores) if s.total >= top - margin)
    best = _best_per_method(candidates, scores)
    winner, terms = candidates[chosen], scores[chosen]
    others = ", ".join(f"{m} {total:.3f}" for m, (k, total) in best.items() if k != chosen)
    how = "the best score" if terms.total >= top else f"within {margin} of the best, and preferred"
    reason = (f"{winner.method}: {how}, {terms.total:.3f} (inside {terms.inside:.2f}, medial gap {terms.medial_gap:.3f}, "
              f"off medial {terms.off_medial:.3f}, asymmetry {terms.asymmetry:.3f}, stacked {terms.stacked:.2f})"
              + (f"; others {others}" if others else ""))
    return Selection(winner, scores, reason)

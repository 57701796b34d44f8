"""Several skinning models read as one: the mean of their logits, so the softmax gives a normalised product of experts.

The members are trained on different groups of the corpus's source families (simcore/training/skin_ensemble.py).
A convention one member learned from its families and that does not carry to a new character is outvoted by the
members that never saw it: averaging models whose errors differ lowers the variance that a few dozen families
leave in any single model. A weights file stores the members' state dicts under "members.<k>." and their count in
its "model" metadata; a file of one plain model (what `rigforge train skin` writes) reads as an ensemble of one.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import torch
from torch import nn

from simcore.skinning.attention_model import ModelConfig, SkinAttention


@dataclass(frozen=True)
class EnsembleConfig:
    """The members' network sizes and how many there are (stored beside the weights)."""

    member: ModelConfig
    members: int

    def to_dict(self) -> dict[str, float]:
        return {**self.member.to_dict(), "members": self.members}


class SkinEnsemble(nn.Module):
    """Members of one network size whose logits are averaged; `bones` and `logits` read as SkinAttention's do."""

    def __init__(self, members: list[SkinAttention]):
        super().__init__()
        if not members or len({m.config for m in members}) != 1:
            raise ValueError("an ensemble needs at least one member, all of one network size")
        self.members = nn.ModuleList(members)
        self.config = EnsembleConfig(members[0].config, len(members))

    @classmethod
    def of_size(cls, sizes: dict) -> SkinEnsemble | SkinAttention:
        """An untrained network for a weights file's "model" metadata: an ensemble when it counts members, else
        one plain model."""
        count = int(sizes.get("members", 0))
        config = ModelConfig(**{k: v for k, v in sizes.items() if k != "members"})
        return cls([SkinAttention(config) for _ in range(count)]) if count else SkinAttention(config)

    def networks(self) -> list[SkinAttention]:
        """The members, typed."""
        return [cast(SkinAttention, member) for member in self.members]

    def leading(self, count: int) -> SkinEnsemble:
        """The first `count` members (at least one) as an ensemble sharing their weights."""
        return self if count >= len(self.members) else SkinEnsemble(self.networks()[:max(count, 1)]).eval()

    def bones(self, bone: torch.Tensor) -> list[torch.Tensor]:
        """(J, B) → each member's (J, width) bone embeddings."""
        return [member.bones(bone) for member in self.networks()]

    def logits(self, pair: torch.Tensor, bones: list[torch.Tensor], point: torch.Tensor, candidates: torch.Tensor,
               prior: torch.Tensor) -> torch.Tensor:
        """(V, K) mean of the members' logits (`bones`: this ensemble's `bones`)."""
        return torch.stack([member.logits(pair, b, point, candidates, prior)
                            for member, b in zip(self.networks(), bones)]).mean(dim=0)

    def forward(self, pair: torch.Tensor, bone: torch.Tensor, point: torch.Tensor, candidates: torch.Tensor,
                prior: torch.Tensor) -> torch.Tensor:
        return torch.softmax(self.logits(pair, self.bones(bone), point, candidates, prior), dim=-1)

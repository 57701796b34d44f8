"""The learned skinning network: bone–point cross-attention over each vertex's candidate bones (UniRig §skinning).

Bones first exchange context through a few self-attention layers (siblings, chains, the tree's extent). Each
vertex-bone pair is embedded from its pair features, the bone's embedding and the vertex's; the vertex then
attends over its candidate pairs (query: the vertex, keys and values: the pairs) and every pair's logit is
read from its embedding and that context. The geodesic method's log-weights are added to the logits with a
learned scale, and the output layer starts at zero: an untrained model reproduces geodesic voxel binding, and
training learns the residual. Softmax over the candidates gives rows that sum to 1.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import cast

import torch
from torch import nn

from simcore.skinning.pair_features import BONE_FEATURES, PAIR_FEATURES, POINT_FEATURES


@dataclass(frozen=True)
class ModelConfig:
    """Network sizes (stored beside the weights)."""

    width: int = 64
    heads: int = 4
    bone_layers: int = 2
    dropout: float = 0.0  # training only: on the bone context, the pair embeddings and the output layer's input

    def to_dict(self) -> dict[str, float]:
        return asdict(self)


def _mlp(inputs: int, width: int, outputs: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(inputs, width), nn.GELU(), nn.Linear(width, outputs))


class SkinAttention(nn.Module):
    """(pair (V, K, P), bone (J, B), point (V, Q), candidates (V, K), prior (V, K)) → (V, K) weights (softmax)."""

    def __init__(self, config: ModelConfig = ModelConfig()):
        super().__init__()
        w = config.width
        self.config = config
        self.bone_in = nn.Linear(BONE_FEATURES, w)
        layer = nn.TransformerEncoderLayer(w, config.heads, dim_feedforward=2 * w, dropout=config.dropout, batch_first=True, norm_first=True)
        self.bone_context = nn.TransformerEncoder(layer, config.bone_layers, enable_nested_tensor=False)
        self.point_in = _mlp(POINT_FEATURES, w, w)
        self.pair_in = _mlp(PAIR_FEATURES + 2 * w, w, w)
        self.cross = nn.MultiheadAttention(w, config.heads, batch_first=True)
        self.norm = nn.LayerNorm(w)
        head = nn.Linear(w, 1)  # zero at the start: the logits are the geodesic prior's
        nn.init.zeros_(head.weight)
        nn.init.zeros_(head.bias)
        self.out = nn.Sequential(nn.Linear(2 * w, w), nn.GELU(), head)
        self.prior_scale = nn.Parameter(torch.ones(()))

    def bones(self, bone: torch.Tensor) -> torch.Tensor:
        """(J, B) → (J, width) bone embeddings with tree context."""
        return self.bone_context(self.bone_in(bone)[None])[0]

    def logits(self, pair: torch.Tensor, bones: torch.Tensor, point: torch.Tensor, candidates: torch.Tensor,
               prior: torch.Tensor, valid: torch.Tensor | None = None) -> torch.Tensor:
        """(V, K) logits for a chunk of vertices given the bone embeddings of the whole skeleton. valid (V, K) bool
        marks real candidates when rows of different skeletons are padded to one K (training batches): padding
        gets no attention and a -inf logit."""
        p = self.point_in(point)  # (V, w)
        # The first layers read concatenations [pair, bone, point] and [pair, context]: their weights are split so
        # bone and point terms are computed once per bone and per vertex, not once per pair (same result, less work).
        w = self.config.width
        first = cast(nn.Linear, self.pair_in[0])
        wp, wb, wq = first.weight.split([PAIR_FEATURES, w, w], dim=1)
        pre = pair @ wp.T + (bones @ wb.T)[candidates] + (p @ wq.T + first.bias)[:, None, :]
        h = self._drop(self.pair_in[1:](pre))  # (V, K, w)
        context = self._attend(p, h, valid)[:, None, :]  # (V, 1, w)
        z = self._drop(self.norm(h + context))
        top = cast(nn.Linear, self.out[0])
        wz, wc = top.weight.split([w, w], dim=1)
        out = self.out[1:](z @ wz.T + (context @ wc.T + top.bias))[..., 0] + self.prior_scale * prior
        return out if valid is None else out.masked_fill(~valid, float("-inf"))

    def _drop(self, x: torch.Tensor) -> torch.Tensor:
        return nn.functional.dropout(x, self.config.dropout, self.training)

    def _attend(self, query: torch.Tensor, pairs: torch.Tensor, valid: torch.Tensor | None = None) -> torch.Tensor:
        """`self.cross` for one query per vertex over its K pairs: (V, w), (V, K, w) → (V, w).

        The key and value projections are moved off the pairs: q·(Wk h) = (Wkᵀ q)·h, and since the attention
        weights sum to 1, Σ a (Wv h + bv) = Wv (Σ a h) + bv. Same result as nn.MultiheadAttention, without its two
        (V·K, w) × (w, w) products. The key bias shifts every score of a head equally and cancels in the softmax.
        """
        heads, w = self.config.heads, self.config.width
        d = w // heads
        wq, wk, wv = self.cross.in_proj_weight.split(w)
        bq, _, bv = self.cross.in_proj_bias.split(w)
        q = (query @ wq.T + bq).view(-1, heads, d)  # (V, H, d)
        u = torch.einsum("vhd,hdw->vhw", q, wk.view(heads, d, w)) / d**0.5  # (V, H, w)
        scores = torch.einsum("vhw,vkw->vhk", u, pairs)
        if valid is not None:
            scores = scores.masked_fill(~valid[:, None, :], float("-inf"))
        attn = torch.softmax(scores, dim=-1)
        mixed = torch.einsum("vhk,vkw->vhw", attn, pairs)  # (V, H, w)
        values = torch.einsum("vhw,hdw->vhd", mixed, wv.view(heads, d, w)).reshape(-1, w) + bv
        return cast(torch.Tensor, self.cross.out_proj(values))

    def forward(self, pair: torch.Tensor, bone: torch.Tensor, point: torch.Tensor, candidates: torch.Tensor,
                prior: torch.Tensor) -> torch.Tensor:
        return torch.softmax(self.logits(pair, self.bones(bone), point, candidates, prior), dim=-1)

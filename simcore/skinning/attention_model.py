"""The learned skinning network: bone–point cross-attention over each vertex's candidate bones (UniRig §skinning).

Bones first exchange context through a few self-attention layers (siblings, chains, the tree's extent). Each
vertex-bone pair is embedded from its pair features, the bone's embedding and the vertex's; the vertex then
attends over its candidate pairs (query: the vertex, keys and values: the pairs) and every pair's logit is
read from its embedding and that context. The geodesic method's log-weights are added to the logits with a
learned scale, and the output layer starts at zero: an untrained model reproduces geodesic voxel binding, and
training learns the residual. Softmax over the candidates gives rows that sum to 1.

Shape context (`tokens` > 0): a vertex alone sees only its own position, normal and candidate bones. A set of
shape tokens, the mesh's farthest-point samples (so their spread does not depend on vertex density), each
embedded from its point features and its nearest bone, exchange context in one self-attention layer; every
vertex then attends to them with a per-head distance penalty (heads start local at different radii) and reads
their mixed embeddings and their mean offset from it. That context joins the vertex's embedding before the
pairs are formed. Its output projection starts at zero, so an untrained model is still the geodesic prior.
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
    tokens: int = 0  # shape tokens per mesh (0: no shape context, every vertex on its own)
    dropout: float = 0.0  # in the bone, pair and output layers while training

    def to_dict(self) -> dict[str, int | float]:
        return asdict(self)


def _mlp(inputs: int, width: int, outputs: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(inputs, width), nn.GELU(), nn.Linear(width, outputs))


def farthest_points(positions: torch.Tensor, count: int, start: int | None = None) -> torch.Tensor:
    """(min(count, N),) int64 indices of farthest-point samples of (N, 3) positions, from `start` (default: the
    point farthest from the centroid, which does not depend on vertex order)."""
    n = len(positions)
    if start is None:
        start = int(torch.argmax((positions - positions.mean(dim=0)).square().sum(dim=1)))
    chosen = torch.empty(min(count, n), dtype=torch.int64)
    nearest = torch.full((n,), float("inf"))
    current = start
    for k in range(len(chosen)):
        chosen[k] = current
        nearest = torch.minimum(nearest, (positions - positions[current]).square().sum(dim=1))
        current = int(torch.argmax(nearest))
    return chosen


@dataclass
class ShapeTokens:
    """Token embeddings (T, width) and positions (T, 3) of one mesh, computed once and shared by its chunks."""

    embedding: torch.Tensor
    positions: torch.Tensor


class SkinAttention(nn.Module):
    """(pair (V, K, P), bone (J, B), point (V, Q), candidates (V, K), prior (V, K)) → (V, K) weights (softmax)."""

    def __init__(self, config: ModelConfig = ModelConfig()):
        super().__init__()
        w = config.width
        self.config = config
        self.bone_in = nn.Linear(BONE_FEATURES, w)
        layer = nn.TransformerEncoderLayer(w, config.heads, dim_feedforward=2 * w, dropout=config.dropout, batch_first=True,
                                           norm_first=True)
        self.bone_context = nn.TransformerEncoder(layer, config.bone_layers, enable_nested_tensor=False)
        self.point_in = _mlp(POINT_FEATURES, w, w)
        self.pair_in = _mlp(PAIR_FEATURES + 2 * w, w, w)
        if config.tokens:
            self.token_in = _mlp(POINT_FEATURES, w, w)
            self.token_bone = nn.Linear(w, w, bias=False)
            self.token_context = nn.TransformerEncoder(
                nn.TransformerEncoderLayer(w, config.heads, dim_feedforward=2 * w, dropout=config.dropout, batch_first=True,
                                           norm_first=True), 1, enable_nested_tensor=False)
            self.shape_query = nn.Linear(w, w)
            self.shape_key = nn.Linear(w, w, bias=False)
            self.shape_value = nn.Linear(w, w)
            # squared-distance penalty per head, in unit-cube units: heads look from about 0.05 to 0.4 of the mesh
            radii = torch.logspace(-1.3, -0.4, config.heads)
            self.shape_reach = nn.Parameter(torch.log(1.0 / radii**2))
            self.shape_out = nn.Linear(config.heads * (w // config.heads + 3), w)
            nn.init.zeros_(self.shape_out.weight)  # no shape context at the start: the untrained model is the prior
            nn.init.zeros_(self.shape_out.bias)
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

    def shape(self, point: torch.Tensor, nearest: torch.Tensor, bones: torch.Tensor,
              index: torch.Tensor | None = None) -> ShapeTokens | None:
        """The mesh's shape tokens from its vertices' point features (N, Q) and nearest joints (N,); `index` picks
        the token vertices (default: farthest-point samples). None when the network has no shape context."""
        if not self.config.tokens:
            return None
        if index is None:
            index = farthest_points(point[:, :3], self.config.tokens)
        t = self.token_in(point[index]) + self.token_bone(bones[nearest[index]])
        return ShapeTokens(self.token_context(t[None])[0], point[index, :3])

    def _shape_context(self, p: torch.Tensor, position: torch.Tensor, tokens: ShapeTokens) -> torch.Tensor:
        """(V, w) what each vertex reads from the shape tokens: their mixed values and mean offset, per head."""
        heads, w = self.config.heads, self.config.width
        d = w // heads
        q = self.shape_query(p).view(-1, heads, d)  # (V, H, d)
        k = self.shape_key(tokens.embedding).view(-1, heads, d)  # (T, H, d)
        v = self.shape_value(tokens.embedding).view(-1, heads, d)
        distance = torch.cdist(position, tokens.positions).square()  # (V, T)
        score = torch.einsum("vhd,thd->vht", q, k) / d**0.5 - torch.exp(self.shape_reach)[None, :, None] * distance[:, None, :]
        attn = torch.softmax(score, dim=-1)  # (V, H, T)
        mixed = torch.einsum("vht,thd->vhd", attn, v)
        offset = torch.einsum("vht,tc->vhc", attn, tokens.positions) - position[:, None, :]  # (V, H, 3)
        return cast(torch.Tensor, self.shape_out(torch.cat([mixed, offset], dim=-1).reshape(len(p), -1)))

    def logits(self, pair: torch.Tensor, bones: torch.Tensor, point: torch.Tensor, candidates: torch.Tensor,
               prior: torch.Tensor, tokens: ShapeTokens | None = None) -> torch.Tensor:
        """(V, K) logits for a chunk of vertices given the bone embeddings of the whole skeleton (and the mesh's
        shape tokens when the network has them)."""
        p = self.point_in(point)  # (V, w)
        if tokens is not None:
            p = p + self._shape_context(p, point[:, :3], tokens)
        # The first layers read concatenations [pair, bone, point] and [pair, context]: their weights are split so
        # bone and point terms are computed once per bone and per vertex, not once per pair (same result, less work).
        w = self.config.width
        first = cast(nn.Linear, self.pair_in[0])
        wp, wb, wq = first.weight.split([PAIR_FEATURES, w, w], dim=1)
        pre = pair @ wp.T + (bones @ wb.T)[candidates] + (p @ wq.T + first.bias)[:, None, :]
        h = self.pair_in[2](self._drop(self.pair_in[1](pre)))  # (V, K, w)
        context = self._attend(p, h)[:, None, :]  # (V, 1, w)
        z = self.norm(h + context)
        top = cast(nn.Linear, self.out[0])
        wz, wc = top.weight.split([w, w], dim=1)
        hidden = self._drop(self.out[1](z @ wz.T + (context @ wc.T + top.bias)))
        return self.out[2](hidden)[..., 0] + self.prior_scale * prior

    def _drop(self, x: torch.Tensor) -> torch.Tensor:
        """Dropout while training (functional: the layer lists, and so the weight files' keys, stay as they were)."""
        return nn.functional.dropout(x, self.config.dropout, self.training) if self.config.dropout else x

    def _attend(self, query: torch.Tensor, pairs: torch.Tensor) -> torch.Tensor:
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
        attn = torch.softmax(torch.einsum("vhw,vkw->vhk", u, pairs), dim=-1)
        mixed = torch.einsum("vhk,vkw->vhw", attn, pairs)  # (V, H, w)
        values = torch.einsum("vhw,hdw->vhd", mixed, wv.view(heads, d, w)).reshape(-1, w) + bv
        return cast(torch.Tensor, self.cross.out_proj(values))

    def forward(self, pair: torch.Tensor, bone: torch.Tensor, point: torch.Tensor, candidates: torch.Tensor,
                prior: torch.Tensor) -> torch.Tensor:
        """(V, K) weights of a whole mesh's vertices (shape tokens drawn from these same vertices)."""
        bones = self.bones(bone)
        tokens = self.shape(point, candidates[:, 0], bones)
        return torch.softmax(self.logits(pair, bones, point, candidates, prior, tokens), dim=-1)

"""The learned skeleton model: a point-query shape encoder and a decoder-only transformer over skeleton tokens.

Shape encoder (3DShape2VecSet-style): `queries` of the input points, embedded with Fourier features of their
position and their normal, cross-attend to all points, then `encoder_layers` self-attention blocks; the result
is a prefix of conditioning vectors. Decoder (UniRig's "Skeleton Tree GPT", small): causal self-attention over
[prefix, <bos>, <cls>, tokens...]. Each token's input is its embedding, a Fourier embedding of its coordinate
value (coordinate tokens only, so neighbouring bins start out alike), its position, and the *slot* of the token
it must predict (which axis of which joint, or a template joint: read off the grammar, see `next_slot`).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from simcore.skeleton.grammar import BODY_COORDS, HAND_COORDS, GrammarState, SkeletonGrammar
from simcore.skeleton.mixamo import BODY_JOINTS, HAND_JOINTS
from simcore.skeleton.vocab import NUM_BINS, VOCAB_SIZE, dequantize

BOUNDARY, BRANCH_CHILD_X, BRANCH_PARENT_X, TEMPLATE = 0, 3, 4, 7
NUM_SLOTS = TEMPLATE + 3 * (len(BODY_JOINTS) + len(HAND_JOINTS))


def next_slot(state: GrammarState) -> int:
    """What the token after `state` is: 0 a boundary (a special token or a free joint's x), 1/2 a joint's y/z,
    3 a branch joint's x, 4-6 a branch's parent x/y/z, 7 + 3k + axis template joint k's coordinate."""
    if state.phase != "coords":
        return BOUNDARY
    left = state.coords_left
    axis = (-left) % 3  # every unit's coordinates end on z
    if state.section in ("body", "hand"):
        done = (BODY_COORDS if state.section == "body" else HAND_COORDS) - left
        joint = done // 3 + (len(BODY_JOINTS) if state.section == "hand" else 0)
        return TEMPLATE + 3 * joint + axis
    if left > 3:
        return BRANCH_PARENT_X + axis
    return BRANCH_CHILD_X if left == 3 else axis


# Axis (0 x, 1 y, 2 z) of the coordinate a slot asks for; a boundary slot's coordinate is a free joint's x.
SLOT_AXES = np.array([0, 1, 2, 0, 0, 1, 2] + [k % 3 for k in range(NUM_SLOTS - TEMPLATE)], dtype=np.int64)


def sequence_slots(tokens: np.ndarray, grammar: SkeletonGrammar) -> np.ndarray:
    """(L,) int64: for each position t, the slot of token t + 1 (the last entry, after <eos>, is 0)."""
    out = np.zeros(len(tokens), dtype=np.int64)
    state = grammar.initial()
    for t, token in enumerate(tokens):
        state = grammar.advance(state, int(token))
        out[t] = next_slot(state)
    return out


@dataclass(frozen=True)
class SkeletonModelConfig:
    """Network sizes (stored in the weights file's metadata)."""

    width: int = 128
    heads: int = 4
    encoder_layers: int = 2
    decoder_layers: int = 4
    queries: int = 128  # input points that become the conditioning prefix
    max_tokens: int = 512  # context length of the token sequence, <bos> and <eos> included
    frequencies: int = 8  # Fourier octaves of point positions and coordinate values
    dropout: float = 0.0  # residual dropout in every block while training (inference runs without)

    def to_dict(self) -> dict:
        return asdict(self)


def fourier(x: torch.Tensor, octaves: int) -> torch.Tensor:
    """(..., C) values in [-1, 1] → (..., C * 2 * octaves) sin/cos features at π·2^k."""
    scaled = x[..., None] * (math.pi * 2.0 ** torch.arange(octaves, dtype=x.dtype, device=x.device))
    return torch.cat([scaled.sin(), scaled.cos()], dim=-1).flatten(-2)


class Attention(nn.Module):
    """Multi-head attention; with a cache dict, keys and values of earlier positions are kept and reused."""

    def __init__(self, width: int, heads: int) -> None:
        super().__init__()
        self.heads = heads
        self.q = nn.Linear(width, width)
        self.kv = nn.Linear(width, 2 * width)
        self.out = nn.Linear(width, width)

    def _split(self, x: torch.Tensor) -> torch.Tensor:
        b, n, w = x.shape
        return x.view(b, n, self.heads, w // self.heads).transpose(1, 2)

    def forward(self, x: torch.Tensor, context: torch.Tensor, causal: bool = False, cache: dict | None = None) -> torch.Tensor:
        q = self._split(self.q(x))
        k, v = (self._split(t) for t in self.kv(context).chunk(2, dim=-1))
        if cache is not None:
            if "k" in cache:  # one new position attends to every earlier one: no mask needed
                k, v = torch.cat([cache["k"], k], dim=2), torch.cat([cache["v"], v], dim=2)
                causal = False
            cache["k"], cache["v"] = k, v
        y = F.scaled_dot_product_attention(q, k, v, is_causal=causal)
        return self.out(y.transpose(1, 2).flatten(2))


class Block(nn.Module):
    """Pre-norm transformer block: attention (self, or to a context) then an MLP."""

    def __init__(self, width: int, heads: int, dropout: float = 0.0) -> None:
        super().__init__()
        self.norm1, self.norm2 = nn.LayerNorm(width), nn.LayerNorm(width)
        self.attn = Attention(width, heads)
        self.mlp = nn.Sequential(nn.Linear(width, 4 * width), nn.GELU(), nn.Linear(4 * width, width))
        self.drop = nn.Dropout(dropout)

    def forward(self, x: torch.Tensor, context: torch.Tensor | None = None, causal: bool = False,
                cache: dict | None = None) -> torch.Tensor:
        h = self.norm1(x)
        x = x + self.drop(self.attn(h, h if context is None else context, causal=causal, cache=cache))
        return x + self.drop(self.mlp(self.norm2(x)))


class ShapeEncoder(nn.Module):
    """(B, N, 6) model-frame points and normals → (B, queries, width) conditioning vectors."""

    def __init__(self, config: SkeletonModelConfig) -> None:
        super().__init__()
        self.config = config
        self.embed = nn.Linear(6 + 6 * config.frequencies, config.width)
        self.cross = Block(config.width, config.heads, config.dropout)
        self.layers = nn.ModuleList(Block(config.width, config.heads, config.dropout) for _ in range(config.encoder_layers))

    def forward(self, points: torch.Tensor) -> torch.Tensor:
        features = self.embed(torch.cat([points, fourier(points[..., :3], self.config.frequencies)], dim=-1))
        x = self.cross(features[:, : self.config.queries], context=features)  # the first points are a random subset
        for layer in self.layers:
            x = layer(x)
        return x


class SkeletonTokenModel(nn.Module):
    """Shape encoder + causal decoder; `forward` gives next-token logits (B, L, 267) for teacher forcing."""

    bin_values: torch.Tensor  # (NUM_BINS,) coordinate of each bin, a buffer

    def __init__(self, config: SkeletonModelConfig) -> None:
        super().__init__()
        self.config = config
        w = config.width
        self.encoder = ShapeEncoder(config)
        self.tokens = nn.Embedding(VOCAB_SIZE, w)
        self.values = nn.Linear(2 * config.frequencies, w)
        self.slots = nn.Embedding(NUM_SLOTS, w)
        self.positions = nn.Embedding(config.max_tokens, w)
        self.layers = nn.ModuleList(Block(w, config.heads, config.dropout) for _ in range(config.decoder_layers))
        self.norm = nn.LayerNorm(w)
        self.head = nn.Linear(w, VOCAB_SIZE)
        self.register_buffer("bin_values", torch.from_numpy(dequantize(np.arange(NUM_BINS))).to(torch.float32), persistent=False)

    def embed(self, tokens: torch.Tensor, slots: torch.Tensor, start: int) -> torch.Tensor:
        """(B, T) tokens and next-token slots at positions start.. → (B, T, width) decoder inputs."""
        is_coord = tokens < NUM_BINS
        value = self.bin_values[tokens.clamp(max=NUM_BINS - 1)]
        coord = self.values(fourier(value[..., None], self.config.frequencies)) * is_coord[..., None]
        pos = torch.arange(start, start + tokens.shape[1], device=tokens.device)
        return self.tokens(tokens) + coord + self.slots(slots) + self.positions(pos)[None]

    def forward(self, points: torch.Tensor, tokens: torch.Tensor, slots: torch.Tensor) -> torch.Tensor:
        """points (B, N, 6), tokens (B, L) and slots (B, L) int64 → logits (B, L, 267) for tokens 1..L."""
        prefix = self.encoder(points)
        x = torch.cat([prefix, self.embed(tokens, slots, 0)], dim=1)
        for layer in self.layers:
            x = layer(x, causal=True)
        return self.head(self.norm(x[:, prefix.shape[1]:]))

    def start(self, points: torch.Tensor, tokens: torch.Tensor, slots: torch.Tensor) -> tuple[torch.Tensor, list[dict]]:
        """Begin cached decoding: logits (B, 267) after the prompt `tokens` (B, T), and the per-layer caches."""
        caches: list[dict] = [{} for _ in self.layers]
        prefix = self.encoder(points)
        x = torch.cat([prefix, self.embed(tokens, slots, 0)], dim=1)
        for layer, cache in zip(self.layers, caches):
            x = layer(x, causal=True, cache=cache)
        return self.head(self.norm(x[:, -1])), caches

    def step(self, tokens: torch.Tensor, slots: torch.Tensor, position: int, caches: list[dict]) -> torch.Tensor:
        """Logits (B, 267) after one more token (B,) at sequence `position`, updating `caches`."""
        x = self.embed(tokens[:, None], slots[:, None], position)
        for layer, cache in zip(self.layers, caches):
            x = layer(x, cache=cache)
        return self.head(self.norm(x[:, -1]))

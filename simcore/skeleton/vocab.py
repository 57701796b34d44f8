"""The 267-token skeleton vocabulary of UniRig's released tokenizer, and coordinate quantisation.

Ids 0..255 are coordinate bins over [-1, 1]; the special ids follow in the released order
(`<branch> <bos> <eos> <pad> <spring>`, the part tokens, `<cls:none>`, the class tokens), so a model
trained on these ids can share UniRig's embedding layout.
"""

from __future__ import annotations

import numpy as np

NUM_BINS = 256
BRANCH = 256
BOS = 257
EOS = 258
PAD = 259
SPRING = 260
PART_BODY = 261  # Mixamo body: 22 joints in mixamo.BODY_JOINTS order
PART_HAND = 262  # Mixamo fingers: 30 joints in mixamo.HAND_JOINTS order
CLS_NONE = 263
CLASS_TOKENS: dict[str, int] = {"none": CLS_NONE, "vroid": 264, "mixamo": 265, "articulation": 266}
VOCAB_SIZE = 267

TOKEN_NAMES: dict[int, str] = {
    BRANCH: "<branch>", BOS: "<bos>", EOS: "<eos>", PAD: "<pad>", SPRING: "<spring>",
    PART_BODY: "<part:body>", PART_HAND: "<part:hand>",
    **{tok: f"<cls:{name}>" for name, tok in CLASS_TOKENS.items()},
}


def quantize(x: np.ndarray) -> np.ndarray:
    """Bins of normalised coordinates: `clip(floor((x + 1) / 2 * 256), 0, 255)`, same shape, int64."""
    return np.clip(np.floor((np.asarray(x, dtype=np.float64) + 1.0) / 2.0 * NUM_BINS), 0, NUM_BINS - 1).astype(np.int64)


def dequantize(bins: np.ndarray) -> np.ndarray:
    """Bin centres in [-1, 1] (`(2 d + 1) / 256 - 1`), same shape, float64.

    The centre rather than the paper's left edge `2 d / 256 - 1` halves the worst-case error to half a bin.
    """
    return (2.0 * np.asarray(bins, dtype=np.float64) + 1.0) / NUM_BINS - 1.0


def token_name(token: int) -> str:
    """Readable form of one id: the bin number for coordinates, `<...>` for special tokens."""
    return str(token) if 0 <= token < NUM_BINS else TOKEN_NAMES.get(int(token), f"<unknown:{token}>")

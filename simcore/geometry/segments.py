"""Points and distances on straight segments (bones), shared by the skeleton metrics and skinning."""

from __future__ import annotations

import numpy as np


def segment_points(heads: np.ndarray, tails: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (N, 3) along every segment heads[i] → tails[i] (S, 3), ends included, at most `step` apart, and
    (N,) int64 the segment each point lies on."""
    counts = np.maximum(2, np.ceil(np.linalg.norm(tails - heads, axis=1) / step).astype(np.int64) + 1)
    segment = np.repeat(np.arange(len(counts)), counts)
    t = (np.arange(counts.sum()) - np.repeat(np.cumsum(counts) - counts, counts)) / (counts[segment] - 1)
    return heads[segment] + t[:, None] * (tails[segment] - heads[segment]), segment


def row_distances(points: np.ndarray, heads: np.ndarray, tails: np.ndarray) -> np.ndarray:
    """(N,) float64 distance from each point (N, 3) to the segment in the same row of heads/tails (N, 3)."""
    d = tails - heads
    rel = points - heads
    t = np.clip((rel * d).sum(axis=1) / np.maximum((d * d).sum(axis=1), 1e-30), 0.0, 1.0)
    return np.linalg.norm(rel - t[:, None] * d, axis=1)

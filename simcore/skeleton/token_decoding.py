"""Grammar-constrained decoding of the learned skeleton model: every finished sequence is a valid tree.

At each step the logits of tokens the grammar state machine does not allow are set to -inf before choosing, so
the model can only write sequences `SkeletonTokenizer.decode` accepts; the grammar's length and joint caps make
every sequence close with <eos> within the context.
"""

from __future__ import annotations

import numpy as np
import torch

from simcore.skeleton.grammar import GrammarState, SkeletonGrammar
from simcore.skeleton.learned_model import SkeletonTokenModel, next_slot
from simcore.skeleton.vocab import BOS, CLASS_TOKENS, PAD, VOCAB_SIZE

PAD_ONLY = np.arange(VOCAB_SIZE) == PAD  # a finished sequence's row: <pad> (ignored; it keeps the batch in step)


def decode_tokens(model: SkeletonTokenModel, points: torch.Tensor, classes: list[str], grammar: SkeletonGrammar, *,
                  temperature: float = 0.0, generator: torch.Generator | None = None) -> list[tuple[np.ndarray, float]]:
    """One sequence per entry of `classes`, decoded together for the same shape.

    points: (N, 6) float32 token-frame points and normals; temperature 0 = greedy, else sampling from
    softmax(logits / temperature). Returns (tokens (L,) int64 from <bos> to <eos>, mean log-probability per
    token under the model with the grammar mask, temperature 1) for each class, in order.
    """
    if grammar.max_length > model.config.max_tokens:
        raise ValueError(f"grammar allows {grammar.max_length} tokens, the model's context is {model.config.max_tokens}")
    count = len(classes)
    states: list[GrammarState] = [grammar.run([BOS, CLASS_TOKENS[c]]) for c in classes]
    sequences = [[BOS, CLASS_TOKENS[c]] for c in classes]
    prompt = torch.tensor(sequences, dtype=torch.int64)
    slots = torch.tensor([[next_slot(grammar.run([BOS])), next_slot(s)] for s in states], dtype=torch.int64)
    log_prob = np.zeros(count)
    with torch.no_grad():
        logits, caches = model.start(points[None].expand(count, -1, -1), prompt, slots)
        position = prompt.shape[1]
        while True:
            mask = torch.from_numpy(np.stack([grammar.allowed(s) if not s.complete else PAD_ONLY for s in states]))
            scores = torch.log_softmax(logits.masked_fill(~mask, float("-inf")), dim=-1)
            if temperature > 0:
                chosen = torch.multinomial(torch.softmax(scores / temperature, dim=-1), 1, generator=generator)[:, 0]
            else:
                chosen = scores.argmax(dim=-1)
            for b, token in enumerate(chosen.tolist()):
                if not states[b].complete:
                    log_prob[b] += float(scores[b, token])
                    states[b] = grammar.advance(states[b], token)
                    sequences[b].append(token)
            if all(s.complete for s in states):
                break
            slot = torch.tensor([next_slot(s) for s in states], dtype=torch.int64)
            logits = model.step(chosen, slot, position, caches)
            position += 1
    return [(np.asarray(s, dtype=np.int64), float(lp) / (len(s) - 2)) for s, lp in zip(sequences, log_prob)]


"""Grammar of skeleton token sequences: the set of legal next tokens after any prefix.

Used for constrained decoding (mask the logits with `allowed`) and by the tokenizer to validate what it
decodes. The language, in the terms of `simcore.skeleton.vocab`:

    <bos> <cls> [<part:body> 66 coords [<part:hand> 90 coords]] joint* (<spring> joint+)* <eos> <pad>*
    joint := x y z                      (parent = the joint written just before)
           | <branch> px py pz x y z    (parent = the earlier joint nearest to (px, py, pz))

with at least one joint, `<branch>` never before the first joint, `<spring>` only once a joint exists
(a spring chain hangs off an earlier joint), `<part:hand>` only directly after the body block (its
chains hang off the hands). Every complete sequence therefore de-tokenises to one rooted tree whose
parents precede their children. `max_length` (tokens including <bos>/<eos>) and `max_joints` are
enforced ahead of time: a token is allowed only if the sequence can still be closed within both.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

import numpy as np

from simcore.errors import InvalidInput
from simcore.skeleton.mixamo import BODY_JOINTS, HAND_JOINTS
from simcore.skeleton.vocab import (
    BOS,
    BRANCH,
    CLASS_TOKENS,
    EOS,
    NUM_BINS,
    PAD,
    PART_BODY,
    PART_HAND,
    SPRING,
    VOCAB_SIZE,
    token_name,
)

BODY_COORDS = 3 * len(BODY_JOINTS)
HAND_COORDS = 3 * len(HAND_JOINTS)
DEFAULT_MAX_LENGTH = 2048  # our choice; the learned model passes its own context length

# Tokens still needed after emitting a token until <eos> is written (included), at the cheapest.
_TAIL_AFTER = {BRANCH: 6 + 1, SPRING: 3 + 1, PART_BODY: BODY_COORDS + 1, PART_HAND: HAND_COORDS + 1, EOS: 0}
_JOINTS_ADDED = {BRANCH: 1, SPRING: 1, PART_BODY: len(BODY_JOINTS), PART_HAND: len(HAND_JOINTS), EOS: 0}


@dataclass(frozen=True)
class GrammarState:
    """Where a prefix stands; immutable so beam search can share it.

    phase: "bos" | "cls" | "open" (between joints) | "spring_open" (after <spring>) | "coords" (inside a
           joint, branch or template block) | "done" (after <eos>).
    section: what the next joint belongs to: "free" | "body" | "hand" | "spring".
    coords_left: coordinate tokens still owed by the current unit (phase "coords").
    joints: joints begun so far (a template block counts all of its joints at its marker).
    """

    length: int = 0
    phase: str = "bos"
    section: str = "free"
    coords_left: int = 0
    joints: int = 0
    has_hand: bool = False

    @property
    def complete(self) -> bool:
        """True once <eos> has been written."""
        return self.phase == "done"


class SkeletonGrammar:
    """Legal-next-token sets over the 267-token vocabulary.

    max_length: cap on the whole sequence, <bos> and <eos> included (pads may fill up to it).
    max_joints: cap on decoded joints (None = only the length cap).
    """

    def __init__(self, max_length: int = DEFAULT_MAX_LENGTH, max_joints: int | None = None) -> None:
        if max_length < 6:
            raise InvalidInput("max_length must allow <bos> <cls> x y z <eos> (6 tokens)", code="invalid_option", field="max_length")
        if max_joints is not None and max_joints < 1:
            raise InvalidInput("max_joints must be at least 1", code="invalid_option", field="max_joints")
        self.max_length = int(max_length)
        self.max_joints = max_joints

    def initial(self) -> GrammarState:
        """The state before any token."""
        return GrammarState()

    def _fits(self, state: GrammarState, tail_after: int, joints_added: int) -> bool:
        if state.length + 1 + tail_after > self.max_length:
            return False
        return self.max_joints is None or state.joints + joints_added <= self.max_joints

    def allowed(self, state: GrammarState) -> np.ndarray:
        """(267,) bool mask of the tokens that may follow `state`."""
        mask = np.zeros(VOCAB_SIZE, dtype=bool)
        phase = state.phase
        if phase == "bos":
            mask[BOS] = True
        elif phase == "cls":
            mask[list(CLASS_TOKENS.values())] = self._fits(state, 3 + 1, 1)
        elif phase == "coords":
            mask[:NUM_BINS] = True  # the unit was only opened when it could be closed in time
        elif phase == "done":
            mask[PAD] = state.length < self.max_length
        else:
            mask[:NUM_BINS] = self._fits(state, 2 + 1, 1)
            for token in self._specials_at_boundary(state):
                mask[token] = self._fits(state, _TAIL_AFTER[token], _JOINTS_ADDED[token])
        return mask

    @staticmethod
    def _specials_at_boundary(state: GrammarState) -> list[int]:
        if state.phase == "spring_open":
            return [BRANCH]
        if state.joints == 0:
            return [PART_BODY]  # the root comes first: a body block (Hips) or a plain joint
        out = [BRANCH, SPRING, EOS]
        if state.section == "body" and not state.has_hand:
            out.append(PART_HAND)
        return out

    def advance(self, state: GrammarState, token: int) -> GrammarState:
        """The state after `token`; InvalidInput(code="invalid_tokens") when it is not allowed."""
        token = int(token)
        if not (0 <= token < VOCAB_SIZE) or not self.allowed(state)[token]:
            raise InvalidInput(
                f"token {token_name(token)} is not allowed at position {state.length} (phase {state.phase})",
                code="invalid_tokens", field="tokens",
            )
        nxt = state.length + 1
        if token == BOS:
            return replace(state, length=nxt, phase="cls")
        if token in CLASS_TOKENS.values():
            return replace(state, length=nxt, phase="open")
        if token == PAD:
            return replace(state, length=nxt)
        if token == EOS:
            return replace(state, length=nxt, phase="done")
        if token == SPRING:
            return replace(state, length=nxt, phase="spring_open", section="spring")
        if token == PART_BODY:
            return replace(state, length=nxt, phase="coords", section="body", coords_left=BODY_COORDS,
                           joints=state.joints + len(BODY_JOINTS))
        if token == PART_HAND:
            return replace(state, length=nxt, phase="coords", section="hand", coords_left=HAND_COORDS,
                           joints=state.joints + len(HAND_JOINTS), has_hand=True)
        # A new joint after a template block is a free joint; inside a spring section it stays spring.
        section = "spring" if state.section == "spring" else "free"
        if token == BRANCH:
            return replace(state, length=nxt, phase="coords", section=section, coords_left=6, joints=state.joints + 1)
        if state.phase == "coords":  # a coordinate inside the current unit
            left = state.coords_left - 1
            return replace(state, length=nxt, phase="coords" if left else "open", coords_left=left)
        return replace(state, length=nxt, phase="coords", section=section, coords_left=2, joints=state.joints + 1)

    def run(self, tokens: Iterable[int], state: GrammarState | None = None) -> GrammarState:
        """Advance through every token of `tokens` (raising on the first illegal one)."""
        state = self.initial() if state is None else state
        for token in tokens:
            state = self.advance(state, token)
        return state

    def mask(self, prefix: Iterable[int]) -> np.ndarray:
        """(267,) bool legal next tokens after `prefix` (a token sequence starting with <bos>, or empty)."""
        return self.allowed(self.run(prefix))

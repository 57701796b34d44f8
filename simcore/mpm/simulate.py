"""Frame-level rollouts: forward, and differentiable with frame checkpoints.

A frame interval is a `FramePlan` (substep count, dt, per-substep grid origin and driver motion). The
differentiable rollout keeps one particle state per frame start; its backward re-runs each frame's forward
storing every substep state (values only), then walks the substeps back with `MPMSolver.backward_substep`.
Memory: (frames + substeps + 2) particle states, never a grid per substep.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import warp as wp

from simcore.mpm.solver import MPMSolver, ParticleState, SubstepInputs, Tether


@dataclass
class FramePlan:
    """One frame interval.

    dt: substep length, s; origins: (n, 3) float grid origin per substep (the grid follows the body);
    dp, dv: (n, D, 3) float32 driver positions and velocities per substep (D may be 0);
    skin: (n + 1, J, 4, 4) skinning matrices at the substep boundaries, for the tether (None: no tether).
    """

    dt: float
    origins: np.ndarray
    dp: np.ndarray
    dv: np.ndarray
    skin: np.ndarray | None = None

    @property
    def substeps(self) -> int:
        return int(len(self.origins))


class DeviceDrive:
    """A FramePlan's driver arrays on the solver's device: dp, dv (n, D) vec3 (dv optionally with gradient)."""

    def __init__(self, plan: FramePlan, device: str, requires_grad: bool = False, tether: Tether | None = None) -> None:
        self.plan = plan
        self.tether = None
        if tether is not None and plan.skin is not None:
            skin = wp.array(np.ascontiguousarray(plan.skin, np.float32).reshape(-1, 4, 4), dtype=wp.mat44, device=device)
            self.tether = dataclasses.replace(tether, skin=skin, num_joints=int(plan.skin.shape[1]))
        d = plan.dp.shape[1] if plan.dp.ndim == 3 else 0
        self.has_drivers = d > 0
        if self.has_drivers:
            self.dp = wp.array(np.ascontiguousarray(plan.dp, np.float32), dtype=wp.vec3, device=device)
            self.dv = wp.array(np.ascontiguousarray(plan.dv, np.float32), dtype=wp.vec3, device=device,
                               requires_grad=requires_grad)

    def inputs(self, k: int, mu: wp.array, lam: wp.array) -> SubstepInputs:
        o = self.plan.origins[k]
        origin = (float(o[0]), float(o[1]), float(o[2]))
        if not self.has_drivers:
            return SubstepInputs(mu, lam, origin, self.plan.dt, tether=self.tether, tether_step=k)
        return SubstepInputs(mu, lam, origin, self.plan.dt, self.dp[k], self.dv[k], tether=self.tether, tether_step=k)


def advance_frame(solver: MPMSolver, a: ParticleState, b: ParticleState, drive: DeviceDrive,
                  mu: wp.array, lam: wp.array) -> tuple[ParticleState, ParticleState]:
    """Run one frame's substeps ping-ponging a → b; returns (state holding the result, the spare state)."""
    for k in range(drive.plan.substeps):
        solver.substep(a, b, drive.inputs(k, mu, lam))
        a, b = b, a
    return a, b


class DifferentiableRollout:
    """Forward over frames with checkpoints; backward of a loss given per-frame gradients on positions.

    mu, lam: (N,) float arrays with requires_grad (their .grad accumulates); the solver must have been built
    with requires_grad=True.
    """

    def __init__(self, solver: MPMSolver, mu: wp.array, lam: wp.array, max_substeps: int) -> None:
        self.solver, self.mu, self.lam = solver, mu, lam
        self.checkpoints: list[ParticleState] = []
        self.stored = [solver.new_state() for _ in range(max_substeps + 1)]
        self.work = [solver.new_state(requires_grad=True), solver.new_state(requires_grad=True)]

    def forward(self, start: ParticleState | None, drives: list[DeviceDrive], first: int = 0,
                last: int | None = None) -> list[np.ndarray]:
        """Simulate drives[first:last + 1] from `start` (the state at frame `first`; None: the kept checkpoint);
        returns each frame's end positions (N, 3) float32. Frame-start checkpoints are kept for backward."""
        while len(self.checkpoints) < len(drives) + 1:
            self.checkpoints.append(self.solver.new_state())
        if start is not None:
            self.checkpoints[first].assign(start)
        out = []
        a, b = self.stored[0], self.stored[1]
        for f in range(first, len(drives) if last is None else last + 1):
            a.assign(self.checkpoints[f])
            a, b = advance_frame(self.solver, a, b, drives[f], self.mu, self.lam)
            self.checkpoints[f + 1].assign(a)
            out.append(a.x.numpy().copy())
        return out

    def _replay(self, f: int, drive: DeviceDrive) -> None:
        self.stored[0].assign(self.checkpoints[f])
        for k in range(drive.plan.substeps):
            self.solver.substep(self.stored[k], self.stored[k + 1], drive.inputs(k, self.mu, self.lam))

    def backward(self, drives: list[DeviceDrive], position_grads: dict[int, np.ndarray], first: int = 0) -> np.ndarray:
        """Back-propagate dL/dx given at frame ends {frame: (N, 3)} through frames first..last.

        Accumulates into mu.grad, lam.grad and each drive's dv.grad; returns dL/dx at frame `first`'s start.
        """
        last = max(position_grads)
        out_state, in_state = self.work
        out_state.zero_grad()
        for f in range(last, first - 1, -1):
            if f in position_grads:
                g = out_state.x.grad.numpy() + np.asarray(position_grads[f], np.float32)
                out_state.x.grad.assign(g)
            self._replay(f, drives[f])
            for k in range(drives[f].plan.substeps - 1, -1, -1):
                in_state.assign(self.stored[k])
                in_state.zero_grad()
                self.solver.backward_substep(in_state, out_state, drives[f].inputs(k, self.mu, self.lam))
                out_state, in_state = in_state, out_state
        self.work = [out_state, in_state]
        return out_state.x.grad.numpy().copy()

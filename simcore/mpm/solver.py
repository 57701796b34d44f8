"""MLS-MPM substeps on a (sparse) background grid, forward and adjoint.

The adjoint never keeps a grid per substep: `backward_substep` recomputes one substep's grid from the stored
particle state under a short `wp.Tape`, pulls the particle adjoints back through it and clears the grid. So a
differentiable frame stores only particle states (x, v, C, F: 24 floats per particle per substep).
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
import warp as wp

from simcore.cores import usable_cores
from simcore.mpm import kernels as K


@dataclass
class ParticleState:
    """Particle arrays on one device: x, v (N,) vec3; C (APIC affine velocity), F (deformation gradient) (N,) mat33."""

    x: wp.array
    v: wp.array
    C: wp.array
    F: wp.array

    def arrays(self) -> tuple[wp.array, ...]:
        return (self.x, self.v, self.C, self.F)

    def assign(self, other: ParticleState) -> None:
        """Copy values (not gradients) from another state."""
        for dst, src in zip(self.arrays(), other.arrays()):
            wp.copy(dst, src)

    def zero_grad(self) -> None:
        for a in self.arrays():
            if a.grad is not None:
                a.grad.zero_()


@dataclass
class SubstepInputs:
    """What one substep needs besides the particle state.

    mu, lam: (N,) float per-particle Lamé parameters (Pa); origin: world position of grid node (0, 0, 0), metres;
    dt: seconds; dp, dv: (D,) vec3 driving-point positions and velocities (None: no drivers).
    """

    mu: wp.array
    lam: wp.array
    origin: tuple[float, float, float]
    dt: float
    dp: wp.array | None = None
    dv: wp.array | None = None
    tether: Tether | None = None
    tether_step: int = 0  # this substep's index into the tether's skinning sets


@dataclass
class Tether:
    """Max-distance constraint to the skinned pose (forward only, see kernels.tether).

    rest: (N,) vec3 bind positions; joints, weights: (N,) vec4i / vec4 four skinning influences per particle;
    skin: ((S + 1) · J,) mat44 skinning matrices at the S + 1 substep boundaries of a frame interval;
    radius: (N,) float metres per particle; count: (1,) int32 particles put back since the last read.
    """

    rest: wp.array
    joints: wp.array
    weights: wp.array
    skin: wp.array
    num_joints: int
    radius: wp.array
    count: wp.array


MAX_CPU_THREADS = 8  # particle passes split over at most this many cores


def warp_device(device: str | None = None) -> str:
    """Initialise Warp quietly and return the device name ("cpu", "cuda:0"); default: CUDA when present."""
    wp.config.quiet = True
    wp.init()
    if device:
        return device
    return "cuda:0" if wp.is_cuda_available() else "cpu"


class MPMSolver:
    """Fixed-size particle set on an n³ grid of spacing dx (the grid may move: `origin` is per substep).

    particle_mass: kg per particle; particle_volume: m³ per particle; sparse: update only active 4³ blocks
    (False runs the dense reference of the same kernels; None picks sparse on CPU and dense on CUDA, where
    bench/mpm.py measures the dense pass faster there: launch-bound; the README's bench table has the figures);
    gravity: m/s²; drive_gain: how strongly driver
    weight on a node replaces its velocity (weight × gain, capped at 1); bound: wall band in nodes;
    v_max: velocity clamp in m/s (None: 0.5 dx/dt per substep, the CFL limit).
    threads: CPU cores for the particle passes (None: every core up to MAX_CPU_THREADS on CPU without gradients,
    else 1). Warp runs a CPU launch on one core and releases the GIL, so P2G and G2P are launched over contiguous
    particle ranges from a thread pool; each range scatters into its own grid copy, added into copy 0 before the
    grid pass (`sum_copies`; the same sum in another order: results agree with one thread to float rounding).
    """

    def __init__(
        self,
        num_particles: int,
        grid: int,
        dx: float,
        particle_mass: float,
        particle_volume: float,
        *,
        device: str | None = None,
        sparse: bool | None = None,
        gravity: tuple[float, float, float] = (0.0, 0.0, 0.0),
        drive_gain: float = 4.0,
        bound: int = 3,
        requires_grad: bool = False,
        threads: int | None = None,
    ) -> None:
        if grid % K.BLOCK:
            raise ValueError(f"grid must be a multiple of {K.BLOCK}, got {grid}")
        self.device = warp_device(device)
        cpu = not self.device.startswith("cuda")
        if threads is None:
            threads = min(usable_cores(), MAX_CPU_THREADS) if cpu and not requires_grad else 1
        if threads > 1 and (requires_grad or not cpu):
            raise ValueError("threads > 1 is for forward-only CPU solvers (a tape records one thread's launches)")
        self.threads = max(1, min(int(threads), max(int(num_particles), 1)))
        self.n, self.dx, self.num_particles = int(grid), float(dx), int(num_particles)
        self.mass, self.vol = float(particle_mass), float(particle_volume)
        sparse = not self.device.startswith("cuda") if sparse is None else sparse
        self.sparse, self.gravity, self.drive_gain, self.bound = sparse, wp.vec3(*gravity), float(drive_gain), int(bound)
        self.requires_grad = requires_grad
        nodes, nb = self.n**3, (self.n // K.BLOCK) ** 3
        g = dict(device=self.device, requires_grad=requires_grad)
        self.grid_mv = wp.zeros(nodes * self.threads, dtype=wp.vec3, **g)  # one P2G copy per thread
        self.grid_m = wp.zeros(nodes * self.threads, dtype=float, **g)
        self.drv_v = wp.zeros(nodes, dtype=wp.vec3, **g)
        self.drv_w = wp.zeros(nodes, dtype=float, **g)
        self.grid_v = wp.zeros(nodes, dtype=wp.vec3, **g)
        self.flags = wp.zeros(nb, dtype=wp.int32, device=self.device)
        self.active = wp.zeros(nb, dtype=wp.int32, device=self.device)
        self.count = wp.zeros(1, dtype=wp.int32, device=self.device)
        self.active_blocks = 0
        # [velocity clamps, det F rejections] per thread
        self.clamps = wp.zeros(2 * self.threads, dtype=wp.int32, device=self.device)
        bounds = np.linspace(0, self.num_particles, self.threads + 1).astype(int)
        self.ranges = [(int(a), int(b - a)) for a, b in zip(bounds[:-1], bounds[1:])]  # (offset, count) per thread
        self.pool: ThreadPoolExecutor | None = None
        if self.threads > 1:
            wp.load_module(K, device=self.device)  # compile/load once here, never from two threads at once
            self.pool = ThreadPoolExecutor(self.threads - 1, thread_name_prefix="mpm")

    # --- state -----------------------------------------------------------------------------------------

    def new_state(self, x: np.ndarray | None = None, requires_grad: bool = False) -> ParticleState:
        """A state at rest (v = 0, C = 0, F = I) at positions x: (N, 3) float (zeros when None)."""
        n, d = self.num_particles, self.device
        xs = np.zeros((n, 3), np.float32) if x is None else np.asarray(x, np.float32)
        F = np.tile(np.eye(3, dtype=np.float32), (n, 1, 1))
        return ParticleState(
            wp.array(xs, dtype=wp.vec3, device=d, requires_grad=requires_grad),
            wp.zeros(n, dtype=wp.vec3, device=d, requires_grad=requires_grad),
            wp.zeros(n, dtype=wp.mat33, device=d, requires_grad=requires_grad),
            wp.array(F, dtype=wp.mat33, device=d, requires_grad=requires_grad),
        )

    # --- one substep -----------------------------------------------------------------------------------

    def _prepare_blocks(self, s: ParticleState, inp: SubstepInputs) -> None:
        if not self.sparse:
            return
        origin, inv_dx = wp.vec3(*inp.origin), 1.0 / self.dx
        wp.launch(K.mark_blocks, dim=self.num_particles, inputs=[s.x, origin, inv_dx, self.n, self.flags], device=self.device)
        if inp.dp is not None and inp.dp.shape[0]:
            wp.launch(K.mark_blocks, dim=inp.dp.shape[0], inputs=[inp.dp, origin, inv_dx, self.n, self.flags], device=self.device)
        self.count.zero_()
        wp.launch(K.compact_blocks, dim=self.flags.shape[0], inputs=[self.flags, self.active, self.count], device=self.device)
        self.active_blocks = int(self.count.numpy()[0])  # host read: the launch size of the grid passes

    def _particle_pass(self, kernel, args: Callable[[int, int], list]) -> None:
        """Launch `kernel` over every particle range; args(offset, thread index) → its inputs."""
        launches = [(count, args(offset, t)) for t, (offset, count) in enumerate(self.ranges)]
        if self.pool is None:
            for count, inputs in launches:
                wp.launch(kernel, dim=count, inputs=inputs, device=self.device)
            return
        futures = [self.pool.submit(wp.launch, kernel, dim=count, inputs=inputs, device=self.device)
                   for count, inputs in launches[1:]]
        wp.launch(kernel, dim=launches[0][0], inputs=launches[0][1], device=self.device)  # this thread takes a share
        for f in futures:
            f.result()

    def _transfer(self, s_in: ParticleState, s_out: ParticleState, inp: SubstepInputs) -> None:
        origin, dev, n = wp.vec3(*inp.origin), self.device, self.n
        self._particle_pass(K.p2g, lambda offset, t: [
            s_in.x, s_in.v, s_in.C, s_in.F, inp.mu, inp.lam, self.mass, self.vol, origin, self.dx, inp.dt, n,
            offset, t, self.grid_mv, self.grid_m])
        if inp.dp is not None and inp.dp.shape[0]:
            wp.launch(K.drivers_to_grid, dim=inp.dp.shape[0], device=dev,
                      inputs=[inp.dp, inp.dv, origin, self.dx, n, self.drv_v, self.drv_w])
        if self.threads > 1:
            dim = self.active_blocks * K.BLOCK**3 if self.sparse else n**3
            wp.launch(K.sum_copies, dim=dim, inputs=[self.active, n, int(not self.sparse), self.threads, self.grid_mv, self.grid_m], device=dev)
        common = [self.grid_mv, self.grid_m, self.drv_v, self.drv_w, self.gravity, inp.dt, self.drive_gain, self.bound, self.grid_v]
        if self.sparse:
            wp.launch(K.grid_update_sparse, dim=self.active_blocks * K.BLOCK**3, inputs=[self.active, n, *common], device=dev)
        else:
            wp.launch(K.grid_update_dense, dim=n**3, inputs=[n, *common], device=dev)
        v_max = 0.5 * self.dx / inp.dt
        self._particle_pass(K.g2p, lambda offset, t: [
            s_in.x, s_in.F, self.grid_v, origin, self.dx, inp.dt, n, v_max, offset, t,
            s_out.x, s_out.v, s_out.C, s_out.F, self.clamps])

    def _clear(self, with_grads: bool) -> None:
        arrays = [self.grid_mv, self.grid_m, self.drv_v, self.drv_w, self.grid_v]
        sets = [arrays] + ([[a.grad for a in arrays]] if with_grads else [])
        if not self.sparse:
            for group in sets:
                for a in group:
                    a.zero_()
            return
        dim = self.active_blocks * K.BLOCK**3
        for group in sets:
            wp.launch(K.clear_blocks, dim=dim, inputs=[self.active, self.n, self.threads, *group], device=self.device)
        wp.launch(K.clear_flags, dim=self.active_blocks, inputs=[self.active, self.flags], device=self.device)

    def substep(self, s_in: ParticleState, s_out: ParticleState, inp: SubstepInputs) -> None:
        """Advance s_in by inp.dt into s_out (they must be different states)."""
        self._prepare_blocks(s_in, inp)
        self._transfer(s_in, s_out, inp)
        self._clear(with_grads=False)
        t = inp.tether
        if t is not None:
            k = inp.tether_step * t.num_joints
            wp.launch(K.tether, dim=self.num_particles, device=self.device, inputs=[
                t.rest, t.joints, t.weights, t.skin, k, k + t.num_joints, inp.dt, t.radius, s_out.x, s_out.v, t.count])

    def backward_substep(self, s_in: ParticleState, s_out: ParticleState, inp: SubstepInputs) -> None:
        """Accumulate s_in.grad (and mu/lam/dv grads) from s_out.grad, recomputing the grid of this substep.

        s_in holds the stored values of the substep's start; s_out's values are overwritten by the recompute,
        its grads are read. s_in.grad must be zeroed by the caller.
        """
        self._prepare_blocks(s_in, inp)
        tape = wp.Tape()
        with tape:
            self._transfer(s_in, s_out, inp)
        tape.backward()
        self._clear(with_grads=True)

    # --- diagnostics -----------------------------------------------------------------------------------

    def take_clamp_counts(self) -> tuple[int, int]:
        """(velocity clamps, det F rejections) since the last call."""
        c = self.clamps.numpy().reshape(-1, 2).sum(axis=0)
        self.clamps.zero_()
        return int(c[0]), int(c[1])

    def mean_det_deviation(self, s: ParticleState) -> float:
        """Mean over particles of |det F - 1|."""
        out = wp.zeros(1, dtype=float, device=self.device)
        wp.launch(K.det_deviation, dim=self.num_particles, inputs=[s.F, out], device=self.device)
        return float(out.numpy()[0]) / max(self.num_particles, 1)

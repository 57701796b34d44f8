"""Inverse PhysRig: fit prototype materials and driving-point velocities to an observed mesh sequence.

The paper's alternating scheme (§3.1.4, A.2): per cycle, (1) AdamW on the prototype materials over all
frames at once, (2) SGD on the driving-point velocities frame by frame (frames before the current one
fixed), each phase with a linearly decaying learning rate reset at its start; 3 cycles. Loss: squared
chamfer distance between the simulated mesh vertices and the target frame, summed over vertices and
divided by dx² (cells²), so SGD step sizes do not depend on the mesh's scale or vertex count.
Gradients: Warp adjoint (`DifferentiableRollout`).

Parameterisation (our choices): materials as θ_p = 4 · log(E_p / E_preset) (positive E; AdamW's decay pulls
toward the preset; the factor 4 makes the paper's 20× learning-rate ratio give 0.05 steps in log E, larger
steps overshoot the narrow valleys of the chamfer loss in E), ν fixed (the paper assumes one ν per object); velocities in grid cells per frame so
that the SGD learning rate does not depend on the mesh's scale or frame rate.
Learned mixing (eq. 11): with `learn_mixing` the material phase also moves each prototype's centre (in cells),
its axes (a rotation vector) and its log radii, so the per-particle weights W(x) are learned with E; their
gradients come from dL/dE per particle through the softmax (torch).
Driving points: with `drivers="skeleton"` a skeleton is predicted on frame 0 (geometric, as the paper uses
Pinocchio) with coarse geodesic skinning weights, and each joint gets 8 points along its bone cores
(`place_drivers` "bones"); with "virtual", `virtual_joints` centres by farthest-point sampling of the volume
(the paper's "uniform sampling" initialisation), 8 points each on a cube. Initial velocity of a driving
point per frame = mean displacement of the target vertices nearest it (the paper's neighbourhood average).
Drive (`drive`): "velocity" integrates the fitted velocities into the driving points' positions (open loop, as
the paper: an error in one interval's velocity stays in every later frame). "anchored" (default) closes the
loop: at each frame start a driving point sits where the particles it is embedded in are, and its velocity over
the interval is the one that reaches its anchor at the interval's end (`anchors`: its joint's rigid motion
fitted to that target frame) plus a fitted correction in cells; the correction is what SGD fits, and an
interval's error is corrected by the next one instead of accumulating. The material phase treats the
feedback as fixed within an iteration (no gradient through the driving points' start positions).
Initial motion (`initial_motion`, our choice, off by default): the particles may start with the velocity their
joints' fitted motion gives them over the first interval (coarse weights of the particle's nearest target vertices,
or the virtual joints' falloff) instead of at rest. It has not helped in the sequences measured, so the
body starts at rest unless asked.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from simcore.mpm.anchors import driver_anchors, falloff_weights, joint_motions
from simcore.mpm.drivers import CUBE
from simcore.mpm.materials import PRESETS, Prototypes, farthest_points, lame, seed_prototypes
from simcore.mpm.measures import chamfer, chamfer_grad
from simcore.mpm.sampling import sample_on_grid
from simcore.mpm.scene import BOUND, MARGIN_NODES

NEIGHBOURS = 16  # target vertices averaged for a virtual joint's initial velocity
EMBED = 8  # particles whose mean motion carries a driving point (anchored drive)
LOG_E_SCALE = 4.0  # material parameter θ = LOG_E_SCALE · log(E / E_preset)


@dataclass
class FitConfig:
    """Sizes and schedule; defaults are small enough for 2 CPU cores (scale up with the CLI flags)."""

    grid: int = 32
    substeps: int = 25  # per frame
    max_particles: int = 3000
    prototypes: int = 25
    virtual_joints: int = 12
    cycles: int = 3
    material_iters: int = 5  # paper: 20
    velocity_iters: int = 5  # paper: 30 per frame
    velocity_lr: float = 0.01  # SGD, velocities in cells per frame (the paper: 5e-3 to 2e-2, often 0.01)
    material_lr_factor: float = 20.0  # paper: material lr = 20 × velocity lr
    weight_decay: float = 0.01
    loss_threshold: float = 0.01  # next frame once a frame's loss is below this × V (cells² per vertex)
    preset: str = "flesh"
    seed: int = 0
    device: str | None = None
    drivers: str = "skeleton"  # "skeleton" (predicted on frame 0) or "virtual" (farthest-point centres)
    max_joints: int = 24  # skeleton drivers: joints of the predicted skeleton at most
    learn_mixing: bool = True  # material phase also learns prototype centres, axes and radii
    drive: str = "anchored"  # "anchored" (closed loop on per-frame anchors) or "velocity" (open loop)
    initial_motion: bool = False  # particles start with their joints' motion over the first interval (off: at rest)


@dataclass
class FitScene:
    """A prepared inverse problem: targets (T, V, 3) float64; particles x0 (N, 3) at frame 0;
    vertex_particles (V,) int64; prototypes (initial); driver rest points (D, 3) at frame 0;
    velocities (T-1, D, 3) cells/frame; centres (T, 3) grid centres; dx, grid, dt, substeps, frame_dt."""

    targets: np.ndarray
    x0: np.ndarray
    vertex_particles: np.ndarray
    particle_volume: float
    density: float
    protos: Prototypes
    drivers0: np.ndarray
    velocities: np.ndarray
    centres: np.ndarray
    dx: float
    grid: int
    substeps: int
    frame_dt: float
    nu: float
    joints: np.ndarray  # (M, 3) joint (or virtual joint) positions at frame 0
    joint_weights: np.ndarray | None = None  # (V, M) coarse skinning weights of the target vertices (skeleton drivers)
    anchors: np.ndarray | None = None  # (T, D, 3) driving-point targets per frame (anchored drive)
    driver_particles: np.ndarray | None = None  # (D, EMBED) particles each driving point is embedded in
    joint_motion: tuple[np.ndarray, np.ndarray] | None = None  # per-frame joint rotations (T, M, 3, 3), translations (T, M, 3)
    particle_weights: np.ndarray | None = None  # (N, M) the particles' weights over the joints of joint_motion
    grid_note: str | None = None  # why the grid differs from the one asked for (simcore.mpm.sampling.sample_on_grid)


@dataclass
class FitResult:
    """chamfer_init / chamfer: (T,) mean-L2 symmetric chamfer per frame before / after fitting, in the units of the
    targets; E: (P,) fitted Young's moduli, Pa; losses: loss after each phase; seconds: wall time."""

    chamfer_init: np.ndarray
    chamfer: np.ndarray
    E: np.ndarray
    losses: list[float] = field(default_factory=list)
    seconds: float = 0.0
    frames: np.ndarray | None = None  # (T, V, 3) fitted vertex positions


def prepare_scene(targets: np.ndarray, faces: np.ndarray, fps: float, config: FitConfig,
                  driver_centres: np.ndarray | None = None) -> FitScene:
    """Sample frame 0, seed prototypes and drivers, initialise velocities. targets: (T, V, 3) float, faces: (F, 3)."""
    targets = np.asarray(targets, np.float64)
    lo, hi = targets.min(axis=1), targets.max(axis=1)
    placed = sample_on_grid(targets[0], faces, float((hi - lo).max()), config.grid, 2 * (BOUND + MARGIN_NODES),
                            max_particles=config.max_particles, seed=config.seed)
    sample, grid, dx = placed.sample, placed.grid, placed.dx
    material = PRESETS[config.preset]
    protos = seed_prototypes(sample.positions, config.prototypes, material, sample.volume, seed=config.seed)
    joint_weights = None
    if driver_centres is None and config.drivers == "skeleton":
        driver_centres, drivers0, joint_weights, owners = skeleton_drivers(targets[0], faces, dx, config.max_joints)
        anchor_weights = joint_weights
    else:
        if driver_centres is None:
            driver_centres = sample.positions[farthest_points(sample.positions, config.virtual_joints, config.seed + 1)]
        driver_centres = np.asarray(driver_centres, np.float64)
        drivers0 = (driver_centres[:, None, :] + CUBE[None] * 0.5 * dx).reshape(-1, 3)
        owners = np.repeat(np.arange(len(driver_centres)), len(CUBE))
        anchor_weights = falloff_weights(targets[0], driver_centres)
    frame_dt = 1.0 / fps
    _, near = cKDTree(targets[0]).query(drivers0, k=min(NEIGHBOURS, targets.shape[1]))
    velocities = np.diff(targets, axis=0)[:, near].mean(axis=2) / dx  # (T-1, D, 3) cells per frame
    rot, trans = joint_motions(targets, anchor_weights)
    _, nearest = cKDTree(targets[0]).query(sample.positions)
    particle_weights = anchor_weights[nearest]
    anchors = driver_anchors(rot, trans, drivers0, owners)
    _, embedded = cKDTree(sample.positions).query(drivers0, k=min(EMBED, len(sample.positions)))
    return FitScene(targets, sample.positions, sample.vertex_particles, sample.particle_volume, material.density,
                    protos, drivers0, velocities,
                    0.5 * (lo + hi), dx, grid, config.substeps, frame_dt, material.nu,
                    np.asarray(driver_centres, np.float64), joint_weights, anchors,
                    np.asarray(embedded, np.int64).reshape(len(drivers0), -1), (rot, trans), particle_weights,
                    placed.note)


def driver_path(scene: FitScene, velocities: np.ndarray) -> FitScene:
    """The scene with driving points that follow velocities (T-1, D, 3) in cells per frame, in both drives:
    the open-loop velocities and the anchors they integrate to."""
    steps = np.concatenate([np.zeros((1,) + velocities.shape[1:]), np.cumsum(velocities, axis=0)]) * scene.dx
    return dataclasses.replace(scene, velocities=np.asarray(velocities, np.float64), anchors=scene.drivers0[None] + steps)


def initial_velocities(scene: FitScene) -> np.ndarray:
    """(N, 3) particle velocities over the first interval from the joints' fitted motion (zeros without one)."""
    if scene.joint_motion is None or scene.particle_weights is None or len(scene.targets) < 2:
        return np.zeros_like(scene.x0)
    rot, trans = scene.joint_motion
    w = scene.particle_weights / np.maximum(scene.particle_weights.sum(axis=1, keepdims=True), 1e-12)
    moved = np.einsum("nm,mab,nb->na", w, rot[1], scene.x0) + w @ trans[1]
    return (moved - scene.x0) / scene.frame_dt


def skeleton_drivers(vertices: np.ndarray, faces: np.ndarray, dx: float,
                     max_joints: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Predicted skeleton of a mesh frame (V, 3): (joint positions (M, 3), driving points (D, 3) along the bone
    cores, coarse skinning weights (V, M) dense, joint carrying each driving point (D,))."""
    from simcore.mpm.drivers import leaf_tips, place_drivers
    from simcore.skeleton.predict import predict_skeleton
    from simcore.skinning.predict import compute_weights

    skeleton = predict_skeleton(vertices, faces, method="geometric", max_joints=max_joints).skeleton
    weights = compute_weights(vertices, faces, skeleton, method="geodesic").weights
    drivers = place_drivers(skeleton, "bones", dx, tips=leaf_tips(skeleton, vertices, weights))
    return skeleton.positions.copy(), drivers.rest, np.asarray(weights.todense(), np.float64), drivers.joints


class PhysicsFit:
    """Owns the Warp solver and rollout for one FitScene."""

    def __init__(self, scene: FitScene, config: FitConfig) -> None:
        import warp as wp

        from simcore.mpm.simulate import DifferentiableRollout
        from simcore.mpm.solver import MPMSolver

        self.wp, self.scene, self.config = wp, scene, config
        n = len(scene.x0)
        self.solver = MPMSolver(n, scene.grid, scene.dx, scene.density * scene.particle_volume, scene.particle_volume,
                                device=config.device, requires_grad=True)
        dev = self.solver.device
        self.mu = wp.zeros(n, dtype=float, device=dev, requires_grad=True)
        self.lam = wp.zeros(n, dtype=float, device=dev, requires_grad=True)
        self.rollout = DifferentiableRollout(self.solver, self.mu, self.lam, scene.substeps)
        self.start = self.solver.new_state(scene.x0)
        if config.initial_motion:
            self.start.v.assign(initial_velocities(scene).astype(np.float32))
        self.theta = np.zeros(scene.protos.count)  # LOG_E_SCALE · log(E / E_preset)
        protos = scene.protos
        # prototype geometry: centres in cells, axes as rotation vectors, log of Λ's diagonal
        self.geometry = {"centres": protos.centres / scene.dx, "rotvec": np.zeros((protos.count, 3)),
                         "log_inv_sq": np.log(protos.inv_sq_radii)}
        self.anchored = config.drive == "anchored"
        if self.anchored and (scene.anchors is None or scene.driver_particles is None):
            raise ValueError("the anchored drive needs the scene's anchors and driver particles")
        # fitted driving quantity per interval, cells: the velocity per frame (open loop) or the correction of the
        # interval's end anchor (anchored)
        self.controls = np.zeros_like(scene.velocities) if self.anchored else scene.velocities.copy()
        self.drive_list: list = []  # DeviceDrive per interval, rebuilt by `forward`
        self.set_materials(self.theta)

    # --- parameters → simulation inputs -----------------------------------------------------------------

    def E(self, theta: np.ndarray | None = None) -> np.ndarray:
        return self.scene.protos.E * np.exp((self.theta if theta is None else theta) / LOG_E_SCALE)

    def theta_of(self, E: np.ndarray) -> np.ndarray:
        return LOG_E_SCALE * np.log(np.asarray(E, np.float64) / self.scene.protos.E)

    def particle_E(self, theta, geometry: dict):  # noqa: ANN001, ANN201 - torch tensors in, (N,) tensor out
        """Eq. 11 in torch: per-particle E from prototype E (θ) and geometry (differentiable in both)."""
        import torch

        from simcore.mpm.lbs_fit import rodrigues

        x = torch.as_tensor(self.scene.x0 / self.scene.dx)
        R = rodrigues(geometry["rotvec"])  # (P, 3, 3)
        local = torch.einsum("pab,npb->npa", R, x[:, None, :] - geometry["centres"][None])
        d = (local**2 * torch.exp(geometry["log_inv_sq"])[None] * self.scene.dx**2).sum(-1)
        w = torch.softmax(-d, dim=1)
        return w @ (torch.as_tensor(self.scene.protos.E) * torch.exp(theta / LOG_E_SCALE))

    def set_materials(self, theta: np.ndarray, geometry: dict | None = None) -> None:
        import torch

        self.theta = np.asarray(theta, np.float64)
        if geometry is not None:
            self.geometry = {k: np.asarray(v, np.float64) for k, v in geometry.items()}
        with torch.no_grad():
            E = self.particle_E(torch.as_tensor(self.theta), {k: torch.as_tensor(v) for k, v in self.geometry.items()})
        mu, lam = lame(E.numpy(), self.scene.nu)
        self.mu.assign(mu.astype(np.float32))
        self.lam.assign(lam.astype(np.float32))

    def driver_start(self, f: int, x: np.ndarray) -> np.ndarray:
        """(D, 3) driving-point positions at the start of interval f; x: (N, 3) particles at that frame."""
        sc = self.scene
        if not self.anchored:
            return sc.drivers0 + self.controls[:f].sum(axis=0) * sc.dx
        assert sc.driver_particles is not None
        embed = sc.driver_particles
        return sc.drivers0 + x[embed].mean(axis=1) - sc.x0[embed].mean(axis=1)

    def _drive(self, f: int, x: np.ndarray):  # noqa: ANN202 - a DeviceDrive
        from simcore.mpm.simulate import DeviceDrive, FramePlan

        sc, n = self.scene, self.scene.substeps
        dt = sc.frame_dt / n
        start = self.driver_start(f, x)
        if self.anchored:
            assert sc.anchors is not None
            v = (sc.anchors[f + 1] + self.controls[f] * sc.dx - start) / sc.frame_dt  # m/s
        else:
            v = self.controls[f] * sc.dx / sc.frame_dt
        k = (np.arange(n) / n)[:, None]
        dp = start[None] + (np.arange(n) * dt)[:, None, None] * v[None]
        origins = (1 - k) * sc.centres[f] + k * sc.centres[f + 1] - 0.5 * (sc.grid - 1) * sc.dx
        plan = FramePlan(dt, origins, dp.astype(np.float32), np.repeat(v[None], n, axis=0).astype(np.float32))
        return DeviceDrive(plan, self.solver.device, requires_grad=True)

    def forward(self, first: int = 0, last: int | None = None) -> list[np.ndarray]:
        """Simulate intervals first..last (default: to the end) from the kept state at frame `first` (frame 0:
        the rest state), building each interval's drive from the state at its start; returns each frame's end
        positions (N, 3). Keeps the drives (`drive_list`) and frame checkpoints for backward."""
        last = len(self.controls) - 1 if last is None else last
        x = self.scene.x0 if first == 0 else self.rollout.checkpoints[first].x.numpy().astype(np.float64)
        out = []
        for f in range(first, last + 1):
            drive = self._drive(f, x)
            if f < len(self.drive_list):
                self.drive_list[f] = drive
            else:
                self.drive_list.append(drive)
            x = self.rollout.forward(self.start if f == 0 else None, self.drive_list, first=f, last=f)[0]
            out.append(x)
            x = x.astype(np.float64)
        return out

    # --- losses ------------------------------------------------------------------------------------------

    def _frame_loss(self, x: np.ndarray, f: int) -> tuple[float, np.ndarray]:
        """Loss of simulated particles x (N, 3) against target frame f, and dL/dx (N, 3): the squared chamfer
        summed over vertices (V × the mean) in cells², so SGD steps on velocities do not shrink with V."""
        vp = self.scene.vertex_particles
        loss, grad_v = chamfer_grad(x[vp], self.scene.targets[f])
        scale = len(vp) / self.scene.dx**2
        grad = np.zeros_like(x, dtype=np.float64)
        np.add.at(grad, vp, grad_v * scale)
        return loss * scale, grad

    def simulate(self) -> np.ndarray:
        """(T, V, 3) float64 simulated vertex positions with the current parameters (frame 0 = targets[0])."""
        xs = self.forward()
        vp = self.scene.vertex_particles
        return np.concatenate([self.scene.targets[:1], np.stack([x[vp] for x in xs]).astype(np.float64)])

    # --- phases ------------------------------------------------------------------------------------------

    def material_phase(self, iters: int, lr: float) -> float:
        import torch

        theta = torch.tensor(self.theta, dtype=torch.float64, requires_grad=True)
        geometry = {k: torch.tensor(v, dtype=torch.float64, requires_grad=self.config.learn_mixing)
                    for k, v in self.geometry.items()}
        groups = [{"params": [theta], "weight_decay": self.config.weight_decay}]
        if self.config.learn_mixing:
            groups.append({"params": list(geometry.values()), "weight_decay": 0.0})
        opt = torch.optim.AdamW(groups, lr=lr)
        sched = torch.optim.lr_scheduler.LambdaLR(opt, lambda i: max(1.0 - i / max(iters, 1), 0.0))
        total, best = 0.0, (np.inf, self.theta.copy(), dict(self.geometry))
        for _ in range(iters):
            xs = self.forward()
            grads, total = {}, 0.0
            for f, x in enumerate(xs):
                loss, g = self._frame_loss(x, f + 1)
                grads[f], total = g, total + loss
            if total < best[0]:
                best = (total, self.theta.copy(), dict(self.geometry))
            self.mu.grad.zero_()
            self.lam.grad.zero_()
            self.rollout.backward(self.drive_list, grads)
            nu = self.scene.nu
            d_e = self.mu.grad.numpy() / (2 * (1 + nu)) + self.lam.grad.numpy() * nu / ((1 + nu) * (1 - 2 * nu))
            opt.zero_grad()
            # dL/dθ and dL/d(geometry) through E(x) = W(x) · E_p: backward of the surrogate Σ_n dL/dE_n · E_n
            surrogate = (torch.as_tensor(np.nan_to_num(d_e.astype(np.float64))) * self.particle_E(theta, geometry)).sum()
            surrogate.backward()
            opt.step()
            sched.step()
            self.set_materials(theta.detach().numpy().copy(), {k: v.detach().numpy().copy() for k, v in geometry.items()})
        if best[0] < total:  # a step can overshoot a narrow valley: leave the phase at its best evaluated point
            self.set_materials(best[1], best[2])
            total = best[0]
        return total

    def velocity_phase(self, iters: int, lr: float, progress: Callable[[float], None] = lambda f: None,
                       first: int = 0) -> float:
        """SGD on the driving controls frame by frame from frame interval `first` (earlier ones stay fixed);
        returns the summed loss of the fitted intervals. Each step looks at its own frame only, so fitting early
        frames can cost the later ones more than it gains (the particles' velocities carry on); a phase that ends
        worse than it started is undone, as the material phase keeps its best point."""
        frames = len(self.controls)
        xs = self.forward()  # checkpoints for every frame start
        start_loss = sum(self._frame_loss(xs[f], f + 1)[0] for f in range(first, frames))
        start_controls = self.controls.copy()
        total = 0.0
        for f in range(first, frames):
            loss = 0.0
            for i in range(iters):
                x = self.forward(f, f)[0]
                loss, g = self._frame_loss(x, f + 1)
                if loss < self.config.loss_threshold * len(self.scene.vertex_particles):
                    break
                self.rollout.backward(self.drive_list, {f: g}, first=f)
                # dL/d(control): the interval's velocity moves by dx / frame_dt per cell of control in both drives
                grad_cells = self.drive_list[f].dv.grad.numpy().sum(axis=0) * self.scene.dx / self.scene.frame_dt
                self.controls[f] -= lr * (1.0 - i / iters) * np.nan_to_num(grad_cells)
            x = self.forward(f, f)[0]  # refresh the next frame's checkpoint
            total += self._frame_loss(x, f + 1)[0]
            progress((f + 1) / frames)
        if total > start_loss:
            self.controls = start_controls
            self.forward()
            total = start_loss
        return total


def per_frame_chamfer(frames: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """(T,) symmetric mean-L2 chamfer per frame between (T, V, 3) and (T, W, 3) point sets."""
    return np.array([chamfer(a, b) for a, b in zip(frames, targets)])


def fit_physics(scene: FitScene, config: FitConfig, log: Callable[[str], None] = lambda s: None,
                materials_from: PhysicsFit | None = None, first: int = 0) -> tuple[FitResult, PhysicsFit]:
    """Run the alternating scheme on a prepared scene.

    materials_from: a fit whose materials (E and prototype geometry) are copied and kept fixed, and whose
    driving controls seed the intervals it covered (the test part of the train/test protocol: only the controls of
    intervals ≥ `first` are fitted). Returns the result and the fit (its parameters).
    """
    started = time.perf_counter()
    fit = PhysicsFit(scene, config)
    if materials_from is not None:
        fit.set_materials(materials_from.theta, materials_from.geometry)
        fit.controls[:len(materials_from.controls)] = materials_from.controls
    init = per_frame_chamfer(fit.simulate(), scene.targets)
    losses = []
    for cycle in range(config.cycles):
        if materials_from is None:
            m = fit.material_phase(config.material_iters, config.velocity_lr * config.material_lr_factor)
            losses.append(m)
        v = fit.velocity_phase(config.velocity_iters, config.velocity_lr, first=first)
        losses.append(v)
        log(f"cycle {cycle + 1}/{config.cycles}: phase losses {', '.join(f'{x:.4f}' for x in losses[-2:])} (cells²)")
    frames = fit.simulate()
    result = FitResult(init, per_frame_chamfer(frames, scene.targets), fit.E(), losses, time.perf_counter() - started, frames)
    return result, fit

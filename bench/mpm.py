"""MLS-MPM substep speed and adjoint memory (issue 6 targets: ≤ 10 ms per substep at 20k particles / 64³ on
this CPU; forward + backward ≤ 400 MB per 100-substep frame at 20k).

Scene: N particles at 8 per cell filling a ball in the middle of an n³ grid (a character fills its grid
sparsely too), spinning and sheared so F, C and the polar iterations do real work; two driving points;
Δt = 4e-4 s (PhysRig's). Measured per configuration, same kernels:
  sparse  grid passes over the active 4³ blocks only (what the product runs), particle passes on every core
          (MPMSolver's default) and again on one core
  dense   grid passes over every node (the in-run reference)
Forward: ms per substep (median over 6 timed blocks, and the fastest block) and particle-substeps per second.
Backward: ms per substep of `backward_substep` (grid recompute + adjoint). Memory: bytes Warp allocated for a differentiable
100-substep frame (stored particle states + grid + gradients), and on CPU the process's peak RSS growth.
Floor: a streaming copy (numpy, one core, best of several) of as many bytes as one substep must move at
least: the particle state read and written (x, v, C, F in and out, μ and λ in: 200 bytes a particle) and the
grid arrays of the active blocks (P2G copies, drivers, velocities), measured in the same run; `floor_ratio`
is the forward substep over that copy (the issue's target: within 3×).
Prints a table and writes bench/results/mpm.json.

    .venv/bin/python bench/mpm.py [--quick] [--device cuda:0]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
CONFIGS = [(20_000, 64), (100_000, 100)]
DT = 4e-4
TARGET_MS = 10.0  # compared with the median block
BLOCKS = 6
TARGET_MB = 400.0
TARGET_FLOOR_RATIO = 3.0


def _scene(n_particles: int, grid: int, seed: int = 0):
    """Positions (N, 3), velocities (N, 3), dx: a ball of N particles at 8 per cell, in a unit-wide grid."""
    rng = np.random.default_rng(seed)
    dx = 1.0 / grid
    radius = (3 * (n_particles / 8) / (4 * np.pi)) ** (1 / 3) * dx
    d = rng.normal(size=(n_particles, 3))
    x = 0.5 + d / np.linalg.norm(d, axis=1, keepdims=True) * radius * rng.uniform(0, 1, (n_particles, 1)) ** (1 / 3)
    r = x - 0.5
    v = np.cross([0.0, 2.0, 0.5], r) + 0.5 * r[:, [1, 2, 0]]  # spin plus shear, m/s
    return x.astype(np.float32), v.astype(np.float32), dx, radius


def _solver(n: int, grid: int, sparse: bool, requires_grad: bool, device: str | None, threads: int | None = None):
    import warp as wp

    from simcore.mpm.materials import lame
    from simcore.mpm.solver import MPMSolver

    x, v, dx, radius = _scene(n, grid)
    vol = (4 / 3 * np.pi * radius**3) / n
    solver = MPMSolver(n, grid, dx, 1000.0 * vol, vol, device=device, sparse=sparse, gravity=(0, -9.8, 0),
                       requires_grad=requires_grad, threads=threads)
    mu, lam = lame(4e4, 0.4)
    mu = wp.full(n, float(mu), dtype=float, device=solver.device, requires_grad=requires_grad)
    lam = wp.full(n, float(lam), dtype=float, device=solver.device, requires_grad=requires_grad)
    state = solver.new_state(x, requires_grad=requires_grad)
    state.v.assign(v)
    dp = wp.array(np.array([[0.5, 0.5, 0.5], [0.5 + radius / 2, 0.5, 0.5]], np.float32), dtype=wp.vec3, device=solver.device)
    dv = wp.array(np.array([[0.0, 0.3, 0.0], [0.0, 0.3, 0.0]], np.float32), dtype=wp.vec3, device=solver.device,
                  requires_grad=requires_grad)
    return solver, state, mu, lam, dp, dv


def _allocated(*objs) -> int:
    """Bytes of Warp arrays (and their gradients) reachable from solver / states / lists."""
    import warp as wp

    seen, total = set(), 0

    def visit(a) -> None:
        nonlocal total
        if isinstance(a, wp.array) and id(a) not in seen:
            seen.add(id(a))
            total += a.capacity
            if a.grad is not None:
                visit(a.grad)
        elif isinstance(a, (list, tuple)):
            for b in a:
                visit(b)
        elif hasattr(a, "__dict__") and not isinstance(a, type):
            for b in vars(a).values():
                if isinstance(b, (wp.array, list, tuple)) or hasattr(b, "arrays"):
                    visit(b)

    for o in objs:
        visit(o)
    return total


def measure(n: int, grid: int, sparse: bool, substeps: int, backward_substeps: int, device: str | None,
            threads: int | None = None) -> dict:
    import warp as wp

    from simcore.mpm.solver import SubstepInputs

    solver, a, mu, lam, dp, dv = _solver(n, grid, sparse, False, device, threads)
    b = solver.new_state()
    inp = SubstepInputs(mu, lam, (0.0, 0.0, 0.0), DT, dp, dv)
    for _ in range(5):  # warm-up: compile, caches, F away from identity
        solver.substep(a, b, inp)
        a, b = b, a
    wp.synchronize_device(solver.device)
    blocks = []  # this VM's neighbours steal time in bursts: time blocks of substeps, report median and min
    for _ in range(BLOCKS):
        t = time.perf_counter()
        for _ in range(substeps):
            solver.substep(a, b, inp)
            a, b = b, a
        wp.synchronize_device(solver.device)
        blocks.append((time.perf_counter() - t) / substeps)
    fwd = float(np.median(blocks))
    out = {"particles": n, "grid": grid, "variant": "sparse" if sparse else "dense", "device": solver.device,
           "threads": solver.threads,
           "active_blocks": solver.active_blocks if sparse else None, "total_blocks": (grid // 4) ** 3,
           "forward_ms": round(1e3 * fwd, 3), "forward_ms_min": round(1e3 * min(blocks), 3),
           "forward_particle_substeps_per_s": round(n / fwd)}
    nodes = solver.active_blocks * 64 if sparse else grid**3
    floor, bandwidth = floor_ms(n, nodes, solver.threads)
    out.update({"floor_ms": round(floor, 4), "copy_GB_s": round(bandwidth, 2), "floor_ratio": round(1e3 * fwd / floor, 1)})

    if backward_substeps:
        gs, s_in, mu_g, lam_g, dp_g, dv_g = _solver(n, grid, sparse, True, device)
        s_out = gs.new_state(requires_grad=True)
        s_out.x.grad.fill_(1.0)
        ginp = SubstepInputs(mu_g, lam_g, (0.0, 0.0, 0.0), DT, dp_g, dv_g)
        gs.backward_substep(s_in, s_out, ginp)  # compile the adjoint
        wp.synchronize_device(gs.device)
        t = time.perf_counter()
        for _ in range(backward_substeps):
            s_in.zero_grad()
            gs.backward_substep(s_in, s_out, ginp)
        wp.synchronize_device(gs.device)
        bwd = (time.perf_counter() - t) / backward_substeps
        out.update({"backward_ms": round(1e3 * bwd, 3), "backward_particle_substeps_per_s": round(n / bwd)})
    return out


FLOOR_REPEATS = 20
PARTICLE_BYTES = 2 * 96 + 8  # x, v, C, F read and written, μ and λ read
NODE_BYTES = 16 + 16 + 12  # P2G momentum + mass, driver velocity + weight, grid velocity


def floor_ms(n: int, nodes: int, copies: int) -> tuple[float, float]:
    """(ms, GB/s) of a streaming copy of the bytes one substep moves at least (see the module docstring).

    nodes: active grid nodes; copies: P2G grid copies (one per thread).
    """
    size = n * PARTICLE_BYTES + nodes * (NODE_BYTES + 16 * (copies - 1))
    src = np.ones(size // 4, np.float32)
    dst = np.empty_like(src)
    best = np.inf
    for _ in range(FLOOR_REPEATS):
        t = time.perf_counter()
        np.copyto(dst, src)
        best = min(best, time.perf_counter() - t)
    return 1e3 * best, 2 * size / best / 1e9  # read + write


def frame_memory(n: int, grid: int, device: str | None) -> dict:
    """Forward + backward of one differentiable 100-substep frame: allocated bytes and peak RSS growth."""
    import warp as wp

    from simcore.mpm.simulate import DeviceDrive, DifferentiableRollout, FramePlan

    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB, after warp and the kernels are loaded
    solver, start, mu, lam, dp, dv = _solver(n, grid, True, True, device)
    steps = 100
    plan = FramePlan(DT, np.zeros((steps, 3)), np.tile(dp.numpy()[None], (steps, 1, 1)), np.tile(dv.numpy()[None], (steps, 1, 1)))
    drives = [DeviceDrive(plan, solver.device, requires_grad=True)]
    rollout = DifferentiableRollout(solver, mu, lam, steps)
    t = time.perf_counter()
    x = rollout.forward(start, drives)[0]
    rollout.backward(drives, {0: np.ones_like(x)})
    wp.synchronize_device(solver.device)
    seconds = time.perf_counter() - t
    allocated = _allocated(solver, rollout, mu, lam, start, drives)
    rss = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0) / 1024  # KiB on Linux → MiB
    return {"particles": n, "grid": grid, "substeps": steps, "fwd_bwd_seconds": round(seconds, 2),
            "allocated_MB": round(allocated / 2**20, 1), "peak_rss_growth_MB": round(rss, 1)}


def _cpu_model() -> str:
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return platform.processor()
    return next((line.split(":", 1)[1].strip() for line in lines if line.startswith("model name")), platform.processor())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer substeps (CI smoke run)")
    parser.add_argument("--device", default=None, help="warp device (default: CUDA when present, else cpu)")
    parser.add_argument("--out", type=Path, default=REPO / "bench" / "results" / "mpm.json")
    args = parser.parse_args()
    from simcore.mpm.solver import warp_device

    device = warp_device(args.device)
    memory = frame_memory(20_000, 64, device)  # first, so the process's peak RSS growth is this run's alone
    print(f"fwd+bwd 100-substep frame at 20k/64³: {memory['allocated_MB']} MB allocated, "
          f"peak RSS +{memory['peak_rss_growth_MB']} MB, {memory['fwd_bwd_seconds']} s", flush=True)
    rows = []
    for n, grid in CONFIGS:
        small = n <= 20_000
        # sparse on every core (the product), the same on one core, and the dense grid pass (the reference)
        for sparse, threads in ((True, None), (True, 1), (False, None)):
            steps = (4 if args.quick else 10) if small else (2 if args.quick else 4)
            back = (3 if args.quick else 10) if small else (2 if args.quick else 5)
            rows.append(measure(n, grid, sparse, steps, back if threads is None else 0, device, threads))
            r = rows[-1]
            bwd = f"{r['backward_ms']:8.2f}" if "backward_ms" in r else "       -"
            print(f"{r['variant']:>6} {r['threads']:>2} thr {n:>7} {grid:>4}³  "
                  f"fwd {r['forward_ms']:8.2f} ms (min {r['forward_ms_min']:6.2f})  floor {r['floor_ms']:7.3f} ms "
                  f"({r['copy_GB_s']:5.1f} GB/s) ×{r['floor_ratio']:6.1f}  bwd {bwd} ms  "
                  f"{r['forward_particle_substeps_per_s'] / 1e6:6.2f} M p·substep/s  active blocks {r['active_blocks'] or 'all'}/{r['total_blocks']}",
                  flush=True)
    sparse20 = rows[0]  # 20k, sparse, every core: what the refine stage runs
    result = {
        "machine": {"platform": platform.platform(), "cpu": _cpu_model(), "cores": os.cpu_count(), "device": device},
        "dt_s": DT, "rows": rows, "frame_memory": memory,
        "load_average": os.getloadavg(),
        "targets": {"forward_ms_20k_64": TARGET_MS, "fwd_bwd_MB_per_frame_20k": TARGET_MB, "floor_ratio": TARGET_FLOOR_RATIO},
        "meets": {"forward_ms_20k_64": sparse20["forward_ms"] <= TARGET_MS,
                  "floor_ratio_20k_64": sparse20["floor_ratio"] <= TARGET_FLOOR_RATIO,
                  "fwd_bwd_MB_per_frame_20k": memory["allocated_MB"] <= TARGET_MB},
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()

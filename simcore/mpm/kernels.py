"""Warp kernels of the MLS-MPM substep (quadratic B-splines, APIC, fixed-corotated), sparse over 4³ blocks.

Grid layout: n³ nodes, flat index (i * n + j) * n + k, node (i, j, k) at `origin + (i, j, k) * dx`. Blocks of
BLOCK³ nodes are marked by the particles and drivers that touch them, compacted into a list, and only those
blocks are updated and cleared, so the per-substep grid cost follows the body's volume, not the box.
All kernels are differentiable except the block bookkeeping (integer only). Only this module and the solver
import warp (loaded lazily by the worker).
"""

from __future__ import annotations

import warp as wp

wp.config.quiet = True
wp.set_module_options({"optimization_level": 3})  # CPU default is -O2; these few hot kernels are worth -O3

BLOCK = 4  # nodes per block edge; n must be a multiple of it
J_MIN = 0.05  # det F clamp: below this (or non-finite) the F update is rejected and counted
J_MAX = 20.0


@wp.func
def polar_rotation(F: wp.mat33) -> wp.mat33:
    """Rotation R of the polar decomposition F = R S (det F > 0), by determinant-scaled Newton iterations.

    Chosen over wp.svd3: about 3x cheaper on CPU and ~1e-7 accurate where svd3's rotation can be 1e-2 off.
    Each step takes X⁻ᵀ as X's cofactor matrix over det X (the determinant from its first row, one pass for
    both), and skips the scaling's cube root while det X is within 1 % of 1, where the scale is within
    0.4 % of 1 and the unscaled step converges as fast (bench/mpm.py: p2g's largest cost).
    """
    X = F
    for _ in range(10):
        r0 = wp.vec3(X[0, 0], X[0, 1], X[0, 2])
        r1 = wp.vec3(X[1, 0], X[1, 1], X[1, 2])
        r2 = wp.vec3(X[2, 0], X[2, 1], X[2, 2])
        c0 = wp.cross(r1, r2)
        d = wp.dot(r0, c0)
        if wp.abs(d) < 1.0e-12:
            break
        g = 1.0
        if wp.abs(d - 1.0) > 0.01:
            g = wp.pow(wp.abs(d), -1.0 / 3.0)
        Y = 0.5 * (g * X + (1.0 / (g * d)) * wp.matrix_from_rows(c0, wp.cross(r2, r0), wp.cross(r0, r1)))
        e = Y - X
        X = Y
        if wp.ddot(e, e) < 1.0e-8:  # a step under 1e-4: Newton's quadratic rate leaves ~1e-8, below float32 rounding
            break
    return X


@wp.func_grad(polar_rotation)
def adj_polar_rotation(F: wp.mat33, adj_ret: wp.mat33):
    # R^T dR = [w]x with w = (tr(S) I - S)^-1 axial(R^T dF - dF^T R), so adj_F = R [c]x, c = (tr(S) I - S)^-1 a,
    # a = axial(R^T adj_R - its transpose): finite at F = I, unlike an SVD adjoint with 1/(s_i² - s_j²) terms.
    R = polar_rotation(F)
    S = wp.transpose(R) * F
    S = 0.5 * (S + wp.transpose(S))
    M = wp.identity(n=3, dtype=float) * wp.trace(S) - S
    A = wp.transpose(R) * adj_ret
    a = wp.vec3(A[2, 1] - A[1, 2], A[0, 2] - A[2, 0], A[1, 0] - A[0, 1])
    c = wp.inverse(M) * a
    wp.adjoint[F] += R * wp.skew(c)


@wp.func
def node_index(i: int, j: int, k: int, n: int) -> int:
    return (i * n + j) * n + k


@wp.func
def stencil_base(x: wp.vec3, origin: wp.vec3, inv_dx: float, n: int) -> wp.vec3i:
    """Lowest node of the 3³ quadratic B-spline stencil, clamped so the stencil stays in the grid."""
    g = (x - origin) * inv_dx
    bi = wp.clamp(int(wp.floor(g[0] - 0.5)), 0, n - 3)
    bj = wp.clamp(int(wp.floor(g[1] - 0.5)), 0, n - 3)
    bk = wp.clamp(int(wp.floor(g[2] - 0.5)), 0, n - 3)
    return wp.vec3i(bi, bj, bk)


@wp.func
def stencil_fraction(x: wp.vec3, origin: wp.vec3, inv_dx: float, b: wp.vec3i) -> wp.vec3:
    """Position of x relative to the stencil's lowest node, in cells (each component in [0.5, 1.5) inside the grid)."""
    return (x - origin) * inv_dx - wp.vec3(float(b[0]), float(b[1]), float(b[2]))


@wp.func
def bspline_rows(fx: wp.vec3) -> wp.mat33:
    """Row a: quadratic B-spline weights of the nodes at offsets 0, 1, 2 along axis a; node weight = W[0,i] W[1,j] W[2,k]."""
    out = wp.mat33()
    for a in range(3):
        f = fx[a]
        out[a, 0] = 0.5 * (1.5 - f) * (1.5 - f)
        out[a, 1] = 0.75 - (f - 1.0) * (f - 1.0)
        out[a, 2] = 0.5 * (f - 0.5) * (f - 0.5)
    return out


@wp.kernel
def mark_blocks(x: wp.array(dtype=wp.vec3), origin: wp.vec3, inv_dx: float, n: int, flags: wp.array(dtype=wp.int32)):
    """Flag every block a point's 3³ stencil touches (at most 2 blocks per axis)."""
    p = wp.tid()
    b = stencil_base(x[p], origin, inv_dx, n)
    nb = n // BLOCK
    for di in range(2):
        for dj in range(2):
            for dk in range(2):
                bi = (b[0] + 2 * di) // BLOCK
                bj = (b[1] + 2 * dj) // BLOCK
                bk = (b[2] + 2 * dk) // BLOCK
                flags[(bi * nb + bj) * nb + bk] = 1


@wp.kernel
def compact_blocks(flags: wp.array(dtype=wp.int32), active: wp.array(dtype=wp.int32), count: wp.array(dtype=wp.int32)):
    b = wp.tid()
    if flags[b] != 0:
        slot = wp.atomic_add(count, 0, 1)
        active[slot] = b


@wp.func
def block_node(active: wp.array(dtype=wp.int32), t: int, n: int) -> int:
    """Flat node index of thread t when threads enumerate BLOCK³ nodes of each active block."""
    nb = n // BLOCK
    b = active[t // (BLOCK * BLOCK * BLOCK)]
    local = t % (BLOCK * BLOCK * BLOCK)
    bi = b // (nb * nb)
    bj = (b // nb) % nb
    bk = b % nb
    i = bi * BLOCK + local // (BLOCK * BLOCK)
    j = bj * BLOCK + (local // BLOCK) % BLOCK
    k = bk * BLOCK + local % BLOCK
    return node_index(i, j, k, n)


@wp.kernel
def p2g(
    x: wp.array(dtype=wp.vec3),
    v: wp.array(dtype=wp.vec3),
    C: wp.array(dtype=wp.mat33),
    F: wp.array(dtype=wp.mat33),
    mu: wp.array(dtype=float),
    lam: wp.array(dtype=float),
    mass: float,
    vol: float,
    origin: wp.vec3,
    dx: float,
    dt: float,
    n: int,
    offset: int,
    copy: int,
    grid_mv: wp.array(dtype=wp.vec3),
    grid_m: wp.array(dtype=float),
):
    """Eq. 7: scatter APIC momentum plus the fixed-corotated stress impulse to the 3³ stencil.

    Thread t handles particle `offset + t` and scatters into grid copy `copy` (nodes copy·n³ … (copy+1)·n³ - 1),
    so concurrent CPU launches over disjoint particle ranges never add into the same memory.
    """
    p = wp.tid() + offset
    base = copy * n * n * n
    inv_dx = 1.0 / dx
    b = stencil_base(x[p], origin, inv_dx, n)
    fx = stencil_fraction(x[p], origin, inv_dx, b)
    W = bspline_rows(fx)
    Fp = F[p]
    R = polar_rotation(Fp)
    J = wp.determinant(Fp)
    kirchhoff = 2.0 * mu[p] * (Fp - R) * wp.transpose(Fp) + wp.identity(n=3, dtype=float) * (lam[p] * J * (J - 1.0))
    affine = kirchhoff * (-dt * vol * 4.0 * inv_dx * inv_dx) + C[p] * mass
    # mv + affine·dpos with dpos = ((i, j, k) - fx)·dx, split per axis so the stencil loop only adds vectors.
    ax = wp.vec3(affine[0, 0], affine[1, 0], affine[2, 0]) * dx
    ay = wp.vec3(affine[0, 1], affine[1, 1], affine[2, 1]) * dx
    az = wp.vec3(affine[0, 2], affine[1, 2], affine[2, 2]) * dx
    m0 = v[p] * mass - affine * fx * dx
    for i in range(3):
        mi = m0 + ax * float(i)
        for j in range(3):
            mj = mi + ay * float(j)
            wij = W[0, i] * W[1, j]
            for k in range(3):
                w = wij * W[2, k]
                node = base + node_index(b[0] + i, b[1] + j, b[2] + k, n)
                wp.atomic_add(grid_mv, node, w * (mj + az * float(k)))
                wp.atomic_add(grid_m, node, w * mass)


@wp.kernel
def drivers_to_grid(
    dp: wp.array(dtype=wp.vec3),
    dv: wp.array(dtype=wp.vec3),
    origin: wp.vec3,
    dx: float,
    n: int,
    drv_v: wp.array(dtype=wp.vec3),
    drv_w: wp.array(dtype=float),
):
    """Splat each driving point's velocity onto its control region (its own 3³ B-spline stencil)."""
    d = wp.tid()
    inv_dx = 1.0 / dx
    b = stencil_base(dp[d], origin, inv_dx, n)
    W = bspline_rows(stencil_fraction(dp[d], origin, inv_dx, b))
    for i in range(3):
        for j in range(3):
            for k in range(3):
                w = W[0, i] * W[1, j] * W[2, k]
                node = node_index(b[0] + i, b[1] + j, b[2] + k, n)
                wp.atomic_add(drv_v, node, w * dv[d])
                wp.atomic_add(drv_w, node, w)


@wp.kernel
def sum_copies(active: wp.array(dtype=wp.int32), n: int, dense: int, copies: int,
               grid_mv: wp.array(dtype=wp.vec3), grid_m: wp.array(dtype=float)):
    """Add P2G copies 1..copies-1 into copy 0 (all nodes when dense, else the active blocks'). Forward only."""
    node = wp.tid()
    if dense == 0:
        node = block_node(active, node, n)
    for c in range(1, copies):
        grid_mv[node] = grid_mv[node] + grid_mv[c * n * n * n + node]
        grid_m[node] = grid_m[node] + grid_m[c * n * n * n + node]


@wp.func
def update_node(
    node: int,
    n: int,
    grid_mv: wp.array(dtype=wp.vec3),
    grid_m: wp.array(dtype=float),
    drv_v: wp.array(dtype=wp.vec3),
    drv_w: wp.array(dtype=float),
    gravity: wp.vec3,
    dt: float,
    drive_gain: float,
    bound: int,
    grid_v: wp.array(dtype=wp.vec3),
):
    m = grid_m[node]
    vel = wp.vec3(0.0)
    if m > 0.0:
        vel = grid_mv[node] / m + gravity * dt
    dw = drv_w[node]
    if dw > 0.0:
        # Driven nodes blend toward the drivers' weighted mean velocity; fully driven near a driver's centre.
        a = wp.min(dw * drive_gain, 1.0)
        vel = vel * (1.0 - a) + drv_v[node] * (a / dw)
    i = node // (n * n)
    j = (node // n) % n
    k = node % n
    # Sticky walls: no velocity into the boundary band (the grid follows the body, so rarely reached).
    if (i < bound and vel[0] < 0.0) or (i >= n - bound and vel[0] > 0.0):
        vel = wp.vec3(0.0, vel[1], vel[2])
    if (j < bound and vel[1] < 0.0) or (j >= n - bound and vel[1] > 0.0):
        vel = wp.vec3(vel[0], 0.0, vel[2])
    if (k < bound and vel[2] < 0.0) or (k >= n - bound and vel[2] > 0.0):
        vel = wp.vec3(vel[0], vel[1], 0.0)
    grid_v[node] = vel


@wp.kernel
def grid_update_sparse(
    active: wp.array(dtype=wp.int32),
    n: int,
    grid_mv: wp.array(dtype=wp.vec3),
    grid_m: wp.array(dtype=float),
    drv_v: wp.array(dtype=wp.vec3),
    drv_w: wp.array(dtype=float),
    gravity: wp.vec3,
    dt: float,
    drive_gain: float,
    bound: int,
    grid_v: wp.array(dtype=wp.vec3),
):
    node = block_node(active, wp.tid(), n)
    update_node(node, n, grid_mv, grid_m, drv_v, drv_w, gravity, dt, drive_gain, bound, grid_v)


@wp.kernel
def grid_update_dense(
    n: int,
    grid_mv: wp.array(dtype=wp.vec3),
    grid_m: wp.array(dtype=float),
    drv_v: wp.array(dtype=wp.vec3),
    drv_w: wp.array(dtype=float),
    gravity: wp.vec3,
    dt: float,
    drive_gain: float,
    bound: int,
    grid_v: wp.array(dtype=wp.vec3),
):
    update_node(wp.tid(), n, grid_mv, grid_m, drv_v, drv_w, gravity, dt, drive_gain, bound, grid_v)


@wp.kernel
def g2p(
    x: wp.array(dtype=wp.vec3),
    F: wp.array(dtype=wp.mat33),
    grid_v: wp.array(dtype=wp.vec3),
    origin: wp.vec3,
    dx: float,
    dt: float,
    n: int,
    v_max: float,
    offset: int,
    copy: int,
    x_out: wp.array(dtype=wp.vec3),
    v_out: wp.array(dtype=wp.vec3),
    C_out: wp.array(dtype=wp.mat33),
    F_out: wp.array(dtype=wp.mat33),
    clamps: wp.array(dtype=wp.int32),
):
    """Eqs. 8-9: gather velocity and APIC affine C, advect, update F; clamp |v| and det F, counting clamps.

    Thread t handles particle `offset + t`; clamps are counted in clamps[2·copy] (|v|) and [2·copy + 1] (det F).
    """
    p = wp.tid() + offset
    inv_dx = 1.0 / dx
    b = stencil_base(x[p], origin, inv_dx, n)
    fx = stencil_fraction(x[p], origin, inv_dx, b)
    W = bspline_rows(fx)
    # C = 4/dx² Σ w v ⊗ (node − x) = 4/dx (Σ w v ⊗ (i, j, k) − vel ⊗ fx): the stencil loop adds vectors only
    vel = wp.vec3(0.0)
    bi = wp.vec3(0.0)
    bj = wp.vec3(0.0)
    bk = wp.vec3(0.0)
    for i in range(3):
        for j in range(3):
            wij = W[0, i] * W[1, j]
            for k in range(3):
                wv = grid_v[node_index(b[0] + i, b[1] + j, b[2] + k, n)] * (wij * W[2, k])
                vel = vel + wv
                bi = bi + wv * float(i)
                bj = bj + wv * float(j)
                bk = bk + wv * float(k)
    Cn = (wp.matrix_from_cols(bi, bj, bk) - wp.outer(vel, fx)) * (4.0 * inv_dx)
    speed = wp.length(vel)
    if speed > v_max:
        vel = vel * (v_max / speed)
        wp.atomic_add(clamps, 2 * copy, 1)
    Fn = (wp.identity(n=3, dtype=float) + Cn * dt) * F[p]
    J = wp.determinant(Fn)
    if not (J > J_MIN and J < J_MAX):  # also catches NaN
        Fn = F[p]
        Cn = wp.mat33(0.0)
        wp.atomic_add(clamps, 2 * copy + 1, 1)
    x_out[p] = x[p] + vel * dt
    v_out[p] = vel
    C_out[p] = Cn
    F_out[p] = Fn


@wp.kernel
def tether(
    rest: wp.array(dtype=wp.vec3),
    joints: wp.array(dtype=wp.vec4i),
    weights: wp.array(dtype=wp.vec4),
    skin: wp.array(dtype=wp.mat44),
    prev: int,
    cur: int,
    dt: float,
    radius: wp.array(dtype=float),
    x: wp.array(dtype=wp.vec3),
    v: wp.array(dtype=wp.vec3),
    count: wp.array(dtype=wp.int32),
):
    """Max-distance constraint: keep each particle within its `radius` of its skinned (LBS) position.

    skin holds joint skinning matrices (column-vector 4x4) per substep boundary; `prev` and `cur` are the flat
    offsets of the substep's start and end sets. A particle past the radius is put back on the sphere and loses
    the outward part of its velocity relative to the skinned target's. Forward only (refinement, not the fit).
    """
    p = wp.tid()
    r = rest[p]
    target = wp.vec3(0.0)
    before = wp.vec3(0.0)
    for i in range(4):
        target = target + weights[p][i] * wp.transform_point(skin[cur + joints[p][i]], r)
        before = before + weights[p][i] * wp.transform_point(skin[prev + joints[p][i]], r)
    d = x[p] - target
    length = wp.length(d)
    if length > radius[p]:
        normal = d / length
        x[p] = target + normal * radius[p]
        outward = wp.dot(v[p] - (target - before) / dt, normal)
        if outward > 0.0:
            v[p] = v[p] - normal * outward
        wp.atomic_add(count, 0, 1)


@wp.kernel
def clear_blocks(
    active: wp.array(dtype=wp.int32),
    n: int,
    copies: int,
    grid_mv: wp.array(dtype=wp.vec3),
    grid_m: wp.array(dtype=float),
    drv_v: wp.array(dtype=wp.vec3),
    drv_w: wp.array(dtype=float),
    grid_v: wp.array(dtype=wp.vec3),
):
    """Zero the active blocks' nodes (every P2G copy) so the next substep starts from an empty grid."""
    node = block_node(active, wp.tid(), n)
    for c in range(copies):
        grid_mv[c * n * n * n + node] = wp.vec3(0.0)
        grid_m[c * n * n * n + node] = 0.0
    drv_v[node] = wp.vec3(0.0)
    drv_w[node] = 0.0
    grid_v[node] = wp.vec3(0.0)


@wp.kernel
def clear_flags(active: wp.array(dtype=wp.int32), flags: wp.array(dtype=wp.int32)):
    flags[active[wp.tid()]] = 0


@wp.kernel
def det_deviation(F: wp.array(dtype=wp.mat33), out: wp.array(dtype=float)):
    """Sum over particles of |det F - 1| (divide by N on the host)."""
    wp.atomic_add(out, 0, wp.abs(wp.determinant(F[wp.tid()]) - 1.0))

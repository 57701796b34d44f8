"""Procedural creatures as training characters: random body plans the corpus is thin on or lacks (quadrupeds,
insects, spiders, birds, snakes, fish, dragons, long-tailed bipeds), each built as one closed surface around
its skeleton.

Every bone carries a tapered tube; wings and fins are flat (an elliptical section). The union of the tubes is
meshed by marching cubes on a voxel grid and decimated, so the surface is one skin as a sculpted character's is,
not a soup of parts. A vertex is weighted to the joints whose tubes it lies on, blended where tubes meet; a bone
binds to its start joint (the joint that turns it), so end joints carry no weight and are not skin joints, as in
artists' rigs. Plans and proportions are drawn from the generator passed in (deterministic by its seed).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from typing import NamedTuple

import numpy as np
import scipy.sparse as sp
import trimesh
from skimage.measure import marching_cubes

from simcore.skeleton.types import Skeleton
from simcore.skinning.proxy import simplified
from simcore.training.skin_samples import Character

CATEGORY = {"quadruped": "quadruped", "dragon": "quadruped", "bird": "bird"}  # every other plan is "other"
GRID = 88  # voxels along the creature's longest side for marching cubes
TARGET_VERTICES = 4000  # the meshed surface is decimated to about this many vertices
BLEND = 0.15  # falloff of a tube's weight with its implicit value (0 on its surface, 1 at twice its radius)
MAX_INFLUENCES = 4
UP = (0.0, 1.0, 0.0)  # a flat tube's thin axis: wings, a bird's tail and side fins lie level
SIDEWAYS = (1.0, 0.0, 0.0)  # upright fins
NAME_PREFIX = "creature_"
FLOOR = 1.5  # voxels: the thinnest tube's radius (and flat half-thickness) on the meshing grid


@dataclass
class Tube:
    """A bone's tube: joints a → b, radii at each end, and a flat section (`thin` axis squashed by `ratio`)."""

    a: int
    b: int
    ra: float
    rb: float
    thin: np.ndarray
    ratio: float


@dataclass
class Body:
    """A skeleton under construction (metres, +Y up, facing +Z) and its tubes."""

    positions: list[np.ndarray] = field(default_factory=list)
    parents: list[int] = field(default_factory=list)
    names: list[str] = field(default_factory=list)
    tubes: list[Tube] = field(default_factory=list)

    def chain(self, name: str, points: list, parent: int, radii: list[float], *, thin: tuple = UP,
              ratio: float = 1.0) -> list[int]:
        """Joints `name_01`, `name_02`, … at `points`, the first a child of `parent` (-1: a root); a tube runs
        from each joint's parent to it, `radii[k]` at joint k (one more radius than points when `parent` ≥ 0:
        the first is the parent's end of the first tube)."""
        out: list[int] = []
        offset = 1 if parent >= 0 else 0
        for k, p in enumerate(points):
            self.positions.append(np.asarray(p, float))
            self.parents.append(parent if k == 0 else out[-1])
            self.names.append(f"{name}_{k + 1:02d}" if len(points) > 1 else name)
            joint = len(self.positions) - 1
            if self.parents[-1] >= 0:
                self.tubes.append(Tube(self.parents[-1], joint, radii[k + offset - 1], radii[k + offset],
                                       np.asarray(thin, float), ratio))
            out.append(joint)
        return out

    def skeleton(self) -> Skeleton:
        return Skeleton(np.array(self.positions), np.array(self.parents), list(self.names))


def tube_field(tube: Tube, positions: np.ndarray, x: np.ndarray, floor: float) -> np.ndarray:
    """(N,) implicit value of the tube at points x (N, 3): negative inside, 0 on its surface, about d/r − 1
    outside at distance d from its axis; no radius (nor flat half-thickness) below `floor`, so the voxel grid
    that meshes the union keeps every tube."""
    a, b = positions[tube.a], positions[tube.b]
    axis = b - a
    length = max(float(np.linalg.norm(axis)), 1e-9)
    t = axis / length
    rel = x - a
    along = rel @ t
    s = np.clip(along / length, 0.0, 1.0)
    beyond = along - s * length
    perp = rel - along[:, None] * t
    thin = tube.thin - (tube.thin @ t) * t
    thin = thin / n if (n := float(np.linalg.norm(thin))) > 1e-6 else np.zeros(3)
    across = perp @ thin
    wide = np.sqrt(np.maximum((perp * perp).sum(1) - across**2, 0.0))
    r = np.maximum(tube.ra + (tube.rb - tube.ra) * s, floor)
    flat = np.maximum(r * tube.ratio, floor)
    return np.sqrt((wide / r) ** 2 + (across / flat) ** 2 + (beyond / r) ** 2) - 1.0


class Grid(NamedTuple):
    """The voxel grid that meshes a body: low and high corners (3,), voxel size, and the thinnest tube it keeps."""

    low: np.ndarray
    high: np.ndarray
    step: float

    @property
    def floor(self) -> float:
        return FLOOR * self.step


def meshing_grid(body: Body, voxels: int = GRID) -> Grid:
    """`voxels` voxels along the body's longest side, with room for its widest tube."""
    positions = np.array(body.positions)
    reach = max(max(t.ra, t.rb) for t in body.tubes)
    low, high = positions.min(0) - 1.5 * reach, positions.max(0) + 1.5 * reach
    return Grid(low, high, float((high - low).max()) / voxels)


def surface(body: Body, grid: Grid) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) of the union of the body's tubes on `grid`, outward-facing, about TARGET_VERTICES
    vertices."""
    positions = np.array(body.positions)
    axes = [np.arange(lo, hi + grid.step, grid.step) for lo, hi in zip(grid.low, grid.high)]
    x = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    value = np.full(len(x), np.inf)
    for tube in body.tubes:
        np.minimum(value, tube_field(tube, positions, x, grid.floor), out=value)
    verts, faces, _, _ = marching_cubes(-value.reshape([len(a) for a in axes]), 0.0, spacing=(grid.step,) * 3)
    mesh = trimesh.Trimesh(verts + grid.low, faces)
    mesh = max(mesh.split(only_watertight=False), key=lambda m: len(m.faces))  # drop specks marching cubes may leave
    if mesh.volume < 0:
        mesh.invert()
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces, np.int64)
    return simplified(v, f, TARGET_VERTICES) if len(v) > TARGET_VERTICES else (v, f)


def tube_weights(body: Body, vertices: np.ndarray, floor: float) -> sp.csr_matrix:
    """(V, J) rows summing to 1: each vertex on the start joints of the tubes nearest it (by implicit value, tubes
    no thinner than `floor` as meshed), blended over BLEND, at most MAX_INFLUENCES joints."""
    positions = np.array(body.positions)
    value = np.stack([tube_field(t, positions, vertices, floor) for t in body.tubes], 1)
    share = np.exp(-(value - value.min(1, keepdims=True)) / BLEND)
    owner = np.array([t.a for t in body.tubes])
    dense = np.zeros((len(vertices), len(positions)))
    np.add.at(dense.T, owner, share.T)
    cut = -np.sort(-dense, axis=1)[:, MAX_INFLUENCES - 1: MAX_INFLUENCES]
    dense = np.where((dense >= cut) & (dense > 0.02 * dense.max(1, keepdims=True)), dense, 0.0)
    return sp.csr_matrix(dense / dense.sum(1, keepdims=True))


def arc(start: np.ndarray, end: np.ndarray, count: int, lift: float = 0.0, sway: float = 0.0,
        waves: float = 1.0) -> list[np.ndarray]:
    """`count` points from just past `start` to `end` (start itself is the parent joint), bowed up by `lift` and
    sideways by `sway` (sinusoidal, `waves` half-periods)."""
    out = []
    for k in range(1, count + 1):
        u = k / count
        p = start + (end - start) * u
        out.append(p + np.array([sway * np.sin(np.pi * waves * u), lift * np.sin(np.pi * u), 0.0]))
    return out


def legs(body: Body, rng: np.random.Generator, at: int, name: str, spread: float, length: float, radius: float,
         kind: str, forward: float = 0.0) -> None:
    """A left/right pair of legs from joint `at`: `spread` out to each hip (and `forward` along the body), `length`
    to the ground below the hip (mammal: knee under the hip, foot forward; arthropod: knee raised out to the
    side, foot far out)."""
    root = body.positions[at]
    for side, s in (("L", 1.0), ("R", -1.0)):
        hip = root + np.array([s * spread, -0.2 * radius, forward])
        if kind == "arthropod":
            out = s * length * rng.uniform(0.5, 0.9)
            knee = hip + np.array([out * 0.5, length * rng.uniform(0.2, 0.5), 0.0])
            foot = np.array([hip[0] + out, 0.0, hip[2] + rng.uniform(-0.2, 0.2) * length])
            body.chain(f"{name}_{side}", [hip, knee, foot], at, [radius, radius, 0.8 * radius, 0.5 * radius])
        else:
            bend = rng.uniform(-0.15, 0.15) * length
            knee = np.array([hip[0], hip[1] * 0.5, hip[2] + bend])
            ankle = np.array([hip[0], hip[1] * 0.12, hip[2] - 0.5 * bend])
            toe = ankle + np.array([0.0, -hip[1] * 0.1, rng.uniform(0.1, 0.25) * length])
            body.chain(f"{name}_{side}", [hip, knee, ankle, toe], at,
                       [radius * 1.4, radius * 1.2, radius, 0.8 * radius, 0.6 * radius])


def wings(body: Body, rng: np.random.Generator, at: int, span: float, chord: float, width: float) -> None:
    """Flat wings from joint `at`, spread out sideways or folded back along the body."""
    root = body.positions[at]
    spread = rng.uniform() < 0.6
    for side, s in (("L", 1.0), ("R", -1.0)):
        shoulder = root + np.array([s * width, 0.1 * width, 0.0])
        if spread:
            points = [shoulder + np.array([s * span * u, span * rng.uniform(0.0, 0.15) * u, -span * 0.1 * u])
                      for u in (0.35, 0.7, 1.0)]
        else:
            points = [shoulder + np.array([s * 0.15 * span * u, 0.05 * span, -span * 0.6 * u]) for u in (0.35, 0.7, 1.0)]
        body.chain(f"wing_{side}", [shoulder, *points], at, [width * 0.5, chord * 0.6, chord, chord * 0.8, chord * 0.3],
                   ratio=rng.uniform(0.12, 0.25))


def trunk(body: Body, rng: np.random.Generator, length: float, height: float, count: int, girth: float,
          rise: float = 0.0) -> list[int]:
    """A spine from the pelvis (the root, at the rear) forward to the chest, `rise` higher at the front."""
    pelvis = np.array([0.0, height, -length / 2])
    points = [pelvis + np.array([0.0, rise * u + rng.uniform(-0.03, 0.03) * length, length * u])
              for u in np.linspace(0.0, 1.0, count)]
    radii = [girth * rng.uniform(0.85, 1.1) for _ in points]
    return body.chain("spine", points, -1, radii)


def neck_head(body: Body, rng: np.random.Generator, chest: int, length: float, up: float, head: float,
              neck_radius: float) -> None:
    """A neck of 1–3 joints forward and up from `chest`, then the head and its end joint."""
    base = body.positions[chest]
    count = int(rng.integers(1, 4))
    tip = base + np.array([0.0, up, length])
    neck = body.chain("neck", arc(base, tip, count), chest, [neck_radius] * (count + 1))
    end = tip + np.array([0.0, 0.1 * head, head * rng.uniform(1.2, 2.0)])
    body.chain("head", [tip + (end - tip) * 0.05, end], neck[-1], [neck_radius, head, head * 0.6])


def tail(body: Body, rng: np.random.Generator, pelvis: int, length: float, count: int, radius: float,
         droop: float, *, thin: tuple = UP, ratio: float = 1.0) -> None:
    """A tail of `count` joints back from `pelvis`, tapering, drooping by `droop`, swaying at random."""
    if count <= 0:
        return
    base = body.positions[pelvis]
    end = base + np.array([0.0, -droop, -length])
    points = arc(base, end, count, lift=rng.uniform(-0.1, 0.2) * length, sway=rng.uniform(-0.2, 0.2) * length)
    radii = list(np.linspace(radius, radius * 0.3, count + 1))
    body.chain("tail", points, pelvis, radii, thin=thin, ratio=ratio)


def four_legged(b: Body, rng: np.random.Generator, *, winged: bool) -> None:
    """A quadruped (a tail of 0–6 joints) or, `winged`, a dragon (wings and a tail of 4–6)."""
    u = rng.uniform
    length, girth = u(0.8, 1.6), u(0.12, 0.25)
    leg = u(0.35, 1.0) * length
    spine = trunk(b, rng, length, leg + girth * 0.5, int(rng.integers(3, 6)), girth)
    neck_head(b, rng, spine[-1], u(0.15, 0.5) * length, u(0.1, 0.5) * length, girth * u(0.6, 1.1), girth * 0.55)
    tail(b, rng, spine[0], u(0.3, 1.2) * length, int(rng.integers(4 if winged else 0, 7)), girth * 0.45, u(0.0, 0.4) * leg)
    for at, name in ((spine[-1], "leg_front"), (spine[0], "leg_back")):
        legs(b, rng, at, name, girth * 0.7, leg, girth * u(0.25, 0.4), "mammal")
    if winged:
        wings(b, rng, spine[-1], u(0.8, 1.5) * length, girth * u(1.0, 2.0), girth * 0.6)


def arthropod(b: Body, rng: np.random.Generator, *, pairs: int) -> None:
    """An insect (3 pairs of legs) or a spider (4): a three-joint body, one end swollen, legs from its middle."""
    u = rng.uniform
    length, girth = u(0.6, 1.2), u(0.1, 0.2)
    spine = trunk(b, rng, length, u(0.2, 0.5) * length, 3, girth)
    b.tubes[-1].rb *= u(1.0, 1.6)  # a thorax or abdomen larger than the rest
    neck_head(b, rng, spine[-1], 0.05 * length, 0.0, girth * u(0.6, 1.0), girth * 0.5)
    for k in range(pairs):
        forward = (k - (pairs - 1) / 2) * girth * 0.5
        legs(b, rng, spine[1], f"leg_{k + 1}", girth * 0.8, u(0.6, 1.2) * length, girth * u(0.15, 0.3), "arthropod",
             forward)


def two_legged(b: Body, rng: np.random.Generator, *, bird: bool) -> None:
    """A bird (wings, a short flat tail) or a raptor-like biped (a long tail, short arms), the body leaning up."""
    u = rng.uniform
    length, girth = u(0.5, 1.0), u(0.15, 0.28)
    leg = u(0.4, 1.0) * length
    spine = trunk(b, rng, length, leg + girth * 0.5, int(rng.integers(2, 5)), girth, rise=u(0.1, 0.5) * length)
    neck_head(b, rng, spine[-1], u(0.1, 0.4) * length, u(0.2, 0.6) * length, girth * u(0.5, 0.8), girth * 0.4)
    legs(b, rng, spine[0], "leg", girth * 0.5, leg, girth * u(0.15, 0.3), "mammal")
    if bird:
        wings(b, rng, spine[-1], u(0.8, 1.8) * length, girth * u(0.8, 1.6), girth * 0.6)
        tail(b, rng, spine[0], u(0.3, 0.6) * length, int(rng.integers(1, 3)), girth * 0.8, 0.1 * leg, ratio=0.3)
        return
    tail(b, rng, spine[0], u(0.8, 1.5) * length, int(rng.integers(3, 7)), girth * 0.6, u(0.0, 0.3) * leg)
    arm = u(0.2, 0.5) * length
    for side, s in (("L", 1.0), ("R", -1.0)):
        shoulder = b.positions[spine[-1]] + np.array([s * girth * 0.8, -girth * 0.2, girth * 0.2])
        points = [shoulder, shoulder + np.array([s * 0.1 * arm, -0.5 * arm, 0.3 * arm]),
                  shoulder + np.array([s * 0.1 * arm, -0.6 * arm, 0.9 * arm])]
        b.chain(f"arm_{side}", points, spine[-1], [girth * 0.5, girth * 0.25, girth * 0.2, girth * 0.12])


def snake(b: Body, rng: np.random.Generator) -> None:
    """A long winding body of 8–16 joints on the ground, thick from its middle forward, and a head."""
    u = rng.uniform
    length, girth = u(2.0, 4.0), u(0.04, 0.08)
    count = int(rng.integers(8, 17))
    start = np.array([0.0, girth * 4.0, -length / 2])
    points = [start] + arc(start, start + np.array([0.0, 0.0, length]), count - 1, sway=u(0.1, 0.3) * length,
                           waves=float(rng.integers(2, 5)))
    for p in points:
        p[1] = girth * 4.0
    radii = list(np.linspace(girth * 0.5, girth * 4.0, count // 2)) + [girth * 4.0] * (count - count // 2)
    spine = b.chain("spine", points, -1, radii)
    b.chain("head", [points[-1] + np.array([0.0, 0.0, girth * 6]), points[-1] + np.array([0.0, 0.0, girth * 14])],
            spine[-1], [girth * 4.0, girth * 4.5, girth * 2.5])


def fish(b: Body, rng: np.random.Generator) -> None:
    """A body swelling in the middle, a head, a flat upright tail fin, a dorsal fin and two flat side fins."""
    u = rng.uniform
    length, girth = u(0.6, 1.4), u(0.1, 0.22)
    spine = trunk(b, rng, length, u(0.5, 1.0), int(rng.integers(3, 7)), girth)
    for k, tube in enumerate(b.tubes):
        tube.ra *= 0.6 + 0.4 * np.sin(np.pi * (k + 0.5) / len(b.tubes))
        tube.rb *= 0.6 + 0.4 * np.sin(np.pi * (k + 1.0) / len(b.tubes))
    front = b.positions[spine[-1]]
    b.chain("head", [front + np.array([0.0, 0.0, girth * 0.3]), front + np.array([0.0, 0.0, girth * u(1.0, 2.0)])],
            spine[-1], [girth * 0.8, girth * 0.8, girth * 0.5])
    tail(b, rng, spine[0], u(0.2, 0.4) * length, 2, girth * 1.5, 0.0, thin=SIDEWAYS, ratio=0.12)
    mid = spine[len(spine) // 2]
    top = b.positions[mid] + np.array([0.0, girth * 0.8, 0.0])
    b.chain("fin_dorsal", [top, top + np.array([0.0, girth * 1.2, -0.1 * length])], mid,
            [girth * 0.6, girth * 0.6, girth * 0.3], thin=SIDEWAYS, ratio=0.15)
    for side, s in (("L", 1.0), ("R", -1.0)):
        base = front + np.array([s * girth * 0.8, -girth * 0.4, -girth * 0.3])
        b.chain(f"fin_{side}", [base, base + np.array([s * girth * 1.7, -girth * 0.2, -girth])], spine[-1],
                [girth * 0.5, girth * 0.5, girth * 0.3], ratio=0.15)


BUILDERS: dict[str, Callable[[Body, np.random.Generator], None]] = {
    "quadruped": partial(four_legged, winged=False), "insect": partial(arthropod, pairs=3),
    "spider": partial(arthropod, pairs=4), "bird": partial(two_legged, bird=True), "snake": snake, "fish": fish,
    "dragon": partial(four_legged, winged=True), "raptor": partial(two_legged, bird=False),
}
PLANS = tuple(BUILDERS)  # creature k has plan PLANS[k % len(PLANS)]


def creature_name(k: int) -> str:
    """The name of creature k (its plan is PLANS taken in turn)."""
    return f"{NAME_PREFIX}{PLANS[k % len(PLANS)]}_{k:04d}"


def creature_character(k: int, rng: np.random.Generator) -> Character:
    """Creature k (PLANS taken in turn) drawn from `rng`, meshed and weighted."""
    plan = PLANS[k % len(PLANS)]
    body = Body()
    BUILDERS[plan](body, rng)
    grid = meshing_grid(body)
    vertices, faces = surface(body, grid)
    return Character(creature_name(k), CATEGORY.get(plan, "other"), vertices, faces, body.skeleton(),
                     tube_weights(body, vertices, grid.floor))

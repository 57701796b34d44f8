"""How artists bind separate mesh parts: the data behind `simcore.skinning.parts`.

For every rigged .glb/.gltf in DIR (or the files DIR/MANIFEST.tsv lists for one split) made of several welded
surface parts, each part that carries weight is counted by its size class (a piece: bounding-box diagonal at
most MAX_PIECE of the whole mesh's, else large), by how many joints lie inside its bounding box (0, 1, 2 or more;
the joints a job keeping the rig skins to, its weightless ones left out) and by whether the artist bound it
rigidly (every vertex of the part on one and the same joint). The table gives, per class, the parts counted, the
share bound rigidly, and the share bound rigidly among the parts that lean at least RIGID_SHARE of their weight
mass on one joint: the rule's precision.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import scipy.sparse as sp

from simcore.evaluation.assets import rigged_assets
from simcore.geometry.parts import part_labels
from simcore.io.gltf_rig import weightless_joints
from simcore.skinning.parts import MAX_PIECE, RIGID_SHARE, part_figures, rigid_piece_vertices

HELD_CLASSES = ("0", "1", "2+")


@dataclass
class PartRow:
    """One separate part of one rig."""

    name: str
    category: str
    vertices: int
    size: float  # bounding-box diagonal / the whole mesh's
    held: int  # joints inside the part's bounding box
    share: float  # largest share of the part's weight mass on one joint
    rigid: bool  # every vertex on the same single joint

    @property
    def size_class(self) -> str:
        return "piece" if self.size <= MAX_PIECE else "large"

    @property
    def held_class(self) -> str:
        return HELD_CLASSES[min(self.held, 2)]


@dataclass
class PartStatistics:
    rows: list[PartRow] = field(default_factory=list)
    rigs: int = 0  # rigs read
    skipped: dict[str, str] = field(default_factory=dict)

    def table(self) -> list[dict[str, Any]]:
        """Per (size class, joints held): parts, rigs, share rigid, share rigid among parts leaning on one joint."""
        out = []
        for size in ("piece", "large"):
            for held in HELD_CLASSES:
                rows = [r for r in self.rows if r.size_class == size and r.held_class == held]
                leaning = [r for r in rows if r.share >= RIGID_SHARE]
                out.append({
                    "size": size, "held": held, "parts": len(rows), "rigs": len({r.name for r in rows}),
                    "rigid": float(np.mean([r.rigid for r in rows])) if rows else None,
                    "leaning": len(leaning),
                    "rigid_when_leaning": float(np.mean([r.rigid for r in leaning])) if leaning else None,
                })
        return out

    def to_dict(self) -> dict[str, Any]:
        return {"rigs": self.rigs, "table": self.table(), "rows": [asdict(r) for r in self.rows], "skipped": self.skipped,
                "max_piece": MAX_PIECE, "rigid_share": RIGID_SHARE}


def rig_parts(name: str, category: str, vertices: np.ndarray, faces: np.ndarray, joints: np.ndarray,
              weights: sp.csr_matrix) -> list[PartRow]:
    """The rows of one rig's weighted parts (none for a mesh of one part). vertices (V, 3), faces (F, 3),
    joints (J', 3) positions of the joints a job would skin to, weights (V, J)."""
    labels = part_labels(vertices, faces)
    count = int(labels.max()) + 1 if len(labels) else 0
    if count < 2:
        return []
    fig = part_figures(vertices, labels, weights, joints)
    assert fig.held is not None, "joints were given"
    rigid = np.zeros(count, bool)
    rigid[labels[rigid_piece_vertices(labels, sp.csr_matrix(weights))]] = True
    sizes = np.bincount(labels, minlength=count)
    total = fig.mass.sum(axis=1)
    return [PartRow(name, category, int(sizes[p]), float(fig.size[p]), int(fig.held[p]), float(fig.mass[p].max() / total[p]),
                    bool(rigid[p])) for p in range(count) if total[p] > 0]


def part_statistics(directory: Path, split: str | None = None,
                    on_asset: Callable[[str], None] = lambda name: None) -> PartStatistics:
    """Every rig's weighted parts in `directory` (see the module docstring)."""
    report = PartStatistics()
    for name, category, _doc, asset in rigged_assets(Path(directory), report.skipped, split):
        on_asset(name)
        report.rigs += 1
        skinned = asset.skeleton.positions[~weightless_joints(asset.weights)]  # as a job keeping the rig passes them
        report.rows.extend(rig_parts(name, category, asset.vertices, asset.faces, skinned, asset.weights))
    return report

"""The rigged assets of an evaluation directory and their categories (shared by the eval commands)."""

from __future__ import annotations

import csv
from collections.abc import Iterator
from pathlib import Path

from simcore.errors import InvalidInput, SimcoreError
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset, read_rigged_asset


def read_categories(directory: Path) -> dict[str, str]:
    """Asset name (and file stem) → category from DIR/MANIFEST.tsv (`name`, `file`, `category` columns); {} without one."""
    manifest = Path(directory) / "MANIFEST.tsv"
    if not manifest.is_file():
        return {}
    out: dict[str, str] = {}
    with manifest.open(newline="", encoding="utf-8") as fh:
        for row in csv.DictReader(fh, delimiter="\t"):
            category = (row.get("category") or "").strip() or "unknown"
            for key in (row.get("name"), Path(row.get("file") or "").stem):
                if key:
                    out[key.strip()] = category
    return out


def rigged_assets(directory: Path, skipped: dict[str, str] | None = None) -> Iterator[tuple[str, str, GltfDocument, RiggedAsset]]:
    """(name, category, document, rigged asset) for each readable skinned .glb/.gltf in `directory`, by name.

    Files that do not read as a rig (no skin, malformed) go to `skipped` as name → "code: message".
    """
    directory = Path(directory)
    if not directory.is_dir():
        raise InvalidInput(f"{directory} is not a directory", code="not_a_directory", field="dir")
    categories = read_categories(directory)
    for path in sorted(p for p in directory.iterdir() if p.suffix.lower() in (".glb", ".gltf")):
        try:
            doc = GltfDocument.from_bytes(path.read_bytes())
            asset = read_rigged_asset(doc)
        except SimcoreError as exc:
            if skipped is not None:
                skipped[path.stem] = f"{exc.code}: {exc}"
            continue
        yield path.stem, categories.get(path.stem, "unknown"), doc, asset

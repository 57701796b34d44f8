"""The rigged assets of an evaluation directory and their categories (shared by the eval commands)."""

from __future__ import annotations

import csv
from collections.abc import Iterator
from pathlib import Path

from simcore.errors import InvalidInput, SimcoreError
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset, read_rigged_asset


def problem(exc: Exception) -> str:
    """One line naming what went wrong: "code: message" for our errors, "ExceptionType: message" otherwise."""
    kind = exc.code if isinstance(exc, SimcoreError) else type(exc).__name__
    return f"{kind}: {exc}"[:300]


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


def split_files(directory: Path, split: str) -> list[Path]:
    """The files MANIFEST.tsv (`file` and `split` columns, the training corpus layout) lists for `split`."""
    manifest = Path(directory) / "MANIFEST.tsv"
    if not manifest.is_file():
        raise InvalidInput(f"{directory} has no MANIFEST.tsv to read split {split!r} from", code="no_manifest", field="split")
    with manifest.open(newline="", encoding="utf-8") as fh:
        rows = [r for r in csv.DictReader(fh, delimiter="\t") if (r.get("split") or "").strip() == split and r.get("file")]
    if not rows:
        raise InvalidInput(f"MANIFEST.tsv in {directory} lists no file in split {split!r}", code="empty_split", field="split")
    return sorted(Path(directory) / r["file"].strip() for r in rows)


def asset_files(directory: Path, split: str | None = None) -> list[Path]:
    """The .glb/.gltf files of `directory` by name, or with `split` the files MANIFEST.tsv lists for that split."""
    directory = Path(directory)
    if not directory.is_dir():
        raise InvalidInput(f"{directory} is not a directory", code="not_a_directory", field="dir")
    if split:
        return split_files(directory, split)
    return sorted(p for p in directory.iterdir() if p.suffix.lower() in (".glb", ".gltf"))


def rigged_assets(
    directory: Path, skipped: dict[str, str] | None = None, split: str | None = None
) -> Iterator[tuple[str, str, GltfDocument, RiggedAsset]]:
    """(name, category, document, rigged asset) for each readable skinned .glb/.gltf in `directory`, by name
    (with `split`, the files MANIFEST.tsv lists for that split, wherever they lie below `directory`).

    Files that do not read as a rig (no skin, malformed) go to `skipped` as name → "code: message".
    """
    categories = read_categories(directory)
    for path in asset_files(directory, split):
        try:
            doc = GltfDocument.from_bytes(path.read_bytes())
            asset = read_rigged_asset(doc)
        except Exception as exc:  # one unreadable file must not hide the others; the reason is reported
            if skipped is not None:
                skipped[path.stem] = problem(exc)
            continue
        yield path.stem, categories.get(path.stem, "unknown"), doc, asset

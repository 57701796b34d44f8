"""The rigged assets of an evaluation directory and their categories (shared by the eval commands)."""

from __future__ import annotations

import csv
from collections.abc import Collection, Iterator
from pathlib import Path

from simcore.errors import InvalidInput, SimcoreError
from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import RiggedAsset, read_rigged_asset


def problem(exc: Exception) -> str:
    """One line naming what went wrong: "code: message" for our errors, "ExceptionType: message" otherwise."""
    kind = exc.code if isinstance(exc, SimcoreError) else type(exc).__name__
    return f"{kind}: {exc}"[:300]


def manifest_rows(directory: Path) -> list[dict[str, str]] | None:
    """The rows of DIR/MANIFEST.tsv (tab-separated, a header row), or None when there is none."""
    manifest = Path(directory) / "MANIFEST.tsv"
    if not manifest.is_file():
        return None
    with manifest.open(newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh, delimiter="\t"))


def _keyed_rows(directory: Path) -> Iterator[tuple[str, dict[str, str]]]:
    """(asset name, row) and (file stem, row) for each MANIFEST.tsv row; nothing without a manifest."""
    for row in manifest_rows(directory) or []:
        for key in (row.get("name"), Path(row.get("file") or "").stem):
            if key:
                yield key.strip(), row


def read_categories(directory: Path) -> dict[str, str]:
    """Asset name (and file stem) → category from DIR/MANIFEST.tsv (`name`, `file`, `category` columns); {} without one."""
    return {key: (row.get("category") or "").strip() or "unknown" for key, row in _keyed_rows(directory)}


def _family(row: dict[str, str]) -> str:
    """The "family=X" entry of a row's `notes` (entries split by ";"), or ""."""
    notes = (part.strip() for part in (row.get("notes") or "").split(";"))
    return next((n.removeprefix("family=").strip() for n in notes if n.startswith("family=")), "")


def read_families(directory: Path) -> dict[str, str]:
    """Asset name (and file stem) → source family from DIR/MANIFEST.tsv (`family=X` in its `notes`; an asset
    without one is its own family); {} without a manifest."""
    return {key: _family(row) or key for key, row in _keyed_rows(directory)}


def family_folds(directory: Path, split: str, folds: int) -> list[list[str]]:
    """The asset names of `split` in `folds` groups that never share a source family, as even in size as whole
    families allow (largest family first, each into the smallest group so far; deterministic)."""
    if folds < 2:
        raise InvalidInput("family folds need at least 2 groups", code="invalid_option", field="folds")
    families = read_families(directory)
    members: dict[str, list[str]] = {}
    for path in split_files(directory, split):
        members.setdefault(families.get(path.stem, path.stem), []).append(path.stem)
    if len(members) < folds:
        raise InvalidInput(f"split {split!r} has {len(members)} families, fewer than {folds} folds", code="invalid_option",
                           field="folds")
    groups: list[list[str]] = [[] for _ in range(folds)]
    for family in sorted(members, key=lambda f: (-len(members[f]), f)):
        groups[min(range(folds), key=lambda k: (len(groups[k]), k))].extend(members[family])
    return [sorted(g) for g in groups]


def split_files(directory: Path, split: str) -> list[Path]:
    """The files MANIFEST.tsv (`file` and `split` columns, the training corpus layout) lists for `split`."""
    table = manifest_rows(directory)
    if table is None:
        raise InvalidInput(f"{directory} has no MANIFEST.tsv to read split {split!r} from", code="no_manifest", field="split")
    rows = [r for r in table if (r.get("split") or "").strip() == split and r.get("file")]
    if not rows:
        raise InvalidInput(f"MANIFEST.tsv in {directory} lists no file in split {split!r}", code="empty_split", field="split")
    return sorted(Path(directory) / r["file"].strip() for r in rows)


def asset_files(directory: Path, split: str | None = None, names: Collection[str] | None = None) -> list[Path]:
    """The .glb/.gltf files of `directory` by name, or with `split` the files MANIFEST.tsv lists for that split;
    with `names`, only those file stems."""
    directory = Path(directory)
    if not directory.is_dir():
        raise InvalidInput(f"{directory} is not a directory", code="not_a_directory", field="dir")
    if split:
        files = split_files(directory, split)
    else:
        files = sorted(p for p in directory.iterdir() if p.suffix.lower() in (".glb", ".gltf"))
    return files if names is None else [p for p in files if p.stem in names]


def rigged_assets(
    directory: Path, skipped: dict[str, str] | None = None, split: str | None = None,
    names: Collection[str] | None = None,
) -> Iterator[tuple[str, str, GltfDocument, RiggedAsset]]:
    """(name, category, document, rigged asset) for each readable skinned .glb/.gltf in `directory`, by name
    (with `split`, the files MANIFEST.tsv lists for that split, wherever they lie below `directory`; with `names`,
    only those file stems).

    Files that do not read as a rig (no skin, malformed) go to `skipped` as name → "code: message".
    """
    categories = read_categories(directory)
    for path in asset_files(directory, split, names):
        try:
            doc = GltfDocument.from_bytes(path.read_bytes())
            asset = read_rigged_asset(doc)
        except Exception as exc:  # one unreadable file must not hide the others; the reason is reported
            if skipped is not None:
                skipped[path.stem] = problem(exc)
            continue
        yield path.stem, categories.get(path.stem, "unknown"), doc, asset

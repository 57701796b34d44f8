"""A small corpus folder in the training corpus's layout and the checks every family cross-validation passes."""

from __future__ import annotations

from pathlib import Path

from tests.simcore.io.studio_rig_fixtures import studio_rig, to_glb

HEADER = "name\tfile\tcategory\tsplit\tnotes\n"


def corpus(tmp_path: Path, rows: list[tuple[str, str, str]]) -> Path:
    """A corpus folder of small rigs: rows of (name, split, notes), MANIFEST.tsv in the corpus layout."""
    root = tmp_path / "corpus"
    (root / "rigged").mkdir(parents=True)
    glb = to_glb(studio_rig(["hips", "spine", "head"]))
    lines = [HEADER]
    for name, split, notes in rows:
        (root / "rigged" / f"{name}.glb").write_bytes(glb)
        lines.append(f"{name}\trigged/{name}.glb\thumanoid\t{split}\t{notes}\n")
    (root / "MANIFEST.tsv").write_text("".join(lines))
    return root


def assert_each_held_out_once(result: dict, baseline: str, names: list[str], variants: int,
                              reports: list[tuple[int, int]], steps: int) -> None:
    """A family cross-validation `result` over the train characters `names` (fixture rows a1, a2 of one family):
    the folds split them, a1 and a2 held out together; every fold trained on the others' `variants` samples each;
    each character scored once by `learned` and `baseline`; one progress report per change, up to all `steps`."""
    held = [f["held_out"] for f in result["folds"]]
    assert sorted(sum(held, [])) == sorted(names) and ["a1", "a2"] in held
    for fold in result["folds"]:
        assert fold["train_samples"] == variants * (len(names) - len(fold["held_out"]))
        assert fold["mean"]["learned"]["assets"] == fold["mean"][baseline]["assets"] == len(fold["held_out"])
    scored = sorted((r["name"], r["method"]) for r in result["assets"])
    assert scored == sorted((n, m) for n in names for m in ("learned", baseline))
    summary = result["summary"]
    assert summary["compared"] == len(names) and not summary["errors"] and summary["mean"]["learned"]["assets"] == len(names)
    assert reports[-1] == (steps, steps) and len(reports) == len(set(reports))

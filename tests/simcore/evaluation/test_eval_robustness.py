"""`rigforge eval skeleton DIR`: an asset that cannot be read or scored becomes a problem line; the table of
every other asset still prints and the command succeeds (issue 25)."""

from __future__ import annotations

import shutil

import numpy as np
import typer
from typer.testing import CliRunner

from cli.eval_skeleton import eval_skeleton
from tests.simcore.io.studio_rig_fixtures import studio_rig, to_glb, with_accessor_values

ORDER = ["spine", "head", "hips", "sword"]  # an unordered skin with a second root reads and scores too


def test_unreadable_and_unscorable_assets_are_listed_and_the_table_prints(dev_assets, tmp_path):
    shutil.copy(dev_assets / "rigged_simple.glb", tmp_path / "rigged_simple.glb")
    doc = studio_rig(ORDER)
    (tmp_path / "studio.glb").write_bytes(to_glb(doc))
    weights = doc["meshes"][0]["primitives"][0]["attributes"]["WEIGHTS_0"]
    (tmp_path / "unweighted.glb").write_bytes(to_glb(with_accessor_values(doc, weights, np.zeros_like)))
    (tmp_path / "singular.glb").write_bytes(to_glb(with_accessor_values(doc, doc["skins"][0]["inverseBindMatrices"], np.zeros_like)))
    (tmp_path / "garbage.glb").write_bytes(b"glTF" + bytes(40))
    app = typer.Typer()
    app.command()(eval_skeleton)
    result = CliRunner().invoke(app, [str(tmp_path), "--method", "voxel"])
    assert result.exit_code == 0, result.output
    assert "MEAN" in result.output and "rigged_simple" in result.output and "studio" in result.output
    for name, reason in (("unweighted", "no joints"), ("singular", "inverse bind matrix is singular"), ("garbage", "invalid_gltf")):
        line = next(ln for ln in result.output.splitlines() if ln.startswith(f"skipped {name}:"))
        assert reason in line, line

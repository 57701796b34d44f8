"""`rigforge eval parts`: each separate part of an artist rig is counted by size, joints held and rigid binding."""

from __future__ import annotations

import json

import typer
from typer.testing import CliRunner

from cli.eval_parts import eval_parts
from tests.simcore.io.studio_rig_fixtures import studio_rig, to_glb


def test_a_capsule_body_and_a_rigid_blade_are_counted_apart(tmp_path):
    (tmp_path / "assets").mkdir()
    (tmp_path / "assets" / "studio.glb").write_bytes(to_glb(studio_rig(["hips", "spine", "head", "sword"])))
    app = typer.Typer()
    app.command()(eval_parts)
    result = CliRunner().invoke(app, [str(tmp_path / "assets"), "--json", str(tmp_path / "parts.json")])
    assert result.exit_code == 0, result.output
    report = json.loads((tmp_path / "parts.json").read_text())
    body, blade = sorted(report["rows"], key=lambda r: -r["vertices"])
    assert (body["held"], body["rigid"]) == (3, False) and body["share"] < 0.9  # blended along the chain
    assert (blade["held"], blade["rigid"], blade["share"]) == (1, True, 1.0)  # the sword bone's blade
    counted = {(r["size"], r["held"]): r["parts"] for r in report["table"] if r["parts"]}
    assert counted == {("large", "2+"): 1, ("piece", "1"): 1}

"""`rigforge fit --breakdown`: the error breakdown runs alone (`--protocol none`) and bad grid lists are refused."""

from __future__ import annotations

import json

from typer.testing import CliRunner

from cli.main import app


def test_the_breakdown_alone_writes_its_rows_per_grid(dev_assets, tmp_path):
    out = tmp_path / "fit.json"
    result = CliRunner().invoke(app, ["fit", str(dev_assets / "meshseq_flamingo.glb"), "--frames", "4", "--protocol",
                                      "none", "--breakdown", "16", "--json", str(out)])
    assert result.exit_code == 0, result.output
    report = json.loads(out.read_text())["meshseq_flamingo"]
    assert "pure" not in report and "train_test" not in report
    (run,) = report["breakdown"]
    assert run["grid"] == 16 and run["substeps"] >= 1
    assert set(run["rows"]) == {"observed", "anchor_motion", "drivers", "lbs_motion"}
    assert run["rows"]["observed"]["mean"] < run["rows"]["drivers"]["mean"]
    assert "where the error comes from" in result.output


def test_a_bad_breakdown_list_is_refused_by_name(dev_assets):
    for value in ("32,x", "8"):
        result = CliRunner().invoke(app, ["fit", str(dev_assets / "meshseq_flamingo.glb"), "--breakdown", value])
        assert result.exit_code == 2
        assert "--breakdown" in result.output

"""The dashboard's new-job form starts its number boxes at JobOptions' defaults and limits (no silent drift)."""

from __future__ import annotations

import re
from pathlib import Path

from simcore.options import JobOptions

FORM = Path(__file__).resolve().parents[2] / "web" / "src" / "pages" / "new_job.ts"
NUMBER_BOX = re.compile(r'"data-field": "options\.(\w+)", value: "(\d+)", min: "(\d+)", max: "(\d+)"')


def test_number_boxes_start_at_the_server_defaults() -> None:
    boxes = NUMBER_BOX.findall(FORM.read_text(encoding="utf-8"))
    assert {name for name, *_ in boxes} >= {"max_joints", "smooth_iterations"}
    for name, value, low, high in boxes:
        field = JobOptions.model_fields[name]
        limits = {type(m).__name__: m for m in field.metadata}
        assert int(value) == field.default, name
        assert int(low) == limits["Ge"].ge and int(high) == limits["Le"].le, name

"""The hostile-input corpus: every case, and a script that writes them out for trying against a live server.

    .venv/bin/python -m tests.hostile.corpus OUT_DIR   # one file per case + index.json (name, kind, expected codes)
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from tests.hostile.bomb_cases import bomb_cases
from tests.hostile.case import Case
from tests.hostile.gltf_cases import gltf_cases
from tests.hostile.request_cases import request_cases
from tests.hostile.text_cases import text_cases


def all_cases() -> list[Case]:
    """Every case, names unique."""
    cases = [*gltf_cases(), *text_cases(), *request_cases(), *bomb_cases()]
    names = [c.name for c in cases]
    assert len(names) == len(set(names)), "duplicate case names"
    return cases


def write(out: Path) -> int:
    """Write each file/options case as OUT/<name>.bin and an index of all cases; returns the count."""
    out.mkdir(parents=True, exist_ok=True)
    index = []
    for c in all_cases():
        entry: dict[str, Any] = {"name": c.name, "kind": c.kind, "expect": sorted(c.expect)}
        if c.kind == "request":
            entry["request"] = {k: v for k, v in c.request.items() if k in ("form", "headers")}
        else:
            (out / f"{c.name}.bin").write_bytes(c.data)
        index.append(entry)
    (out / "index.json").write_text(json.dumps(index, indent=1))
    return len(index)


if __name__ == "__main__":
    print(write(Path(sys.argv[1])), "cases written")

"""Format sniffing from the first bytes."""

from __future__ import annotations

import json

from simcore.io.sniff import sniff


def test_a_gltf_whose_asset_key_comes_after_the_first_4_kib_is_still_gltf() -> None:
    doc = {"accessors": [{"componentType": 5126, "count": 3, "type": "VEC3"}] * 200, "asset": {"version": "2.0"}}
    data = json.dumps(doc).encode()
    assert data.index(b'"asset"') > 4096
    assert sniff(data[:4096], len(data)) == "gltf"

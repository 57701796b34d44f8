"""The glTF structure check: linear in the node graph, capped in depth and nesting."""

from __future__ import annotations

import time

import pytest

from simcore.errors import InvalidInput, LimitExceeded
from simcore.io.gltf_schema import MAX_NODE_DEPTH, node_parents, validate_structure


def chain(n: int) -> list[dict]:
    return [{"children": [i + 1]} for i in range(n - 1)] + [{}]


def test_a_20000_deep_node_chain_is_refused_by_depth_in_linear_time():
    started = time.perf_counter()
    with pytest.raises(LimitExceeded) as err:
        node_parents(chain(20_000))
    assert err.value.code == "hierarchy_too_deep" and time.perf_counter() - started < 2.0  # quadratic took 190 s


def test_a_chain_at_the_depth_cap_is_read():
    parents = node_parents(chain(MAX_NODE_DEPTH))
    assert parents[0] == -1 and parents[-1] == MAX_NODE_DEPTH - 2


def test_200000_shallow_nodes_check_in_linear_time():
    nodes = [{"children": list(range(1, 200_000))}] + [{} for _ in range(199_999)]
    started = time.perf_counter()
    assert (node_parents(nodes)[1:] == 0).all()
    assert time.perf_counter() - started < 5.0


@pytest.mark.parametrize("nodes", [[{"children": [1]}, {"children": [0]}], [{"children": [0]}],
                                   [{"children": [1]}, {"children": [2]}, {"children": [1]}]],
                         ids=["two-cycle", "self", "three-with-cycle"])
def test_cycles_are_invalid(nodes):
    with pytest.raises(InvalidInput):
        node_parents(nodes)


def test_wrong_json_types_name_the_property():
    with pytest.raises(InvalidInput) as err:
        validate_structure({"asset": {"version": "2.0"}, "buffers": [{"byteLength": "12"}]})
    assert err.value.code == "invalid_gltf" and "buffers[0].byteLength" in str(err.value)
    with pytest.raises(InvalidInput, match="'buffers' must be an array"):
        validate_structure({"asset": {"version": "2.0"}, "buffers": 5, "bufferViews": [{"buffer": 0, "byteLength": 1}]})


def test_deep_nesting_is_limited():
    extras: list = []
    for _ in range(100):
        extras = [extras]
    with pytest.raises(LimitExceeded) as err:
        validate_structure({"asset": {"version": "2.0"}, "extras": extras})
    assert err.value.code == "json_too_deep"

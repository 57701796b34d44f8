"""Hostile `options` fields and whole multipart requests."""

from __future__ import annotations

import json
from collections.abc import Iterator

from tests.hostile.case import OK, Case, case

MESH = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
BAD_OPTIONS = ("invalid_options",)


def _nest(depth: int) -> str:
    return '{"motion": {"joint_map": ' + "[" * depth + "]" * depth + "}}"


def options_cases() -> Iterator[Case]:
    yield case("options-valid", "options", '{"stages": []}', OK)
    yield case("options-lax-number", "options", '{"max_joints": "64"}', OK)  # pydantic's lax mode reads "64" as 64
    texts = ["{not json", "[1, 2]", '"auto"', "5", "null", "true", '{"stages": [] ', "\x00", "{}" * 3, '{"a":1}',
             '{"skinning": "magic"}', '{"max_joints": 1e400}', '{"max_joints": 10000000000000000000000}',
             '{"max_joints": -1}', '{"max_joints": 1.5}', '{"max_joints": NaN}', '{"smooth_iterations": Infinity}',
             '{"motion": {"fps": NaN}}', '{"motion": {"unit_scale": Infinity}}', '{"motion": {"unit_scale": -1}}',
             '{"motion": {"fps": 1e308}}', '{"motion": {"clip": [1]}}', '{"motion": {"clip": {"a": 1}}}',
             '{"motion": {"joint_map": {"a": 5}}}', '{"motion": {"joint_map": [["a", "b"]]}}', '{"motion": 5}',
             '{"motion": {"bogus": true}}', '{"refine": {"grid": 100000}}', '{"refine": {"bone_stiffness": {"a": NaN}}}',
             '{"refine": {"bone_stiffness": {"a": "hard"}}}', '{"refine": {"max_particles": 10000000}}', '{"refine": null}',
             '{"up_axis": "w"}', '{"up_axis": ["y"]}', '{"stages": ["ingest"]}', '{"stages": "export"}',
             '{"exclude_joints": ' + json.dumps(["j"] * 300) + "}", '{"exclude_joints": ["' + "x" * 300 + '"]}',
             '{"exclude_joints": [5]}', '{"units": null}', '{"max_influences": 5}', '{"skeleton": "keep", "skeleton": 1}',
             '{"__proto__": {}}', '{"units": "cm", "extra": {"deep": ' + "[" * 5 + "]" * 5 + "}}"]
    for k, text in enumerate(texts):
        yield case(f"options-{k}", "options", text, *BAD_OPTIONS)
    for depth in (9, 100, 1000, 100_000):
        yield case(f"options-nested-{depth}", "options", _nest(depth), *BAD_OPTIONS)
    yield case("options-huge-valid", "options", json.dumps({"stages": [], "motion": {"joint_map": {f"j{i}": "Hips" for i in range(2000)}}}), OK)


def _request(name: str, *codes: str, files: list | None = None, form: dict | None = None, headers: dict | None = None,
             content: bytes | None = None) -> Case:
    return case(name, "request", b"", *codes, files=files if files is not None else [("mesh", "t.obj", MESH)],
                form=form if form is not None else {"options": '{"stages": []}'}, headers=headers or {}, content=content)


def multipart_cases() -> Iterator[Case]:
    yield _request("request-valid", OK)
    yield _request("request-no-mesh", "validation_error", files=[("motion", "m.bvh", b"HIERARCHY\n")])
    yield _request("request-mesh-as-text", "validation_error", files=[], form={"mesh": "v 0 0 0", "options": "{}"})
    yield _request("request-no-files", "validation_error", files=[], form={})
    yield _request("request-two-meshes", OK, "validation_error", files=[("mesh", "a.obj", MESH), ("mesh", "b.obj", MESH)])
    yield _request("request-path-filename", OK, files=[("mesh", "../../../etc/passwd", MESH)])
    yield _request("request-long-filename", OK, "invalid_request", files=[("mesh", "a" * 5000 + ".obj", MESH)])
    yield _request("request-empty-filename", OK, "validation_error", files=[("mesh", "", MESH)])
    yield _request("request-unicode-filename", OK, files=[("mesh", "\u202etxt.exe\u0000.obj", MESH)])
    yield _request("request-motion-obj", "wrong_kind", files=[("mesh", "t.obj", MESH), ("motion", "m.obj", MESH)])
    yield _request("request-motion-fbx", "unsupported_format",
                   files=[("mesh", "t.obj", MESH), ("motion", "m.fbx", b"Kaydara FBX Binary  \x00\x1a\x00" + bytes(64))])
    yield _request("request-motion-empty", "empty_file", files=[("mesh", "t.obj", MESH), ("motion", "m.bvh", b"")])
    yield _request("request-idempotency-too-long", "validation_error", headers={"Idempotency-Key": "k" * 300})
    yield _request("request-no-auth", "unauthorized", headers={"Authorization": ""})
    yield _request("request-bad-auth", "unauthorized", headers={"Authorization": "Bearer rf_nope"})
    yield _request("request-basic-auth", "unauthorized", headers={"Authorization": "Basic YTpi"})
    yield _request("request-json-body", "validation_error", files=[], form={}, headers={"Content-Type": "application/json"},
                   content=b'{"mesh": "x"}')
    yield _request("request-urlencoded", "validation_error", files=[], form={},
                   headers={"Content-Type": "application/x-www-form-urlencoded"}, content=b"mesh=x&options=%7B%7D")
    yield _request("request-broken-multipart", "validation_error", "invalid_request", files=[], form={},
                   headers={"Content-Type": "multipart/form-data; boundary=zzz"}, content=b"--zzz\r\nnot a part\r\n")
    yield _request("request-no-boundary", "validation_error", "invalid_request", files=[], form={},
                   headers={"Content-Type": "multipart/form-data"}, content=b"--x\r\n\r\n")
    yield _request("request-options-file", OK, "validation_error", "invalid_options",
                   files=[("mesh", "t.obj", MESH), ("options", "o.json", b'{"stages": []}')], form={})
    yield _request("request-content-length-lies", "upload_too_large", headers={"Content-Length": str(10**12)})


def request_cases() -> Iterator[Case]:
    yield from options_cases()
    yield from multipart_cases()

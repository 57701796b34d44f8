"""Re-skinning an edited skeleton over the API: a skeleton file next to the mesh, linked to the job it came from."""

from __future__ import annotations

import json

import numpy as np

from simcore.io.gltf_document import GltfDocument
from simcore.io.gltf_rig import read_rigged_asset
from simcore.motion.gltf_clips import sample_node_worlds

KEEP = json.dumps({"skeleton": "keep", "stages": ["skeleton", "skin", "export"]})


def _post(client, auth, fox: bytes, options: str, **extra):
    files = {"mesh": ("fox.glb", fox)}
    data = {"options": options}
    if "skeleton" in extra:
        files["skeleton"] = ("edited.json", extra.pop("skeleton"))
    data.update(extra)
    return client.post("/api/v1/jobs", headers=auth, files=files, data=data)


def _artifact(client, auth, job: dict, name: str) -> bytes:
    url = next(a["url"] for a in job["artifacts"] if a["name"] == name)
    return client.get(url, headers=auth).content


def test_an_edited_skeleton_is_reskinned_and_linked(client, auth, dev_assets):
    fox = (dev_assets / "fox.glb").read_bytes()
    first = client.get(f"/api/v1/jobs/{_post(client, auth, fox, json.dumps({'stages': ['skeleton']})).json()['id']}",
                       headers=auth).json()
    assert first["status"] == "succeeded", first
    edited = json.loads(_artifact(client, auth, first, "skeleton.json"))
    edited["positions"][3][1] += 0.02  # a joint moved 2 cm up in the editor
    edited["names"][3] = "moved_joint"
    r = _post(client, auth, fox, KEEP, skeleton=json.dumps(edited).encode(), source_job=first["id"])
    assert r.status_code == 202, r.text
    job = client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()
    assert job["status"] == "succeeded", job
    assert job["source_job_id"] == first["id"] and job["skeleton"]["filename"] == "edited.json"
    rig = read_rigged_asset(GltfDocument.from_bytes(_artifact(client, auth, job, "rigged.glb")))
    k = rig.skeleton.names.index("moved_joint")
    assert abs(rig.skeleton.positions[k][1] - edited["positions"][3][1]) < 1e-5
    assert json.loads(_artifact(client, auth, job, "report.json"))["skeleton"]["method"] == "given"


def test_a_skeleton_file_needs_keep_and_must_be_a_tree(client, auth, dev_assets):
    fox = (dev_assets / "fox.glb").read_bytes()
    tree = json.dumps({"names": ["a", "b"], "parents": [-1, 0], "positions": [[0, 0, 0], [0, 0.1, 0]]}).encode()
    r = _post(client, auth, fox, '{"stages": []}', skeleton=tree)
    assert r.status_code == 422 and r.json()["field"] == "options.skeleton", r.text
    cycle = json.dumps({"names": ["a", "b"], "parents": [1, 0], "positions": [[0, 0, 0], [0, 0.1, 0]]}).encode()
    r = _post(client, auth, fox, KEEP, skeleton=cycle)
    assert r.status_code == 422 and r.json()["code"] == "invalid_skeleton" and r.json()["field"] == "skeleton", r.text


def test_the_source_job_must_be_yours(client, auth, other_auth, dev_assets):
    fox = (dev_assets / "fox.glb").read_bytes()
    theirs = _post(client, other_auth, fox, '{"stages": []}').json()["id"]
    r = _post(client, auth, fox, '{"stages": []}', source_job=theirs)
    assert r.status_code == 404 and r.json()["code"] == "job_not_found", r.text


def test_a_kept_rigs_bind_frames_survive_the_edit(client, auth, dev_assets):
    import numpy as np
    from scipy.spatial.transform import Rotation

    fox = (dev_assets / "fox.glb").read_bytes()
    kept = _post(client, auth, fox, json.dumps({"skeleton": "keep", "stages": ["skeleton"]})).json()
    kept = client.get(f"/api/v1/jobs/{kept['id']}", headers=auth).json()
    doc = json.loads(_artifact(client, auth, kept, "skeleton.json"))
    edited = {k: doc[k] for k in ("names", "parents", "positions", "orientations")}  # what the dashboard sends
    edited["positions"][5][2] += 0.01
    job = _post(client, auth, fox, KEEP, skeleton=json.dumps(edited).encode(), source_job=kept["id"]).json()
    job = client.get(f"/api/v1/jobs/{job['id']}", headers=auth).json()
    assert job["status"] == "succeeded", job
    rig = read_rigged_asset(GltfDocument.from_bytes(_artifact(client, auth, job, "rigged.glb")))
    frames = Rotation.from_matrix(rig.bind_matrices[:, :3, :3]).as_quat()
    order = [edited["names"].index(n) for n in rig.skeleton.names]
    dots = np.abs(np.sum(frames * np.asarray(edited["orientations"])[order], axis=1))
    assert dots.min() > 1 - 1e-5  # every joint keeps its studio bind frame


def _joint_worlds(glb: bytes, names: list[str]) -> np.ndarray:
    """(T, len(names), 4, 4) world matrices of the named joints at every key of the file's first clip."""
    doc = GltfDocument.from_bytes(glb)
    rig = read_rigged_asset(doc)
    anim = doc.items("animations")[0]
    times = np.unique(np.concatenate([doc.accessor(s["input"]) for s in anim["samplers"]]))
    return sample_node_worlds(doc, 0, times, rig.joint_nodes[[rig.skeleton.names.index(n) for n in names]])


def test_a_reskin_replays_the_source_jobs_clip(client, auth, dev_assets):
    """What the dashboard's Re-skin sends for an animated job: its animated.glb as motion, renamed joints mapped
    from their old names; the new rig plays the same clip, each joint turning as it did."""
    fox = (dev_assets / "fox.glb").read_bytes()
    walk = json.dumps({"skeleton": "keep", "motion": {"clip": "Walk"}, "stages": ["skeleton", "skin", "motion", "export"]})
    first = client.get(f"/api/v1/jobs/{_post(client, auth, fox, walk).json()['id']}", headers=auth).json()
    assert first["status"] == "succeeded", first
    edited = json.loads(_artifact(client, auth, first, "skeleton.json"))
    original = list(edited["names"])
    old = original[5]
    edited["names"][5] = "renamed_joint"
    edited["positions"][3][1] += 0.02
    options = json.dumps({"skeleton": "keep", "units": "m", "motion": {"joint_map": {old: "renamed_joint"}},
                          "stages": ["skeleton", "skin", "motion", "export"]})
    files = {"mesh": ("mesh.glb", _artifact(client, auth, first, "mesh.glb")),
             "skeleton": ("edited.json", json.dumps(edited).encode()),
             "motion": ("animated.glb", _artifact(client, auth, first, "animated.glb"))}
    r = client.post("/api/v1/jobs", headers=auth, files=files, data={"options": options, "source_job": first["id"]})
    assert r.status_code == 202, r.text
    second = client.get(f"/api/v1/jobs/{r.json()['id']}", headers=auth).json()
    assert second["status"] == "succeeded", second
    before, after = (json.loads(_artifact(client, auth, job, "report.json"))["motion"] for job in (first, second))
    assert after["status"] == "retargeted" and after["unmapped_target_joints"] == []
    assert (after["clip"]["frames"], after["clip"]["fps"]) == (before["clip"]["frames"], before["clip"]["fps"])
    assert after["joint_map"]["renamed_joint"] == old  # target joint → the clip's joint
    ours = _joint_worlds(_artifact(client, auth, first, "animated.glb"), original)
    theirs = _joint_worlds(_artifact(client, auth, second, "animated.glb"), edited["names"])
    turn = np.einsum("tjab,tjac->tjbc", ours[..., :3, :3], theirs[..., :3, :3])  # R_firstᵀ R_second per joint
    angle = np.degrees(np.arccos(np.clip((np.trace(turn, axis1=-2, axis2=-1) - 1) / 2, -1, 1)))
    moved = {3, edited["parents"][3]}  # the moved joint re-aims its bone and its parent's
    assert max(a for j, a in enumerate(angle.max(axis=0)) if j not in moved) < 0.05  # degrees

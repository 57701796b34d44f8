"""Key management over HTTP: allowed on the embedded development default, 403 problem elsewhere."""

from __future__ import annotations


def test_create_list_and_revoke_a_key_in_development(client, auth):
    created = client.post("/api/v1/keys", headers=auth, json={"name": "render farm"})
    assert created.status_code == 201, created.text
    body = created.json()
    secret, key_id = body["secret"], body["key"]["id"]
    assert secret.startswith(body["key"]["prefix"]) and body["key"]["revoked_at"] is None
    new_auth = {"Authorization": f"Bearer {secret}"}
    assert client.get("/api/v1/keys/me", headers=new_auth).json()["name"] == "render farm"
    names = [k["name"] for k in client.get("/api/v1/keys", headers=auth).json()]
    assert names == ["tester", "render farm"]  # oldest first

    revoked = client.post(f"/api/v1/keys/{key_id}/revoke", headers=auth)
    assert revoked.status_code == 200 and revoked.json()["revoked_at"] is not None
    assert client.get("/api/v1/keys/me", headers=new_auth).status_code == 401
    missing = client.post("/api/v1/keys/00000000-0000-0000-0000-000000000000/revoke", headers=auth)
    assert missing.status_code == 404 and missing.json()["code"] == "key_not_found"


def test_key_management_is_forbidden_outside_development(client, auth, monkeypatch):
    from api.settings import get_settings

    monkeypatch.setattr(get_settings(), "env", "production")
    for method, path, body in (("GET", "/api/v1/keys", None), ("POST", "/api/v1/keys", {"name": "x"})):
        r = client.request(method, path, headers=auth, json=body)
        assert r.status_code == 403, path
        assert r.headers["content-type"] == "application/problem+json"
        assert r.json()["code"] == "key_management_disabled"
    assert client.get("/api/v1/keys/me", headers=auth).status_code == 200  # sign-in check still works


def test_key_management_needs_a_valid_key(client):
    assert client.get("/api/v1/keys").status_code == 401
    assert client.post("/api/v1/keys", json={"name": "x"}).status_code == 401


def test_empty_key_name_is_a_field_error(client, auth):
    r = client.post("/api/v1/keys", headers=auth, json={"name": ""})
    assert r.status_code == 422 and r.json()["field"] == "name"

"""Key management over HTTP: admin keys only, in every environment; any key can ask who it is."""

from __future__ import annotations

import pytest


@pytest.fixture
def admin_auth(client) -> dict:
    from api.db import session_scope
    from api.keys.service import create_key

    with session_scope() as session:
        return {"Authorization": f"Bearer {create_key(session, name='admin', admin=True)[1]}"}


def test_an_admin_creates_lists_and_revokes_keys(client, admin_auth):
    created = client.post("/api/v1/keys", headers=admin_auth, json={"name": "render farm"})
    assert created.status_code == 201, created.text
    body = created.json()
    secret, key_id = body["secret"], body["key"]["id"]
    assert secret.startswith(body["key"]["prefix"]) and body["key"]["revoked_at"] is None and body["key"]["admin"] is False
    new_auth = {"Authorization": f"Bearer {secret}"}
    assert client.get("/api/v1/keys/me", headers=new_auth).json()["name"] == "render farm"
    assert [k["name"] for k in client.get("/api/v1/keys", headers=admin_auth).json()] == ["admin", "render farm"]  # oldest first

    revoked = client.post(f"/api/v1/keys/{key_id}/revoke", headers=admin_auth)
    assert revoked.status_code == 200 and revoked.json()["revoked_at"] is not None
    assert client.get("/api/v1/keys/me", headers=new_auth).status_code == 401
    missing = client.post("/api/v1/keys/00000000-0000-0000-0000-000000000000/revoke", headers=admin_auth)
    assert missing.status_code == 404 and missing.json()["code"] == "key_not_found"


def test_an_admin_can_make_another_admin(client, admin_auth):
    secret = client.post("/api/v1/keys", headers=admin_auth, json={"name": "ops", "admin": True}).json()["secret"]
    assert client.get("/api/v1/keys", headers={"Authorization": f"Bearer {secret}"}).status_code == 200


@pytest.mark.parametrize("env", ["development", "production"])
def test_a_plain_key_manages_no_keys_in_any_environment(client, auth, admin_auth, env, monkeypatch):
    from api.settings import get_settings

    monkeypatch.setattr(get_settings(), "env", env)
    admin_id = client.get("/api/v1/keys/me", headers=admin_auth).json()["id"]
    for method, path, body in (("GET", "/api/v1/keys", None), ("POST", "/api/v1/keys", {"name": "x"}),
                               ("POST", "/api/v1/keys", {"name": "x", "admin": True}),
                               ("POST", f"/api/v1/keys/{admin_id}/revoke", None)):
        r = client.request(method, path, headers=auth, json=body)
        assert r.status_code == 403, (method, path, r.text)
        assert r.headers["content-type"] == "application/problem+json" and r.json()["code"] == "admin_required"
    assert client.get("/api/v1/keys/me", headers=admin_auth).json()["revoked_at"] is None
    me = client.get("/api/v1/keys/me", headers=auth)
    assert me.status_code == 200 and me.json()["admin"] is False  # the sign-in check still works


def test_key_management_needs_a_valid_key(client):
    assert client.get("/api/v1/keys").status_code == 401
    assert client.post("/api/v1/keys", json={"name": "x"}).status_code == 401


def test_empty_key_name_is_a_field_error(client, admin_auth):
    r = client.post("/api/v1/keys", headers=admin_auth, json={"name": ""})
    assert r.status_code == 422 and r.json()["field"] == "name"


def test_the_local_key_of_a_fresh_install_is_an_admin(client):
    from api.db import session_scope
    from api.keys.service import find_active, list_keys
    from cli.server import ensure_local_key

    with session_scope() as session:
        for key in list_keys(session):
            session.delete(key)
    secret = ensure_local_key()
    assert secret is not None  # None only while other keys exist, and they were deleted above
    with session_scope() as session:
        local = find_active(session, secret=secret)
        assert local is not None and local.is_admin


def test_cli_creates_an_admin_key(client):
    from typer.testing import CliRunner

    from cli.keys import app

    result = CliRunner().invoke(app, ["create", "--name", "ops", "--admin"])
    assert result.exit_code == 0, result.output
    r = client.get("/api/v1/keys", headers={"Authorization": f"Bearer {result.output.strip()}"})
    assert r.status_code == 200 and r.json()[-1]["admin"] is True

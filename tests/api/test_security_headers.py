"""Security headers on the dashboard, the API, errors and the docs page."""

from __future__ import annotations


def test_every_response_has_nosniff_no_referrer_and_no_framing(client, auth):
    for r in (client.get("/healthz"), client.get("/api/v1/jobs", headers=auth), client.get("/api/v1/jobs"),
              client.post("/api/v1/jobs", headers=auth)):
        assert r.headers["x-content-type-options"] == "nosniff"
        assert r.headers["referrer-policy"] == "no-referrer" and r.headers["x-frame-options"] == "DENY"
        assert "frame-ancestors 'none'" in r.headers["content-security-policy"]


def test_the_dashboard_csp_allows_only_its_own_origin(client):
    csp = client.get("/healthz").headers["content-security-policy"]
    assert "script-src 'self';" in csp and "unsafe-eval" not in csp and "connect-src 'self' " in csp


def test_the_docs_pages_load_their_assets_from_this_server_only(client):
    for page, asset in (("/docs", "/docs-assets/swagger-ui/swagger-ui-bundle.js"), ("/redoc", "/docs-assets/redoc/redoc.standalone.js")):
        r = client.get(page)
        assert r.status_code == 200 and r.headers["x-frame-options"] == "DENY", page
        assert "default-src 'self'" in r.headers["content-security-policy"] and "http" not in r.headers["content-security-policy"]
        assert f'"{asset}"' in r.text and "cdn" not in r.text.lower(), page
        assert client.get(asset).status_code == 200, asset

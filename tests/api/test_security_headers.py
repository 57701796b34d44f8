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


def test_the_docs_page_keeps_its_cdn_assets(client):
    r = client.get("/docs")
    assert r.status_code == 200 and "content-security-policy" not in r.headers and r.headers["x-frame-options"] == "DENY"

"""/docs (Swagger UI) and /redoc (ReDoc) on assets the web build copies from npm: they work offline, no CDN."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter
from fastapi.openapi.docs import get_redoc_html, get_swagger_ui_html
from fastapi.responses import HTMLResponse

from api.errors import Problem

router = APIRouter(include_in_schema=False)
ASSETS_DIR = Path(__file__).resolve().parents[1] / "web" / "dist" / "docs-assets"  # written by web/build.mjs
ASSETS_URL = "/docs-assets"
OPENAPI_URL = "/openapi.json"
TITLE = "RigForge API"


def _assets_built() -> None:
    if not ASSETS_DIR.is_dir():
        raise Problem(503, "docs_not_built", "the API docs assets are missing: build them with `npm ci && npm run build`")


@router.get("/docs")
def swagger_ui() -> HTMLResponse:
    _assets_built()
    return get_swagger_ui_html(openapi_url=OPENAPI_URL, title=TITLE,
                               swagger_js_url=f"{ASSETS_URL}/swagger-ui/swagger-ui-bundle.js",
                               swagger_css_url=f"{ASSETS_URL}/swagger-ui/swagger-ui.css",
                               swagger_favicon_url=f"{ASSETS_URL}/swagger-ui/favicon-32x32.png",
                               swagger_ui_parameters={"displayOperationId": True})


@router.get("/redoc")
def redoc() -> HTMLResponse:
    _assets_built()
    return get_redoc_html(openapi_url=OPENAPI_URL, title=TITLE, redoc_js_url=f"{ASSETS_URL}/redoc/redoc.standalone.js",
                          redoc_favicon_url=f"{ASSETS_URL}/swagger-ui/favicon-32x32.png", with_google_fonts=False)

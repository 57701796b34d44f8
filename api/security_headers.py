"""ASGI middleware adding security headers to every HTTP response (streamed ones included)."""

from __future__ import annotations

from starlette.types import ASGIApp, Message, Receive, Scope, Send

# The dashboard is one same-origin bundle: no inline script, no third-party origin. Its views set inline
# style attributes (bar widths, colours), hence 'unsafe-inline' for styles only. GLB textures decode through
# blob:/data: URLs.
DASHBOARD_CSP = ("default-src 'self'; script-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; "
                 "connect-src 'self' blob: data:; worker-src 'self' blob:; object-src 'none'; base-uri 'none'; "
                 "frame-ancestors 'none'; form-action 'self'")
COMMON = [(b"x-content-type-options", b"nosniff"), (b"referrer-policy", b"no-referrer"), (b"x-frame-options", b"DENY")]
# /docs and /redoc load Swagger UI/ReDoc from this server (api/docs_pages.py) and start them with FastAPI's inline script.
DOCS_PAGES = ("/docs", "/redoc")
DOCS_CSP = ("default-src 'self'; script-src 'self' 'unsafe-inline'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
            "connect-src 'self'; worker-src 'self' blob:; object-src 'none'; base-uri 'none'; frame-ancestors 'none'; form-action 'self'")

DASHBOARD_HEADERS = [*COMMON, (b"content-security-policy", DASHBOARD_CSP.encode())]  # built once, not per response
DOCS_HEADERS = [*COMMON, (b"content-security-policy", DOCS_CSP.encode())]


class SecurityHeaders:
    """nosniff, no referrer, no framing everywhere; the dashboard's CSP on all but the API docs pages, which get their own."""

    def __init__(self, app: ASGIApp) -> None:
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        extra = DOCS_HEADERS if scope["path"] in DOCS_PAGES else DASHBOARD_HEADERS

        async def send_with_headers(message: Message) -> None:
            if message["type"] == "http.response.start":
                present = {name.lower() for name, _ in message.get("headers", [])}
                message["headers"] = list(message.get("headers", [])) + [h for h in extra if h[0] not in present]
            await send(message)

        await self.app(scope, receive, send_with_headers)

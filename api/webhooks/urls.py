"""Check a callback URL before it is stored: absolute http(s) with a host, of sane length."""

from __future__ import annotations

from pydantic import AnyHttpUrl, TypeAdapter, ValidationError

from api.errors import Problem

MAX_URL_CHARS = 2000
_http_url = TypeAdapter(AnyHttpUrl)


def checked_callback_url(raw: str | None, *, field: str) -> str | None:
    """`raw` when it is an http(s) URL (None or blank: no callback); else 422 problem+json naming `field`."""
    if raw is None or not raw.strip():
        return None
    url = raw.strip()
    if len(url) > MAX_URL_CHARS:
        raise Problem(422, "invalid_callback_url", f"{field} is longer than {MAX_URL_CHARS} characters", field=field)
    scheme = url.partition(":")[0].lower()
    if scheme not in ("http", "https"):
        raise Problem(422, "invalid_callback_url", f"{field} must be an http or https URL, not {scheme or 'a relative'!r}",
                      field=field)
    try:
        _http_url.validate_python(url)
    except ValidationError as exc:
        raise Problem(422, "invalid_callback_url", f"{field}: {exc.errors()[0]['msg']}", field=field) from None
    return url

"""Short-lived signed download links: no API key in a URL, so none in access logs, browser history or shared links.

A link names the job, the file and its expiry, signed with HMAC-SHA256 under the service's signing key
(`RIGFORGE_SIGNING_KEY`, else a random key created once in the data directory). Expiries are rounded up to
a whole EXPIRY_STEP so a job's JSON stays the same between polls within that step.
"""

from __future__ import annotations

import hashlib
import hmac
import math
import os
import secrets
import time
import uuid
from functools import lru_cache
from urllib.parse import quote, urlencode

from api.errors import Problem
from api.settings import get_settings

EXPIRY_STEP = 60
ZIP_NAME = "artifacts.zip"  # the name a link to every artifact of a job signs


@lru_cache
def signing_key() -> bytes:
    """The configured key, else the one kept in data_dir/signing-key (created atomically, mode 600, on first use)."""
    settings = get_settings()
    if settings.signing_key is not None:
        return settings.signing_key.get_secret_value().encode()
    path = settings.data_dir / "signing-key"
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        return path.read_bytes().strip()
    with os.fdopen(fd, "w") as out:
        out.write(secrets.token_urlsafe(32))
    return path.read_bytes().strip()


def _signature(job_id: uuid.UUID, name: str, expires: int) -> str:
    message = f"{job_id}\n{name}\n{expires}".encode()
    return hmac.new(signing_key(), message, hashlib.sha256).hexdigest()


def signed_path(job_id: uuid.UUID, name: str) -> str:
    """/api/v1/files/<job>/<name>?expires=…&sig=…, valid for `download_url_seconds` (rounded up to EXPIRY_STEP)."""
    seconds = get_settings().download_url_seconds
    expires = math.ceil((time.time() + seconds) / EXPIRY_STEP) * EXPIRY_STEP
    query = urlencode({"expires": expires, "sig": _signature(job_id, name, expires)})
    return f"/api/v1/files/{job_id}/{quote(name)}?{query}"


def verify(job_id: uuid.UUID, name: str, expires: int, sig: str) -> None:
    """Raise a 403 problem unless `sig` signs (job, name, expires) and the link has not expired."""
    if not hmac.compare_digest(sig.encode(), _signature(job_id, name, expires).encode()):
        raise Problem(403, "bad_signature", "the download link is not valid: ask the job for a fresh one", field="sig")
    if expires < time.time():
        raise Problem(403, "link_expired", "the download link has expired: ask the job for a fresh one", field="expires")

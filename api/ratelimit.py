"""Request rate limits per API key (a moving window per `RIGFORGE_RATE_LIMIT` item), 429 + Retry-After beyond.

Counters live in this process's memory on the embedded default, or in Redis (`RIGFORGE_RATE_LIMIT_STORAGE`, default
the Redis broker) so that API replicas share them. A limiter that cannot reach its storage lets requests through
(logged): rate limiting protects the service, it must not take it down.
"""

from __future__ import annotations

import logging
import math
import time
from functools import lru_cache

from fastapi.concurrency import run_in_threadpool
from limits import RateLimitItem, parse_many
from limits.storage import storage_from_string
from limits.strategies import MovingWindowRateLimiter

from api.errors import Problem
from api.metrics import RATE_LIMITED
from api.models import ApiKey
from api.settings import Settings, get_settings

log = logging.getLogger("rigforge.ratelimit")


def storage_uri(settings: Settings) -> str:
    if settings.rate_limit_storage:
        return settings.rate_limit_storage
    return settings.broker_url if settings.broker_url.startswith(("redis://", "rediss://")) else "memory://"


@lru_cache
def _limiter(uri: str, spec: str) -> tuple[MovingWindowRateLimiter, list[RateLimitItem]]:
    return MovingWindowRateLimiter(storage_from_string(uri)), parse_many(spec)


def check(identity: str, settings: Settings) -> None:
    """Count one request of `identity`; 429 problem+json with Retry-After when a window is full."""
    if not settings.rate_limit.strip():
        return
    limiter, items = _limiter(storage_uri(settings), settings.rate_limit)
    try:
        full = next((item for item in items if not limiter.test(item, identity)), None)
        if full is None:
            for item in items:
                limiter.hit(item, identity)
            return
        reset = limiter.get_window_stats(full, identity).reset_time
    except Exception:  # noqa: BLE001 - fail open when the counter store is unreachable
        log.warning("rate limiter unavailable; request let through", exc_info=True)
        return
    RATE_LIMITED.inc()
    raise Problem(429, "rate_limited", f"more than {full} requests with this key; slow down",
                  headers={"Retry-After": str(max(1, math.ceil(reset - time.time())))})


async def count(key: ApiKey) -> None:
    """Count one request of the signed-in `key` against its rate limit (in this process's memory on the event loop; in
    Redis from a worker thread)."""
    settings = get_settings()
    if not settings.rate_limit.strip():
        return
    if storage_uri(settings).startswith("memory://"):
        check(str(key.id), settings)
    else:
        await run_in_threadpool(check, str(key.id), settings)

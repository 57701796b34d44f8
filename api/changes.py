"""Change notices: which job or key just changed, so that API processes drop what they cached and wake the event
streams of that job.

Whoever changes a job or a key (the API, a worker, the reconciler, the CLI) calls `publish` after its commit. This
process's listeners hear it at once. On a Redis broker the notice also goes out on one Redis pub/sub channel, and
every API process listens there (one thread each): caches in any process then learn of changes made in any other.
Without Redis (the embedded default) notices stay in the process that made them; `live()` is False and callers
that must see other processes' changes read the database instead.

A notice can be lost (a publisher dies between its commit and its publish, the subscription drops): caches keep a
short time-to-live as the safety net, and a (re)subscription announces `reset` so that they start empty.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from functools import lru_cache
from typing import Any, Literal

from api.settings import get_settings

log = logging.getLogger("rigforge.changes")
CHANNEL = "rigforge:changes"
Kind = Literal["job", "key", "reset"]
Listener = Callable[[Kind, str], None]
PUBLISH_TIMEOUT_SECONDS = 0.5
PUBLISH_BACKOFF_SECONDS = 5.0  # after a failed publish, skip Redis this long (a worker must not stall on it)
RETRY_SECONDS = 1.0
_listeners: list[Listener] = []  # process-wide: they outlive a reset of the settings (tests switch services)
_listeners_lock = threading.Lock()


def listen(listener: Listener) -> None:
    """Call `listener(kind, id)` on every notice, from whichever thread hears it (keep it short, never blocking)."""
    with _listeners_lock:
        if listener not in _listeners:
            _listeners.append(listener)


def _dispatch(kind: Kind, ident: str) -> None:
    for listener in list(_listeners):
        try:
            listener(kind, ident)
        except Exception:  # noqa: BLE001 - one broken listener must not starve the others
            log.exception("change listener failed")


class Notices:
    """Publishes and hears change notices; `redis_url` None keeps them in this process."""

    def __init__(self, redis_url: str | None) -> None:
        self.redis_url = redis_url
        self._lock = threading.Lock()
        self._live = threading.Event()
        self._stopped = threading.Event()
        self._thread: threading.Thread | None = None
        self._publisher: Any = None
        self._publish_paused_until = 0.0

    def live(self) -> bool:
        """True while notices from every process reach this one (subscribed to Redis)."""
        return self._live.is_set()

    def publish(self, kind: Literal["job", "key"], ident: object) -> None:
        """Announce that the job or key `ident` changed (after the change is committed). Never raises."""
        text = str(ident)
        _dispatch(kind, text)
        if self.redis_url is None or time.monotonic() < self._publish_paused_until:
            return
        try:
            if self._publisher is None:
                import redis

                self._publisher = redis.Redis.from_url(self.redis_url, socket_timeout=PUBLISH_TIMEOUT_SECONDS,
                                                       socket_connect_timeout=PUBLISH_TIMEOUT_SECONDS)
            self._publisher.publish(CHANNEL, f"{kind}:{text}")
        except Exception:  # noqa: BLE001 - caches expire on their own; the change itself is committed
            self._publish_paused_until = time.monotonic() + PUBLISH_BACKOFF_SECONDS
            log.warning("could not publish a %s change notice; caches catch up within their time-to-live", kind, exc_info=True)

    def start(self) -> None:
        """Subscribe (a daemon thread) when notices go through Redis; idempotent."""
        if self.redis_url is None or self._thread is not None:
            return
        with self._lock:
            if self._thread is not None:
                return
            self._thread = threading.Thread(target=self._subscribe_forever, name="change-notices", daemon=True)
            self._thread.start()

    def stop(self) -> None:
        self._stopped.set()
        if self._thread is not None:
            self._thread.join(5)

    def _subscribe_forever(self) -> None:
        import redis

        while not self._stopped.is_set():
            pubsub = None
            try:
                client = redis.Redis.from_url(self.redis_url or "", socket_connect_timeout=2, socket_keepalive=True,
                                              health_check_interval=10)
                pubsub = client.pubsub()
                pubsub.subscribe(CHANNEL)
                while not self._stopped.is_set():
                    message = pubsub.get_message(timeout=1.0)
                    if message is None:
                        continue
                    if message["type"] == "subscribe":
                        _dispatch("reset", "")  # whatever was cached before may have missed notices
                        self._live.set()
                    elif message["type"] == "message":
                        kind, _, ident = message["data"].decode().partition(":")
                        if kind == "job" or kind == "key":
                            _dispatch(kind, ident)
            except Exception:  # noqa: BLE001 - Redis away: serve uncached until it is back
                if self._live.is_set():
                    log.warning("change notices lost their Redis subscription; serving uncached until it is back", exc_info=True)
            finally:
                self._live.clear()
                if pubsub is not None:
                    try:
                        pubsub.close()
                    except Exception:  # noqa: BLE001
                        pass
            _dispatch("reset", "")
            self._stopped.wait(RETRY_SECONDS)


def _redis_url() -> str | None:
    url = get_settings().broker_url
    return url if url.startswith(("redis://", "rediss://")) else None


@lru_cache
def notices() -> Notices:
    """This process's notices (Redis pub/sub on a Redis broker, else in-process only)."""
    return Notices(_redis_url())


def publish(kind: Literal["job", "key"], ident: object) -> None:
    """Announce a committed change of job or key `ident` (see `Notices.publish`)."""
    notices().publish(kind, ident)


def heard(kind: Literal["job", "key"], ident: object) -> None:
    """Tell this process's listeners of a change found some other way (a database read), without publishing it."""
    _dispatch(kind, str(ident))


def reset() -> None:
    """Stop this process's subscription and forget it (the settings changed); listeners hear `reset`."""
    if notices.cache_info().currsize:
        notices().stop()
    notices.cache_clear()
    _dispatch("reset", "")

"""A small in-process cache whose entries die of old age or of a change notice (api.changes), whichever comes first.

A value read from the database is stored only if no notice about its entry (and no reset) arrived since the read
began: take a `token()` before reading and `put(key, value, token)` after, and a change committed meanwhile can
never be hidden behind the value read before it. Thread-safe: notices arrive on other threads than requests.
"""

from __future__ import annotations

import threading
import time
from collections import OrderedDict
from typing import Generic, TypeVar

K = TypeVar("K")
V = TypeVar("V")


class NoticeCache(Generic[K, V]):
    """At most `max_entries` values, each for at most `ttl` seconds (0: nothing is kept)."""

    def __init__(self, ttl: float, max_entries: int = 10_000) -> None:
        self.ttl, self.max_entries = ttl, max_entries
        self._entries: OrderedDict[K, tuple[float, V]] = OrderedDict()
        self._changed: OrderedDict[K, int] = OrderedDict()  # recent notices: key -> the sequence number they got
        self._seq = 0
        self._cleared_at = 0
        self._lock = threading.Lock()

    def get(self, key: K) -> V | None:
        """The value while it is younger than the time-to-live and no notice dropped it."""
        entry = self._entries.get(key)
        if entry is None:
            return None
        if time.monotonic() - entry[0] > self.ttl:
            with self._lock:
                if self._entries.get(key) is entry:
                    del self._entries[key]
            return None
        return entry[1]

    def token(self) -> int:
        """Take before reading what `put` will store."""
        return self._seq

    def unchanged_since(self, key: K, token: int) -> bool:
        """No notice about `key` and no reset since `token` was taken."""
        return self._cleared_at <= token and self._changed.get(key, -1) <= token

    def put(self, key: K, value: V, token: int) -> None:
        """Keep `value` unless `key` changed (or everything was cleared) since `token`."""
        if self.ttl <= 0:
            return
        with self._lock:
            if not self.unchanged_since(key, token):
                return
            self._entries[key] = (time.monotonic(), value)
            self._entries.move_to_end(key)
            while len(self._entries) > self.max_entries:
                self._entries.popitem(last=False)

    def drop(self, key: K) -> None:
        """A notice: `key` changed."""
        with self._lock:
            self._seq += 1
            self._entries.pop(key, None)
            self._changed[key] = self._seq
            self._changed.move_to_end(key)
            while len(self._changed) > self.max_entries:  # a read outliving this many later notices is not stored
                _, seq = self._changed.popitem(last=False)
                self._cleared_at = max(self._cleared_at, seq)

    def clear(self) -> None:
        """Everything may have changed (a reset, or a notice that names no single entry)."""
        with self._lock:
            self._seq += 1
            self._cleared_at = self._seq
            self._entries.clear()
            self._changed.clear()

    def __len__(self) -> int:
        return len(self._entries)

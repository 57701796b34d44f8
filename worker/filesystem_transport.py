"""kombu's filesystem:// transport, polled from Celery's event loop so that the worker uses the per-process pool.

Why: Celery runs a transport without event-loop support (kombu's filesystem transport) with billiard's blocking
pool, whose processes share one job pipe guarded by a process-shared lock that an idle process holds while it
waits for the next job. A SIGKILL of an idle pool process (the OOM killer, an operator) leaves that lock taken
for good: every later pool process blocks on it, and the worker takes no job again until restarted. Polling
the queue folder from the event loop lets Celery use its asynchronous pool instead, which gives each process
its own pipes: a killed process takes nothing with it but its own job, which Celery re-queues.
"""

from __future__ import annotations

from typing import Any

from kombu.transport import filesystem


class Transport(filesystem.Transport):
    """The filesystem transport, plus a timer on the worker's event loop that delivers what the folder holds."""

    implements = filesystem.Transport.implements.extend(asynchronous=True)

    def register_with_event_loop(self, connection: Any, loop: Any) -> None:
        loop.call_repeatedly(self.polling_interval or 1.0, self._deliver_waiting, connection)

    def _deliver_waiting(self, connection: Any) -> None:
        """Deliver messages until the queue is empty or the consumers' prefetch is full; never sleeps."""
        try:
            while True:
                self.drain_events(connection, timeout=0)
        except TimeoutError:
            pass

"""Prometheus `/metrics`: job counts by status, queue depth, live workers, stage durations, webhook backlog.

Job figures are read from the database at scrape time (the job rows are the one source of truth, and every API
replica then reports the same values). Stage durations are a gauge histogram over the jobs that succeeded in the
last hour (it falls as jobs age out, which a counter histogram may not). Counters of refused requests are per process.
"""

from __future__ import annotations

from collections.abc import Iterator
from datetime import timedelta

from fastapi import APIRouter, Response
from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, ProcessCollector, generate_latest
from prometheus_client.core import GaugeHistogramMetricFamily, GaugeMetricFamily, Metric
from prometheus_client.registry import Collector
from sqlalchemy import func, select

from api.db import session_scope
from api.models import Job, WebhookDelivery, Worker, utcnow
from api.settings import get_settings

STATUSES = ("queued", "running", "succeeded", "failed", "canceled")
STAGE_BUCKETS = (0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0, 60.0, 120.0, 300.0, 600.0, 1800.0)
STAGE_WINDOW = timedelta(hours=1)
STAGE_WINDOW_JOBS = 5000  # bounds one scrape's work
WORKER_SEEN_BEATS = 3  # a worker missing this many heartbeats is not counted...
WORKER_SEEN_MIN_SECONDS = 15.0  # ...nor sooner than this: a loaded database may delay one beat by seconds


def stage_histogram(durations: list[float]) -> tuple[list[tuple[str, float]], float]:
    """Cumulative (le, count) buckets ending with +Inf, and the sum, of `durations` (seconds)."""
    buckets = [(str(bound), float(sum(d <= bound for d in durations))) for bound in STAGE_BUCKETS]
    return [*buckets, ("+Inf", float(len(durations)))], float(sum(durations))


class JobsCollector(Collector):
    """Reads the job, worker and delivery tables at scrape time."""

    def collect(self) -> Iterator[Metric]:
        t = utcnow()
        seen_after = t - timedelta(seconds=max(WORKER_SEEN_BEATS * get_settings().jobs.heartbeat_seconds, WORKER_SEEN_MIN_SECONDS))
        with session_scope() as session:
            by_status: dict[str, int] = {status: count for status, count in session.execute(
                select(Job.status, func.count()).group_by(Job.status))}
            oldest_queued = session.scalar(select(func.min(Job.created_at)).where(Job.status == "queued"))
            workers = session.execute(select(func.count(), func.coalesce(func.sum(Worker.concurrency), 0))
                                      .where(Worker.last_seen_at > seen_after)).one()
            deliveries: dict[str, int] = {status: count for status, count in session.execute(
                select(WebhookDelivery.status, func.count()).group_by(WebhookDelivery.status))}
            timings = session.scalars(select(Job.timings).where(Job.status == "succeeded", Job.finished_at > t - STAGE_WINDOW,
                                                               Job.timings.is_not(None))
                                      .order_by(Job.finished_at.desc()).limit(STAGE_WINDOW_JOBS)).all()
        jobs = GaugeMetricFamily("rigforge_jobs", "Jobs by status", labels=["status"])
        for status in STATUSES:
            jobs.add_metric([status], by_status.get(status, 0))
        yield jobs
        yield GaugeMetricFamily("rigforge_queue_depth", "Jobs queued and not yet claimed by a worker", value=by_status.get("queued", 0))
        age = (t - oldest_queued).total_seconds() if oldest_queued is not None else 0.0
        yield GaugeMetricFamily("rigforge_oldest_queued_seconds", "Age of the oldest queued job", value=age)
        yield GaugeMetricFamily("rigforge_workers", "Worker processes heard from recently", value=workers[0])
        yield GaugeMetricFamily("rigforge_worker_slots", "Jobs the live workers can run at once", value=workers[1])
        backlog = GaugeMetricFamily("rigforge_webhook_deliveries", "Webhook deliveries by status", labels=["status"])
        for status in ("pending", "delivered", "failed"):
            backlog.add_metric([status], deliveries.get(status, 0))
        yield backlog
        per_stage: dict[str, list[float]] = {}
        for timing in timings:
            for stage, seconds in (timing or {}).items():
                per_stage.setdefault(stage, []).append(float(seconds))
        stages = GaugeHistogramMetricFamily("rigforge_stage_duration_seconds", "Pipeline stage durations of the jobs that "
                                            "succeeded in the last hour", labels=["stage"])
        for stage, durations in sorted(per_stage.items()):
            buckets, total = stage_histogram(durations)
            stages.add_metric([stage], buckets, total)
        yield stages


REGISTRY = CollectorRegistry()
ProcessCollector(registry=REGISTRY)
REGISTRY.register(JobsCollector())
RATE_LIMITED = Counter("rigforge_rate_limited_requests", "Requests refused by the per-key rate limit", registry=REGISTRY)
QUOTA_REFUSED = Counter("rigforge_quota_refused_submissions", "Submissions refused by a per-key quota", ["quota"], registry=REGISTRY)

router = APIRouter(tags=["health"])


@router.get("/metrics", summary="Prometheus metrics (text exposition format)", response_class=Response)
def get_metrics() -> Response:
    return Response(generate_latest(REGISTRY), media_type=CONTENT_TYPE_LATEST)

"""All service settings: one pydantic-settings object, environment variables prefixed RIGFORGE_."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, Field, SecretStr, field_validator, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from simcore.budgets import Budgets


class JobSettings(BaseModel):
    """Durability knobs of the job system (RIGFORGE_JOBS__<NAME>)."""

    lease_seconds: float = Field(15.0, gt=0, description="a running job whose lease is older than this is presumed lost (its "
                                 "whole worker died): it is retried within lease_seconds + reconcile_seconds")
    heartbeat_seconds: float = Field(3.0, gt=0, description="how often a worker renews its lease (5 missed renewals lose it)")
    max_attempts: int = Field(3, ge=1, description="deliveries before a lost job fails with worker_lost")
    soft_time_limit: int = Field(3300, gt=0, description="seconds before a job is asked to stop (fails with timeout)")
    time_limit: int = Field(3600, gt=0, description="seconds before the worker process running a job is killed")
    reconcile_seconds: float = Field(2.0, gt=0, description="period of the reconciler that re-queues lost jobs")
    requeue_after_seconds: float = Field(120.0, gt=0, description="re-send a queued job whose message may be lost")
    worker_stall_seconds: float = Field(60.0, gt=0, description="serve restarts its embedded worker when a job waits queued this "
                                        "long with none running")
    worker_check_seconds: float = Field(5.0, gt=0, description="how often serve checks its embedded worker")
    worker_nice: int = Field(10, ge=0, le=19, description="CPU priority (nice) of serve's embedded worker below the API: on one "
                             "machine requests are answered first and jobs take the CPU time left")


class WebhookSettings(BaseModel):
    """Webhook deliveries (RIGFORGE_WEBHOOKS__<NAME>)."""

    timeout_seconds: float = Field(10.0, gt=0, description="one POST to a callback URL gives up after this long")
    max_attempts: int = Field(8, ge=1, description="attempts before a delivery is marked failed")
    backoff_seconds: float = Field(10.0, gt=0, description="wait before the first retry; doubled on each further one")
    backoff_max_seconds: float = Field(3600.0, gt=0, description="longest wait between two attempts")
    poll_seconds: float = Field(1.0, gt=0, description="how often a worker looks for deliveries that are due")


class QuotaSettings(BaseModel):
    """Per-key limits when the key sets none of its own (RIGFORGE_QUOTAS__<NAME>; 0 = unlimited)."""

    concurrent_jobs: int = Field(20, ge=0, description="jobs queued or running at once")
    jobs_per_hour: int = Field(500, ge=0, description="jobs submitted in any 60 minutes")
    storage_mb: float = Field(51200.0, ge=0, description="uploads and artifacts kept")


class Settings(BaseSettings):
    """Service configuration; every field is documented in the README."""

    model_config = SettingsConfigDict(env_prefix="RIGFORGE_", env_nested_delimiter="__", extra="ignore")

    env: Literal["development", "production"] = "development"
    data_dir: Path = Field(Path(".rigforge"), description="database, broker queue and file storage of the embedded default")
    database_url: str | None = Field(None, description="SQLAlchemy URL; default sqlite in data_dir")
    broker_url: str = Field("filesystem://", description="Celery broker; filesystem:// keeps the queue in data_dir")
    max_upload_mb: float = Field(200.0, gt=0, description="hard cap on one upload request body")
    max_vertices: int = Field(2_000_000, gt=0, description="meshes with more vertices are refused")
    mpm_max_particles: int = Field(30_000, gt=0, description="particle budget of physics refinement per job")
    max_parallel_parses: int = Field(2, gt=0, description="glTF uploads the API checks at once (each costs a few times its size)")
    storage_url: str | None = Field(None, pattern=r"^s3://[^/]+(/.*)?$",
                                    description="s3://bucket/prefix for S3-compatible object storage; default local files in data_dir")
    s3_endpoint_url: str | None = Field(None, description="S3 endpoint other than AWS (MinIO, Ceph, R2); credentials from AWS_* variables")
    s3_public_endpoint_url: str | None = Field(None, description="endpoint browsers reach, for presigned download URLs (default s3_endpoint_url)")
    signing_key: SecretStr | None = Field(None, description="HMAC key of signed download URLs; default a random key kept in data_dir "
                                          "(set it when API replicas do not share data_dir)")
    download_url_seconds: int = Field(900, gt=0, le=7 * 24 * 3600, description="how long a signed download URL stays valid")
    host: str = "127.0.0.1"
    port: int = 8000
    jobs: JobSettings = Field(default_factory=JobSettings)
    webhooks: WebhookSettings = Field(default_factory=WebhookSettings)
    quotas: QuotaSettings = Field(default_factory=QuotaSettings)
    retention_days: float = Field(0.0, ge=0, description="finished jobs older than this are deleted with their files; 0 keeps them")
    cleanup_seconds: float = Field(3600.0, gt=0, description="period of the cleanup (retention and orphaned files) in each worker")
    orphan_grace_seconds: float = Field(3600.0, gt=0, description="an upload no job refers to is deleted once it is this old")
    rate_limit: str = Field("100/second;3000/minute", description="requests per API key, in the `limits` notation ('N/period;...')")
    rate_limit_storage: str | None = Field(None, description="where API replicas share rate-limit counters (redis://...); "
                                           "default the Redis broker, else this process's memory")
    auth_cache_seconds: float = Field(10.0, ge=0, description="an API process trusts a key it verified this long (0: check every "
                                      "request); revoking a key over HTTP or with Redis notices ends it at once")
    job_cache_seconds: float = Field(5.0, ge=0, description="on a Redis broker an API process answers a job from memory this long "
                                     "at most (0: never); every change of the job ends it at once")
    log_format: Literal["text", "json"] = Field("text", description="json: one JSON object per log line, with job_id where known")
    budgets: Budgets = Field(default_factory=Budgets, description="per-job time, memory and sampling budgets")

    @field_validator("rate_limit")
    @classmethod
    def _rate_limit_parses(cls, value: str) -> str:
        if value.strip():
            from limits import parse_many

            parse_many(value)  # ValueError names the item it cannot read
        return value

    @model_validator(mode="after")
    def _resolve(self) -> Settings:
        self.data_dir = self.data_dir.expanduser().resolve()
        if self.env == "production" and (self.database_url is None or self.database_url.startswith("sqlite")):
            raise ValueError("RIGFORGE_DATABASE_URL must name a server database in production")
        return self

    @property
    def sqlalchemy_url(self) -> str:
        return self.database_url or f"sqlite:///{self.data_dir / 'rigforge.db'}"

    @property
    def storage_dir(self) -> Path:
        return self.data_dir / "storage"

    @property
    def broker_dir(self) -> Path:
        return self.data_dir / "broker"

    @property
    def local_key_file(self) -> Path:
        return self.data_dir / "local-api-key"

    @property
    def max_upload_bytes(self) -> int:
        return int(self.max_upload_mb * 1024 * 1024)


@lru_cache
def get_settings() -> Settings:
    """The process-wide settings (tests clear this cache after changing the environment)."""
    return Settings()

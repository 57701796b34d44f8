"""The S3-compatible server of the S3 storage tests (moto's, started by scripts/s3-up.sh from .ci/run).

In CI an unreachable server fails the test instead of skipping it, as for PostgreSQL and Redis.
"""

from __future__ import annotations

import os
import uuid
from typing import Any

import pytest

S3_ENDPOINT = os.environ.get("RIGFORGE_TEST_S3_ENDPOINT", f"http://127.0.0.1:{os.environ.get('RIGFORGE_TEST_S3_PORT', '9000')}")
CREDENTIALS = {"AWS_ACCESS_KEY_ID": "rigforge-test", "AWS_SECRET_ACCESS_KEY": "rigforge-test-secret", "AWS_DEFAULT_REGION": "us-east-1"}


def s3_client() -> Any:
    import boto3

    return boto3.client("s3", endpoint_url=S3_ENDPOINT, aws_access_key_id=CREDENTIALS["AWS_ACCESS_KEY_ID"],
                        aws_secret_access_key=CREDENTIALS["AWS_SECRET_ACCESS_KEY"], region_name=CREDENTIALS["AWS_DEFAULT_REGION"])


def new_bucket() -> str:
    """A fresh bucket on the test server; skips (fails in CI) when the server is down."""
    from botocore.exceptions import EndpointConnectionError

    name = f"rigforge-test-{uuid.uuid4().hex[:12]}"
    try:
        s3_client().create_bucket(Bucket=name)
    except EndpointConnectionError:
        message = f"no S3-compatible server at {S3_ENDPOINT} (run scripts/s3-up.sh)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    return name


def bucket_keys(bucket: str) -> list[str]:
    pages = s3_client().get_paginator("list_objects_v2").paginate(Bucket=bucket)
    return [item["Key"] for page in pages for item in page.get("Contents", [])]


def drop_bucket(bucket: str) -> None:
    """Delete a test bucket and what it holds (the server keeps objects in memory)."""
    client = s3_client()
    keys = bucket_keys(bucket)
    for start in range(0, len(keys), 1000):
        client.delete_objects(Bucket=bucket, Delete={"Objects": [{"Key": k} for k in keys[start:start + 1000]]})
    client.delete_bucket(Bucket=bucket)

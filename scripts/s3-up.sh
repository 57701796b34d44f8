#!/usr/bin/env bash
# Start the S3-compatible server the S3 storage tests use (moto's server, from the `test` extra), if it is not running.
# Why moto: MinIO ships no Debian or PyPI package (only binaries from its own site); moto installs from PyPI
# and speaks S3's REST protocol over HTTP (multipart uploads, presigned URLs, listing, batch delete).
set -euo pipefail
cd "$(dirname "$0")/.."
PORT="${RIGFORGE_TEST_S3_PORT:-9000}"
if ! curl -s -o /dev/null "http://127.0.0.1:${PORT}/"; then
  nohup .venv/bin/moto_server -H 127.0.0.1 -p "${PORT}" >"${TMPDIR:-/tmp}/rigforge-moto.log" 2>&1 &
  for _ in $(seq 30); do curl -s -o /dev/null "http://127.0.0.1:${PORT}/" && break; sleep 1; done
fi
curl -s -o /dev/null -w "S3 (moto) on 127.0.0.1:${PORT}: HTTP %{http_code}\n" "http://127.0.0.1:${PORT}/"

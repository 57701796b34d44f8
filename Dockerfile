# RigForge image: the API, the workers and the one-shot migration of docker-compose.yml run this same image.
#   docker build -t rigforge .                                                            # CPU torch (default)
#   docker build -t rigforge:cuda --build-arg TORCH_INDEX=https://download.pytorch.org/whl/cu128 .   # CUDA torch
# Stages: python-deps (a venv with torch from TORCH_INDEX, the dependencies and the editable package; it also writes
# the OpenAPI document the dashboard's types come from), web (Node builds the dashboard; no Python there), runtime
# (slim Python, Debian's Node for the Khronos glTF validator, non-root).
ARG PYTHON_IMAGE=python:3.11-slim-bookworm
ARG NODE_IMAGE=node:22-bookworm-slim

FROM ${PYTHON_IMAGE} AS python-deps
ARG TORCH_INDEX=https://download.pytorch.org/whl/cpu
ENV PIP_NO_CACHE_DIR=1 PIP_DISABLE_PIP_VERSION_CHECK=1 PATH=/opt/venv/bin:$PATH
RUN python -m venv /opt/venv && pip install --index-url "$TORCH_INDEX" torch==2.13.0
WORKDIR /app
COPY pyproject.toml ./
# the dependencies first, in their own layer: a source change does not download them again
RUN python -c "import tomllib; print('\n'.join(tomllib.load(open('pyproject.toml', 'rb'))['project']['dependencies']))" > /tmp/requirements.txt \
    && pip install -r /tmp/requirements.txt
COPY api api
COPY worker worker
COPY simcore simcore
COPY cli cli
COPY migrations migrations
COPY web/dump_openapi.py web/dump_openapi.py
RUN pip install --no-deps -e . && python web/dump_openapi.py web/openapi.json

FROM ${NODE_IMAGE} AS web
WORKDIR /app
COPY package.json package-lock.json ./
RUN npm ci --no-audit --no-fund
COPY web web
COPY --from=python-deps /app/web/openapi.json web/openapi.json
RUN npm run build:types && npm run build:web

FROM ${PYTHON_IMAGE} AS runtime
RUN apt-get update && apt-get install -y --no-install-recommends nodejs && rm -rf /var/lib/apt/lists/* \
    && useradd --system --uid 10001 --create-home --home-dir /home/rigforge rigforge \
    && mkdir /data && chown rigforge:rigforge /data
ENV PATH=/opt/venv/bin:$PATH RIGFORGE_DATA_DIR=/data PYTHONUNBUFFERED=1
COPY --from=python-deps /opt/venv /opt/venv
COPY --from=python-deps /app /app
COPY --from=web /app/web/dist /app/web/dist
COPY --from=web /app/node_modules/gltf-validator /app/node_modules/gltf-validator
WORKDIR /app
USER rigforge
EXPOSE 8000
CMD ["rigforge", "serve", "--no-worker", "--no-migrate", "--host", "0.0.0.0", "--port", "8000"]

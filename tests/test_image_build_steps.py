"""The Dockerfile, checked here where no image can be built (base images and PyTorch's index are out of reach).

Its instructions are read with dockerfile-parse; the dashboard's stage then runs step by step in a clean
temporary directory: its COPYs from a context filtered by .dockerignore, the OpenAPI document it takes from the
Python stage made by that stage's own command, and its RUNs as written, with no .venv anywhere (npm reads its cache
first). What needs the base images (apt, pip installs) is checked by structure.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pathspec
import pytest
from dockerfile_parse import DockerfileParser

REPO = Path(__file__).resolve().parents[1]
CPU_INDEX = "https://download.pytorch.org/whl/cpu"


def stages() -> dict[str, list[tuple[str, str]]]:
    """(instruction, value) of each named stage, in order."""
    out: dict[str, list[tuple[str, str]]] = {}
    current: list[tuple[str, str]] | None = None
    for item in DockerfileParser(str(REPO / "Dockerfile")).structure:
        if item["instruction"] == "FROM":
            current = out.setdefault(item["value"].split()[-1], [])
        elif current is not None and item["instruction"] != "COMMENT":
            current.append((item["instruction"], item["value"]))
    return out


def ignored(relative: str, patterns: list[str]) -> bool:
    """Whether .dockerignore's `patterns` leave `relative` out (gitignore matching; for these patterns the same)."""
    return pathspec.GitIgnoreSpec.from_lines(patterns).match_file(relative)


def copy_from_context(sources: list[str], dest: Path, patterns: list[str]) -> None:
    """COPY from the build context: what .dockerignore leaves of each source."""
    for source in sources:
        path = REPO / source.rstrip("/")
        files = [path] if path.is_file() else [p for p in path.rglob("*") if p.is_file()]
        for file in files:
            relative = str(file.relative_to(REPO))
            if ignored(relative, patterns):
                continue
            target = dest / file.name if path.is_file() and (dest.is_dir() or str(dest).endswith("/")) else (
                dest / file.relative_to(path) if path.is_dir() else dest)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(file, target)


def run_stage(name: str, root: Path, env: dict[str, str], patterns: list[str], produced: dict[str, Path]) -> Path:
    """Run one stage's WORKDIR/COPY/RUN/ENV in `root` (its WORKDIR mapped under it); returns the work directory."""
    work = root
    for instruction, value in stages()[name]:
        args = shlex.split(value)
        if instruction == "WORKDIR":
            work = root / value.lstrip("/")
            work.mkdir(parents=True, exist_ok=True)
        elif instruction == "COPY" and args[0].startswith("--from="):
            stage, source = args[0].split("=", 1)[1], args[1]
            target = work / args[2]
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(produced[f"{stage}:{source}"], target)
        elif instruction == "COPY":
            copy_from_context(args[:-1], work / args[-1] if args[-1] not in ("./", ".") else work, patterns)
        elif instruction == "RUN":
            result = subprocess.run(["/bin/sh", "-c", value], cwd=work, env=env, capture_output=True, text=True, timeout=600)
            assert result.returncode == 0, f"RUN {value}\n{result.stdout[-2000:]}\n{result.stderr[-2000:]}"
        elif instruction not in ("ENV", "ARG"):
            raise AssertionError(f"this test does not know how to run {instruction} in stage {name}")
    return work


def dockerignore() -> list[str]:
    return [line.strip() for line in (REPO / ".dockerignore").read_text().splitlines() if line.strip() and not line.startswith("#")]


def test_context_leaves_out_local_state_and_builds():
    patterns = dockerignore()
    for path in (".rigforge/local-api-key", ".rigforge/rigforge.db", ".venv/bin/python", "node_modules/three/package.json",
                 ".git/HEAD", ".rigforge-train/x", "api/__pycache__/app.cpython-311.pyc", ".mypy_cache/x", "web/dist/index.html"):
        assert ignored(path, patterns), path
    for path in ("api/app.py", "package-lock.json", "web/src/main.ts", "migrations/env.py", "simcore/io/gltf_validate.mjs"):
        assert not ignored(path, patterns), path


def test_runtime_is_slim_non_root_with_cpu_torch_by_default():
    text = (REPO / "Dockerfile").read_text()
    assert re.search(rf"^ARG TORCH_INDEX={re.escape(CPU_INDEX)}$", text, re.M)
    assert 'pip install --index-url "$TORCH_INDEX" torch==2.13.0' in text
    runtime = stages()["runtime"]
    users = [v for i, v in runtime if i == "USER"]
    assert users and users[-1] not in ("root", "0")
    assert not any(i == "RUN" and ("npm" in v or "pip install" in v) for i, v in runtime)  # built in the other stages
    assert any(i == "COPY" and "--from=web" in v and "web/dist" in v for i, v in runtime)
    assert stages()["web"], "the dashboard is built in a Node stage"
    assert not any(".venv" in v for i, v in stages()["web"])


@pytest.mark.slow  # npm ci and the bundle take a minute or two; .ci/run runs it after the suite
def test_dashboard_stage_builds_in_a_clean_directory_without_a_venv(tmp_path):
    if not shutil.which("npm"):
        pytest.fail("npm is needed to build the dashboard (Node.js ≥ 18 and npm, as `make run` needs)")
    patterns = dockerignore()
    env = {k: v for k, v in os.environ.items() if not k.startswith(("VIRTUAL_ENV", "PYTHON", "RIGFORGE_"))}
    env.update(npm_config_prefer_offline="true", npm_config_update_notifier="false")
    # The Python stage's command that writes the OpenAPI document, run on a copy of what that stage copies
    python_stage = tmp_path / "python-deps"
    python_run = [v for i, v in stages()["python-deps"] if i == "RUN" and "dump_openapi" in v][0]
    for instruction, value in stages()["python-deps"]:
        if instruction == "COPY" and "pyproject" not in value:
            args = shlex.split(value)
            copy_from_context(args[:-1], python_stage / args[-1], patterns)
    dump = python_run.split("&&")[-1].strip().replace("python ", f"{sys.executable} ", 1)
    result = subprocess.run(dump, shell=True, cwd=python_stage, env={**env, "PYTHONPATH": str(python_stage)},
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    web = run_stage("web", tmp_path / "web-stage", env, patterns, {"python-deps:/app/web/openapi.json": python_stage / "web" / "openapi.json"})
    dist = web / "web" / "dist"
    assert (dist / "index.html").is_file() and (dist / "assets" / "main.js").is_file()
    assert (dist / "docs-assets" / "swagger-ui" / "swagger-ui-bundle.js").is_file()
    assert "download_url" in (web / "web" / "src" / "api" / "schema.d.ts").read_text()
    assert not list(tmp_path.rglob(".venv"))

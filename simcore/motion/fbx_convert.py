"""Optional FBX → glTF conversion through the `assimp` command-line tool (Debian package `assimp-utils`).

FBX is a closed format; we do not parse it ourselves. When the `assimp` binary is on PATH (or named by
the RIGFORGE_ASSIMP environment variable), an uploaded FBX motion is converted to GLB in a sandboxed
subprocess: an empty temporary directory as working directory, an empty environment, a wall-clock
time limit, CPU-time, address-space and file-size rlimits, no shell. Otherwise FBX is refused with
UnsupportedFormat(code="unsupported_format"), which the API maps to 415.
"""

from __future__ import annotations

import os
import resource
import shutil
import subprocess
import tempfile
from pathlib import Path

from simcore.errors import InvalidInput, UnsupportedFormat

TIME_LIMIT_S = 60
MEMORY_LIMIT_BYTES = 2 * 1024 ** 3
OUTPUT_LIMIT_BYTES = 512 * 1024 ** 2


def assimp_binary() -> str | None:
    """Path of the assimp CLI, or None when it is not installed."""
    return os.environ.get("RIGFORGE_ASSIMP") or shutil.which("assimp")


def _limits() -> None:  # runs in the child before exec
    resource.setrlimit(resource.RLIMIT_CPU, (TIME_LIMIT_S, TIME_LIMIT_S))
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))
    resource.setrlimit(resource.RLIMIT_FSIZE, (OUTPUT_LIMIT_BYTES, OUTPUT_LIMIT_BYTES))


def fbx_to_glb(data: bytes, field: str = "motion") -> bytes:
    """GLB bytes converted from FBX bytes; UnsupportedFormat without assimp, InvalidInput when it fails."""
    binary = assimp_binary()
    if binary is None:
        raise UnsupportedFormat(
            "FBX is not supported: upload BVH or a GLB/glTF with animations (or install assimp-utils on the worker)",
            code="unsupported_format", field=field,
        )
    with tempfile.TemporaryDirectory(prefix="rigforge-fbx-") as tmp:
        src, dst = Path(tmp) / "in.fbx", Path(tmp) / "out.glb"
        src.write_bytes(data)
        try:
            done = subprocess.run(
                [binary, "export", str(src), str(dst), "-f", "glb2"], cwd=tmp, env={}, capture_output=True,
                timeout=TIME_LIMIT_S, preexec_fn=_limits, check=False,
            )
        except subprocess.TimeoutExpired:
            raise InvalidInput(f"FBX conversion took longer than {TIME_LIMIT_S} s", code="conversion_timeout", field=field) from None
        if done.returncode != 0 or not dst.exists():
            tail = (done.stderr or done.stdout or b"").decode("utf-8", "replace").strip().splitlines()[-1:] or ["no output"]
            raise InvalidInput(f"FBX conversion failed: {tail[0][:200]}", code="invalid_fbx", field=field)
        return dst.read_bytes()

"""FBX export through Blender's own FBX exporter (`bpy` from PyPI), in a sandboxed subprocess.

Blender's io_scene_fbx writes binary FBX 7.4 with mesh, UVs, materials and embedded textures, the armature,
skin clusters and baked animation; it is what Unity and Unreal pipelines receive from Blender every day.
assimp 5.2's FBX exporter was tried and rejected: neither assimp itself nor Blender can read back what it
writes ("block offset is out of range"). We never encode FBX ourselves.

The writer is optional. bpy 5.0.1 needs Python 3.11 and numpy<2 (~1 GB installed), so it lives in its own venv,
not the worker's (numpy 2): its interpreter is RIGFORGE_BLENDER_PYTHON, else `.venv-fbx/bin/python` in the
checkout (`make fbx-writer`), else the worker's own interpreter when it can import bpy. It runs
`fbx_blender_script.py` on our validated GLB with a wall-clock limit, CPU-time, address-space and file-size
rlimits, an empty temporary working directory and a minimal environment; bpy is never imported into the worker.

The file's unit and axes (`FbxFrame`) come from `options.fbx`: presets `unity` (metres, Y up: Unity shows
"1m (File)" and scale 1) and `unreal` (centimetres, Unreal's unit, Z up: no axis conversion on import), or `units`
and `up_axis` given one by one; the default is centimetres, Y up, Blender's own FBX default. In every case the
data is written in that frame and every root node is identity.
"""

from __future__ import annotations

import importlib.util
import os
import resource
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from simcore.errors import InvalidInput
from simcore.options import FbxOptions

SCRIPT = Path(__file__).with_name("fbx_blender_script.py")
LOCAL_VENV_PYTHON = Path(__file__).resolve().parents[2] / ".venv-fbx" / "bin" / "python"
TIME_LIMIT_S = 120
MEMORY_LIMIT_BYTES = 8 * 1024 ** 3  # bpy maps ~2 GB of address space before it reads anything
OUTPUT_LIMIT_BYTES = 1024 ** 3


@dataclass(frozen=True)
class FbxFrame:
    """units: the file's unit (m: UnitScaleFactor 100, cm: 1). up_axis: y (Y up, facing +Z, as glTF) or z (Z up,
    facing -Y); both right-handed, as FBX's Maya Y-up and Max Z-up axis systems."""

    units: Literal["m", "cm"] = "cm"
    up_axis: Literal["y", "z"] = "y"


PRESETS = {"unity": FbxFrame("m", "y"), "unreal": FbxFrame("cm", "z")}


def fbx_frame(option: bool | FbxOptions) -> FbxFrame | None:
    """The frame `options.fbx` asks for (None: no FBX): its preset's, with `units` / `up_axis` given overriding it."""
    if option is False:
        return None
    if option is True:
        return FbxFrame()
    base = PRESETS[option.preset] if option.preset else FbxFrame()
    return FbxFrame(option.units or base.units, option.up_axis or base.up_axis)


@dataclass
class FbxExport:
    """path: the written file. seconds: wall-clock time of the Blender run. writer: what wrote it. frame: its unit
    and axes."""

    path: Path
    seconds: float
    writer: str
    frame: FbxFrame


def blender_python() -> str | None:
    """The interpreter that runs the FBX writer, or None when no `bpy` is installed."""
    configured = os.environ.get("RIGFORGE_BLENDER_PYTHON")
    if configured:
        return configured if Path(configured).is_file() else None
    if LOCAL_VENV_PYTHON.is_file():
        return str(LOCAL_VENV_PYTHON)
    return sys.executable if importlib.util.find_spec("bpy") is not None else None


def _limits() -> None:  # runs in the child before exec
    resource.setrlimit(resource.RLIMIT_CPU, (TIME_LIMIT_S, TIME_LIMIT_S))
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT_BYTES, MEMORY_LIMIT_BYTES))
    resource.setrlimit(resource.RLIMIT_FSIZE, (OUTPUT_LIMIT_BYTES, OUTPUT_LIMIT_BYTES))


def write_fbx(glb_path: Path, fbx_path: Path, fps: float = 30.0, frame: FbxFrame = FbxFrame()) -> FbxExport:
    """Convert our rigged or animated GLB into FBX at `fbx_path` (animation baked at `fps`, a whole number), in
    `frame`'s unit and axes.

    Raises InvalidInput(code="fbx_unavailable") without a writer, code="export_failed" when Blender fails.
    """
    python = blender_python()
    if python is None:
        raise InvalidInput("FBX export needs Blender's bpy: run `make fbx-writer` or set RIGFORGE_BLENDER_PYTHON",
                           code="fbx_unavailable", field="fbx")
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="rigforge-fbx-out-") as tmp:
        src, dst = Path(tmp) / "in.glb", Path(tmp) / "out.fbx"
        src.write_bytes(Path(glb_path).read_bytes())
        env = {"PATH": "/usr/bin:/bin", "HOME": tmp, "PYTHONNOUSERSITE": "1"}
        try:
            command = [python, str(SCRIPT), str(src), str(dst), str(int(round(fps))), frame.units, frame.up_axis]
            done = subprocess.run(command, cwd=tmp, env=env, capture_output=True, timeout=TIME_LIMIT_S, preexec_fn=_limits, check=False)
        except subprocess.TimeoutExpired:
            raise InvalidInput(f"FBX export took longer than {TIME_LIMIT_S} s", code="export_failed", field="fbx") from None
        if done.returncode != 0 or not dst.is_file():
            tail = (done.stderr or done.stdout or b"").decode("utf-8", "replace").strip().splitlines()[-1:] or ["no output"]
            raise InvalidInput(f"FBX export failed: {tail[0][:300]}", code="export_failed", field="fbx")
        Path(fbx_path).write_bytes(dst.read_bytes())
    return FbxExport(Path(fbx_path), round(time.perf_counter() - started, 3), "Blender io_scene_fbx (bpy)", frame)

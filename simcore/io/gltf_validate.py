"""The Khronos glTF validator (npm `gltf-validator`) run through Node on files we wrote.

Install once at the repository root with `npm ci` (or `npm install`): package.json pins the version.
Elsewhere, point RIGFORGE_GLTF_VALIDATOR at the package folder (…/node_modules/gltf-validator) and
RIGFORGE_NODE at the node binary when it is not on PATH.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from dataclasses import dataclass, field
from pathlib import Path

from simcore.errors import SimcoreError

RUNNER = Path(__file__).with_name("gltf_validate.mjs")
TIMEOUT_S = 300


class ValidatorUnavailable(SimcoreError):
    """Node or the validator package is not installed (a setup problem, not a bad file)."""

    code = "validator_unavailable"


@dataclass
class ValidationResult:
    """One file's outcome. `messages` holds the error and warning entries (code, message, pointer)."""

    path: str
    errors: int
    warnings: int
    infos: int = 0
    hints: int = 0
    messages: list[dict] = field(default_factory=list)
    validator: str = ""

    @property
    def ok(self) -> bool:
        return self.errors == 0

    def summary(self) -> dict:
        """JSON-ready form for report.json (at most 20 messages)."""
        return {"validator": self.validator, "errors": self.errors, "warnings": self.warnings,
                "infos": self.infos, "hints": self.hints, "messages": self.messages[:20]}


def validator_package_dir() -> Path:
    """Folder of the installed gltf-validator package; raises ValidatorUnavailable when absent."""
    env = os.environ.get("RIGFORGE_GLTF_VALIDATOR")
    candidates = [Path(env)] if env else [  # an explicit setting is the only place looked at
        parent / "node_modules" / "gltf-validator"
        for base in (Path(__file__).resolve(), Path.cwd() / "x") for parent in base.parents
    ]
    for candidate in candidates:
        if (candidate / "package.json").is_file():
            return candidate
    raise ValidatorUnavailable(
        "npm package gltf-validator not found: run `npm ci` at the repository root "
        "or set RIGFORGE_GLTF_VALIDATOR to its folder")


def node_binary() -> str:
    """Path of `node`; raises ValidatorUnavailable when absent."""
    node = os.environ.get("RIGFORGE_NODE") or shutil.which("node")
    if not node:
        raise ValidatorUnavailable("node is not installed (needed for the Khronos glTF validator)")
    return node


def validate_gltf_files(paths: list[Path]) -> list[ValidationResult]:
    """Validate GLB/.gltf files in one Node process; one result per path, in order."""
    if not paths:
        return []
    package = validator_package_dir()
    cmd = [node_binary(), str(RUNNER), str(package), *[str(p) for p in paths]]
    try:
        done = subprocess.run(cmd, capture_output=True, timeout=TIMEOUT_S, check=False)
    except subprocess.TimeoutExpired as exc:
        raise ValidatorUnavailable(f"glTF validator timed out after {TIMEOUT_S} s") from exc
    if done.returncode != 0:
        raise ValidatorUnavailable(f"glTF validator failed to run: {done.stderr.decode(errors='replace')[-800:]}")
    reports = json.loads(done.stdout)
    out = []
    for path, report in zip(paths, reports):
        issues = report.get("issues", {})
        messages = [
            {k: m[k] for k in ("code", "message", "pointer", "severity") if k in m}
            for m in issues.get("messages", []) if m.get("severity", 3) <= 1
        ]
        if "fatal" in report:
            messages.insert(0, {"code": "UNREADABLE", "message": report["fatal"], "severity": 0})
        out.append(ValidationResult(
            str(path), int(issues.get("numErrors", 0)), int(issues.get("numWarnings", 0)),
            int(issues.get("numInfos", 0)), int(issues.get("numHints", 0)), messages,
            str(report.get("validatorVersion", "gltf-validator")),
        ))
    return out


def validate_gltf_file(path: Path) -> ValidationResult:
    """Validate one GLB/.gltf file."""
    return validate_gltf_files([path])[0]

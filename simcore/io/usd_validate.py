"""usd-core's compliance checks on a USD file (.usd/.usda/.usdc/.usdz).

usd-core ≥ 0.25 replaced `UsdUtils.ComplianceChecker` (the old `usdchecker`) with the UsdValidation
framework, which `usdchecker` now runs: we run every registered validator the same way, and fall back
to the old ComplianceChecker on older builds.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from simcore.errors import InvalidInput


@dataclass
class UsdValidationResult:
    """errors / warnings: "Identifier: message" strings; `checker` names the framework used."""

    path: str
    errors: list[str] = field(default_factory=list)
    warnings: list[str] = field(default_factory=list)
    checker: str = ""

    @property
    def ok(self) -> bool:
        return not self.errors

    def summary(self) -> dict:
        """JSON-ready form for report.json (at most 20 entries each)."""
        return {"validator": self.checker, "errors": len(self.errors), "warnings": len(self.warnings),
                "messages": (self.errors + self.warnings)[:20]}


def _validate_with_framework(stage, result: UsdValidationResult) -> None:
    from pxr import UsdValidation

    registry = UsdValidation.ValidationRegistry()
    context = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())
    for error in context.Validate(stage):
        text = f"{error.GetIdentifier()}: {error.GetMessage()}"
        if error.GetType() == UsdValidation.ValidationErrorType.Error:
            result.errors.append(text)
        elif error.GetType() == UsdValidation.ValidationErrorType.Warn:
            result.warnings.append(text)
    result.checker = "UsdValidation (all registered validators)"


def _validate_with_compliance_checker(path: Path, result: UsdValidationResult) -> None:
    from pxr import UsdUtils

    checker = UsdUtils.ComplianceChecker(arkit=False, skipARKitRootLayerCheck=False, rootPackageOnly=False)
    checker.CheckCompliance(str(path))
    result.errors += [str(e) for e in checker.GetErrors()] + [str(e) for e in checker.GetFailedChecks()]
    result.warnings += [str(w) for w in checker.GetWarnings()]
    result.checker = "UsdUtils.ComplianceChecker"


def validate_usd_file(path: Path) -> UsdValidationResult:
    """Open `path` with usd-core and run its compliance checks; a file that does not open is one error."""
    from pxr import Tf, Usd, UsdUtils

    result = UsdValidationResult(str(path))
    if not Path(path).is_file():
        raise InvalidInput(f"no such file: {path}", code="not_found", field="file")
    if hasattr(UsdUtils, "ComplianceChecker"):
        _validate_with_compliance_checker(Path(path), result)
        return result
    try:
        stage = Usd.Stage.Open(str(path))
    except Tf.ErrorException as exc:
        result.errors.append(f"Open: {exc}")
        return result
    _validate_with_framework(stage, result)
    return result

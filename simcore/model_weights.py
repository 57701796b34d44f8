"""Trained weights shipped in the repo: safetensors state dicts whose metadata carries the network sizes ("model")
and the training summary ("summary"). Read without pickle; any unreadable file is a ModelUnavailable naming it.
What is read from a file is kept per process (`cached_per_file`) until the file changes."""

from __future__ import annotations

import functools
import inspect
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, TypeVar

import torch
from safetensors import SafetensorError, safe_open
from safetensors.torch import load_file, save_file

from simcore.errors import SimcoreError


class ModelUnavailable(SimcoreError):
    """A learned model's weights cannot be read (`field`: the stage whose model it is)."""

    def __init__(self, message: str, field: str = "skinning"):
        super().__init__(message, code="model_unavailable", field=field)


class Configured(Protocol):
    """A torch module with a dataclass-like `config` that can be written as JSON."""

    config: Any

    def state_dict(self) -> dict[str, torch.Tensor]: ...


M = TypeVar("M", bound=torch.nn.Module)
R = TypeVar("R")


def cached_per_file(maxsize: int) -> Callable[[Callable[..., R]], Callable[..., R]]:
    """`functools.lru_cache` for a reader whose first argument is a file's path, keyed also by the file's modification
    time and size: a process reads a file once, and again only after it is rewritten (a model saved over an
    earlier one at the same path). The reader's own defaults and keywords apply as they are."""

    def decorate(read: Callable[..., R]) -> Callable[..., R]:
        signature = inspect.signature(read)

        @functools.lru_cache(maxsize=maxsize)
        def cached(version: tuple[int, int] | None, path: Path, *args: Any) -> R:
            return read(path, *args)

        @functools.wraps(read)
        def reader(*args: Any, **kwargs: Any) -> R:
            bound = signature.bind(*args, **kwargs)
            bound.apply_defaults()
            path = Path(bound.args[0])
            try:
                stat = path.stat()
                version: tuple[int, int] | None = (stat.st_mtime_ns, stat.st_size)
            except OSError:
                version = None  # the reader says why it cannot read the file
            return cached(version, *bound.args)

        return reader

    return decorate


def save_weights(model: Configured, path: Path, summary: dict) -> None:
    """Write the state dict as safetensors with the network sizes and `summary` as JSON metadata."""
    path.parent.mkdir(parents=True, exist_ok=True)
    state = {k: v.detach().contiguous() for k, v in model.state_dict().items()}
    save_file(state, str(path), metadata={"model": json.dumps(model.config.to_dict()), "summary": json.dumps(summary)})


@cached_per_file(maxsize=8)
def read_metadata(path: Path, what: str, field: str) -> dict[str, dict]:
    """The file's JSON metadata {"model": sizes, "summary": training figures}; `what` names the model in errors."""
    if not path.is_file():
        raise ModelUnavailable(f"learned {what} weights not found at {path}", field=field)
    try:
        with safe_open(str(path), framework="pt") as fh:
            meta = fh.metadata() or {}
        return {key: json.loads(meta[key]) for key in ("model", "summary")}
    except (SafetensorError, OSError, KeyError, ValueError) as exc:
        raise ModelUnavailable(f"learned {what} weights at {path} are unreadable: {type(exc).__name__}: {exc}"[:300],
                               field=field) from exc


def load_weights(path: Path, what: str, field: str, build: Callable[[dict], M]) -> M:
    """The model `build(sizes)` with the file's state loaded, in eval mode."""
    sizes = read_metadata(path, what, field)["model"]
    try:
        model = build(sizes)
        model.load_state_dict(load_file(str(path)))
    except (SafetensorError, OSError, RuntimeError, TypeError) as exc:
        raise ModelUnavailable(f"learned {what} weights at {path} do not fit the model: {type(exc).__name__}: {exc}"[:300],
                               field=field) from exc
    return model.eval()
